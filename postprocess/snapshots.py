"""Lattice wireframes at chosen times (in the manner of the report's Figs. 3-5).

    nuno-snapshots run.h5 --times 0 0.5 1.0 --view side -o fig3.png
"""

from __future__ import annotations

import numpy as np

from . import cli, plotting


def choose_steps(run, times=None, count: int = 4) -> list[int]:
    """Output-step indices nearest to the given times, or `count` evenly spaced."""
    if times:
        return [run.step_index(t) for t in times]
    n = min(count, run.nt)
    return [int(k) for k in np.unique(np.rint(np.linspace(0, run.nt - 1, n)).astype(int))]


def grid_columns(n: int) -> int:
    """Columns for n panels with no empty cell where a near-square grid allows one."""
    if n <= 5:
        return n
    for ncols in (4, 3, 5):
        if n % ncols == 0:
            return ncols
    return 4


def _side_axes(ax, lo, hi, units, title=None):
    """A 2-D x-z side view over the box [lo, hi], equal scales, nothing clipped."""
    pad = 0.04 * max(hi[0] - lo[0], hi[2] - lo[2], 1e-12)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[2] - pad, hi[2] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel(plotting.length_label("x", units))
    ax.set_ylabel(plotting.length_label("z", units))
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title)


def build_figure(run, steps, layout: str = "panels", view: str = "iso"):
    """The figure: one panel per step, or all steps in one coloured by time.

    The iso view is 3-D; the side view is drawn on 2-D x-z axes (a 3-D box
    seen edge-on leaves its tick labels floating below it).
    """
    units = run.units()
    shown = {k: run.position[k] for k in steps}  # only the steps shown are read
    lo, hi = plotting.bounds(*shown.values())
    side = view == "side"
    projection = None if side else "3d"
    if layout == "panels":
        n = len(steps)
        ncols = grid_columns(n)
        if side:
            w = 3.6
            h = max(1.6, min(3.6, w * (hi[2] - lo[2] + 1e-12) / (hi[0] - lo[0] + 1e-12) + 1.2))
            fig, axes = plotting.new_figure(n, ncols=ncols, panel_size=(w, h))
        else:
            fig, axes = plotting.new_figure(n, ncols=ncols, projection=projection)
        for ax, k in zip(axes, steps):
            title = f"t = {run.time[k]:g} s"
            if side:
                plotting.draw_lattice_side(ax, shown[k])
                _side_axes(ax, lo, hi, units, title)
            else:
                plotting.draw_lattice(ax, shown[k])
                plotting.setup_3d(ax, lo, hi, units, view, title=title)
                plotting.shrink_3d_box(ax)
        if not side:
            plotting.room_for_3d_labels(fig)
        return fig
    fig, (ax,) = plotting.new_figure(1, ncols=1, projection=projection, panel_size=(6.5, 5.0))
    color, mappable = plotting.time_colormap(run.time[steps[0]], run.time[steps[-1]])
    for k in steps:
        if side:
            plotting.draw_lattice_side(ax, shown[k], color=color(run.time[k]))
        else:
            plotting.draw_lattice(ax, shown[k], color=color(run.time[k]))
    if side:
        _side_axes(ax, lo, hi, units)
    else:
        plotting.setup_3d(ax, lo, hi, units, view)
    fig.colorbar(mappable, ax=ax, label="t [s]", shrink=0.7)
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "snapshots")
    p.add_argument("run", help="nuno output file (.h5)")
    p.add_argument("--times", type=float, nargs="+", default=None,
                   help="times to show (nearest output step); default: 4 evenly spaced steps")
    p.add_argument("--layout", choices=("panels", "overlay"), default="panels",
                   help="one subplot per time, or all times in one coloured by time")
    p.add_argument("--view", choices=tuple(plotting.VIEWS), default="iso",
                   help="iso: oblique; side: along y onto the x-z plane")
    cli.add_output(p, "snapshots")
    return p


def _body(args):
    run = cli.load_run(args.run)
    steps = choose_steps(run, args.times)
    fig = build_figure(run, steps, args.layout, args.view)
    plotting.save(fig, args.output or cli.default_output(args.run, "snapshots"), args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
