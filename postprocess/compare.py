# SPDX-License-Identifier: BSD-2-Clause
"""Compare runs: snapshots at a common time and the difference over time.

    nuno-compare ref.h5 other.h5 --time 1.0 -o compare.png

Prints ``max_difference <value>``: the largest node distance from the first
run over the common output times (the other runs are interpolated linearly to
the first run's output times where those differ). Runs on different lattices
of the same rest sheet are compared on the coarser lattice's nodes: at the
common nodes where the lattices are nested (N, 2N-1, 4N-3, ...: every 2nd or
4th fine node is a coarse node), else by bilinear interpolation of the finer
run over its rest lattice onto the coarser rest positions. With ``--tol`` the
exit status is 1 when max_difference exceeds it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import cli, plotting


def _axes(run):
    """Rest coordinates (xs [nx], ys [ny]) of a rectangular rest lattice, else ValueError."""
    rest = run.rest_position
    xs, ys = rest[0, :, 0], rest[:, 0, 1]
    scale = max(np.max(np.abs(rest)), 1e-300)
    regular = (np.max(np.abs(rest[..., 0] - xs[None, :])) <= 1e-9 * scale
               and np.max(np.abs(rest[..., 1] - ys[:, None])) <= 1e-9 * scale
               and np.all(np.diff(xs) > 0) and np.all(np.diff(ys) > 0))
    if not regular:
        raise ValueError(f"lattices differ: {run.path} has no rectangular rest lattice "
                         "(needed to compare different lattices)")
    return xs, ys


def _nested_stride(n_coarse: int, n_fine: int) -> int | None:
    if n_coarse > 1 and (n_fine - 1) % (n_coarse - 1) == 0:
        return (n_fine - 1) // (n_coarse - 1)
    return None


def sampler(coarse, fine):
    """A function fine-position [ny][nx][3] -> its values at coarse's rest nodes.

    Returns (function, how) with how 'same', 'nested' or 'interpolated';
    ValueError ('lattices differ: ...') when the rest sheets differ.
    """
    scale = max(np.max(np.abs(fine.rest_position)), 1e-300)
    if (coarse.nx, coarse.ny) == (fine.nx, fine.ny):
        gap = np.max(np.abs(coarse.rest_position - fine.rest_position))
        if gap > 1e-9 * scale:
            raise ValueError(f"lattices differ: rest positions of {coarse.path} and "
                             f"{fine.path} differ by up to {gap:g}")
        return (lambda pos: pos), "same"
    sx, sy = _nested_stride(coarse.nx, fine.nx), _nested_stride(coarse.ny, fine.ny)
    if sx and sy:
        sub = fine.rest_position[::sy, ::sx]
        if np.max(np.abs(sub - coarse.rest_position)) <= 1e-9 * scale:
            return (lambda pos: np.asarray(pos)[::sy, ::sx]), "nested"
    xc, yc = _axes(coarse)
    xf, yf = _axes(fine)
    slack = 1e-9 * scale
    if (xc[0] < xf[0] - slack or xc[-1] > xf[-1] + slack
            or yc[0] < yf[0] - slack or yc[-1] > yf[-1] + slack):
        raise ValueError(f"lattices differ: the rest sheet of {coarse.path} is not "
                         f"inside that of {fine.path}")

    def weights(c, f):
        k = np.clip(np.searchsorted(f, c, side="right") - 1, 0, len(f) - 2)
        w = np.clip((c - f[k]) / (f[k + 1] - f[k]), 0.0, 1.0)
        return k, w

    ix, wx = weights(xc, xf)
    iy, wy = weights(yc, yf)
    wx, wy = wx[None, :, None], wy[:, None, None]

    def bilinear(pos):
        p = np.asarray(pos)
        lower = (1 - wx) * p[iy][:, ix] + wx * p[iy][:, ix + 1]
        upper = (1 - wx) * p[iy + 1][:, ix] + wx * p[iy + 1][:, ix + 1]
        return (1 - wy) * lower + wy * upper

    return bilinear, "interpolated"


def pair_samplers(a, b):
    """(sample_a, sample_b): both runs' positions at the coarser lattice's nodes."""
    if a.nx * a.ny <= b.nx * b.ny:
        fn, _ = sampler(a, b)
        return (lambda pos: pos), fn
    fn, _ = sampler(b, a)
    return fn, (lambda pos: pos)


def check_same_lattice(runs) -> None:
    ref = runs[0]
    for run in runs[1:]:
        if (run.nx, run.ny) != (ref.nx, ref.ny):
            raise ValueError(f"lattices differ: {ref.path} is {ref.nx} x {ref.ny}, "
                             f"{run.path} is {run.nx} x {run.ny}")
        gap = np.max(np.abs(run.rest_position - ref.rest_position))
        scale = max(np.max(np.abs(ref.rest_position)), 1e-300)
        if gap > 1e-9 * scale:
            raise ValueError(f"lattices differ: rest positions of {ref.path} and "
                             f"{run.path} differ by up to {gap:g}")


def common_interval(runs) -> tuple[float, float]:
    t0 = max(float(r.time[0]) for r in runs)
    t1 = min(float(r.time[-1]) for r in runs)
    if t1 < t0:
        raise ValueError("the runs share no time interval")
    return t0, t1


def difference(ref, other, interval) -> tuple[np.ndarray, np.ndarray]:
    """(times, max node distance of `other` from `ref`) at ref's output times in interval."""
    t0, t1 = interval
    slack = 1e-9 * max(1.0, abs(t0), abs(t1))
    sel = np.nonzero((ref.time >= t0 - slack) & (ref.time <= t1 + slack))[0]
    times = ref.time[sel]
    same_times = other.nt == ref.nt and np.allclose(other.time, ref.time, rtol=0, atol=slack)
    on_ref, on_other = pair_samplers(ref, other)
    worst = np.empty(len(sel))
    for n, k in enumerate(sel):  # one step at a time: bounded memory
        pos = (other.position[int(k)] if same_times
               else other.position_at(float(np.clip(times[n], t0, t1))))
        gap = on_ref(ref.position[int(k)]) - on_other(pos)
        worst[n] = np.linalg.norm(gap, axis=-1).max()
    return times, worst


def labels(runs) -> list[str]:
    return cli.run_labels(runs)


def run_colors(n: int, overlay: bool) -> list:
    """One colour a run: the default cycle, or viridis in sweep order for an
    overlay (neighbouring values in neighbouring colours)."""
    if not overlay or n < 2:
        return [f"C{k}" for k in range(n)]
    from matplotlib import colormaps
    cmap = colormaps[plotting.CMAP]
    return [cmap(0.9 * k / (n - 1)) for k in range(n)]


def build_figure(runs, t: float, series, view: str = "iso", names=None,
                 layout: str = "auto", plane: str | None = None):
    """Snapshots of each run at time t (top: a panel each, or all in one for
    layout 'overlay', the default for more than 3 runs) and the differences
    from the first run over time (bottom). The side view is 2-D on the
    plane of largest motion (or plane)."""
    n = len(runs)
    units = runs[0].units()
    names = names or labels(runs)
    overlay = layout == "overlay" or (layout == "auto" and n > 3)
    colors = run_colors(n, overlay)
    snaps = [r.position_at(t) for r in runs]
    lo, hi = plotting.bounds(*snaps)
    side = view == "side"
    if side and plane is None:
        plane = plotting.side_plane(snaps, runs[0].rest_position)
    ntop = 1 if overlay else n
    if side:
        pw, ph = plotting.side_panel_size(lo, hi, plane, width=5.5 if overlay else 3.8)
    else:
        pw, ph = plotting.iso_panel_size(lo, hi, width=5.5 if overlay else 4.2)
    width = max(8.0, pw * ntop + (2.5 if overlay else 0.0))
    fig = plotting.blank_figure((width, ph + 3.2))
    grid = fig.add_gridspec(2, ntop, height_ratios=(ph, 3.0))
    top = []
    for k in range(ntop):
        ax = fig.add_subplot(grid[0, k], projection=None if side else "3d")
        top.append(ax)
    for k, (pos, name) in enumerate(zip(snaps, names)):
        ax = top[0] if overlay else top[k]
        label = name if overlay else None
        if side:
            plotting.draw_lattice_side(ax, pos, color=colors[k], plane=plane, label=label)
        else:
            plotting.draw_lattice(ax, pos, color=colors[k], label=label)
    for k, ax in enumerate(top):
        title = f"t = {t:g} s" if overlay else f"{names[k]}, t = {t:g} s"
        if side:
            plotting.side_axes(ax, lo, hi, units, plane, title)
            if k:
                ax.set_ylabel("")      # one vertical axis label for the row
        else:
            plotting.setup_3d(ax, lo, hi, units, view, title=title)
            plotting.shrink_3d_box(ax, plotting.iso_zoom(lo, hi) - 0.05)
    if overlay:
        top[0].legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax = fig.add_subplot(grid[1, :])
    for k, (times, dist) in enumerate(series, start=1):
        ax.plot(times, dist, color=colors[k], label=f"{names[k]} vs {names[0]}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(plotting.length_label("max node distance", units))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", ncols=2 if n > 5 else 1)
    if not side:
        plotting.room_for_3d_labels(fig)
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "compare")
    p.add_argument("runs", nargs="+", help="two or more nuno output files; the first is the reference")
    p.add_argument("--time", type=float, default=None,
                   help="time of the snapshots (default: the last common time)")
    p.add_argument("--view", choices=tuple(plotting.VIEWS), default="iso",
                   help="iso: oblique 3-D; side: 2-D on the vertical plane of the largest motion")
    p.add_argument("--plane", choices=plotting.PLANES, default=None,
                   help="the side view's plane (default: that of the largest motion)")
    p.add_argument("--layout", choices=("auto", "panels", "overlay"), default="auto",
                   help="snapshots one panel a run, or all in one coloured in order "
                        "(auto: overlay for more than 3 runs)")
    cli.add_label_options(p)
    p.add_argument("--tol", type=float, default=None,
                   help="exit 1 (after writing the figure) when max_difference exceeds this")
    p.add_argument("-o", "--output", default="compare.png", help="output file (default compare.png)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")
    return p


def _body(args):
    if len(args.runs) < 2:
        raise cli.UsageError("compare needs at least two runs")
    runs = [cli.load_run(path) for path in args.runs]
    names = cli.run_labels(runs, args.label, args.labels)   # a bad --label before any work
    for run in runs[1:]:
        pair_samplers(runs[0], run)  # 'lattices differ: ...' before any work
    interval = common_interval(runs)
    t = interval[1] if args.time is None else args.time
    if not interval[0] - 1e-12 <= t <= interval[1] + 1e-12:
        raise ValueError(f"time {t:g} outside the common interval "
                         f"[{interval[0]:g}, {interval[1]:g}]")
    series = [difference(runs[0], run, interval) for run in runs[1:]]
    worst = max(float(dist.max()) for _, dist in series)
    print(f"max_difference {worst:.17g}")
    if args.plane and args.view != "side":
        raise cli.UsageError("--plane goes with --view side")
    plotting.save(build_figure(runs, t, series, args.view, names, args.layout, args.plane),
                  args.output, args.dpi)
    if args.tol is not None:
        if not worst <= args.tol:
            raise ValueError(f"max_difference {worst:g} exceeds --tol {args.tol:g}")
        print(f"tolerance {args.tol:g} met")


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
