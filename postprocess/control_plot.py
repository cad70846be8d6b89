# SPDX-License-Identifier: BSD-2-Clause
"""Deformation control: initial guess, optimised motion, target and the objective per iteration.

    nuno-control-plot OPT.h5 --target TARGET.h5 [--initial INIT.h5] [-o FILE.png]

OPT.h5 is the output file of a &control run (its /control group: keyframes
before and after, the objective and the keyframes per TAO iteration, and the
optimised motion itself); TARGET.h5 the target file it was given (nuno's
own output or a plain file with /time and /position); INIT.h5, optional, a
run of the same scene with the initial keyframes (the motion the optimiser
started from). Top row: the cloth at the last target time, initial guess
and optimised motion, each over the target (grey). Bottom row: the path of
the driven nodes (offset from rest per component; initial dashed, optimised
solid, the TAO iterates thin) and the objective per iteration.
"""

from __future__ import annotations

import numpy as np

from . import cli, plotting
from .reader import read_states

COMPONENTS = "xyz"


def path_offsets(times, offsets, t):
    """The keyframe path (piecewise linear, held outside) at times t: [len(t)][3]."""
    return np.stack([np.interp(t, times, offsets[:, c]) for c in range(3)], axis=-1)


def control_data(run):
    """The /control group of a run, or ValueError naming the file."""
    c = run.control
    need = ("keyframe_time", "keyframe_offset", "initial_offset", "objective_history", "keyframe_history")
    missing = [k for k in need if k not in c]
    if missing:
        raise ValueError(f"{run.path}: not the output of a &control run (no /control/{missing[0]})")
    return c


def _shape_panel(fig, pos, index, title, shapes, lo, hi, units):
    ax = fig.add_subplot(2, pos[0], index, projection="3d")
    for p, colour, width in shapes:
        plotting.draw_lattice(ax, p, color=colour, linewidth=width)
        ax.plot(*p[0, 0], "o", color=colour, ms=4)        # the driven corner (0, 0)
    plotting.setup_3d(ax, lo, hi, units, "iso", title=title)
    plotting.shrink_3d_box(ax)
    return ax


def build_figure(opt, target, initial=None, target_path=None):
    """The figure: opt a control run (reader.Run), target (times, positions), initial a Run or None;
    target_path, optional, the keyframe offsets [nk][3] that made a synthetic target (drawn as crosses)."""
    c = control_data(opt)
    t_tgt, x_tgt = target
    t_last = float(t_tgt[-1])
    units = opt.units()
    k_opt = opt.step_index(t_last)
    x_opt = opt.position[k_opt]
    shapes = [x_tgt[-1], x_opt]
    x_ini = None
    if initial is not None:
        x_ini = initial.position[initial.step_index(t_last)]
        shapes.append(x_ini)
    lo, hi = plotting.bounds(*shapes)
    ncols = 2 if x_ini is not None else 1
    fig = plotting.blank_figure((6.2 * max(ncols, 2), 9.0))
    grey = "0.65"
    if x_ini is not None:
        _shape_panel(fig, (2,), 1, f"initial guess at t = {t_last:g} s (blue), target (grey)",
                     [(x_tgt[-1], grey, 1.2), (x_ini, "C0", 0.7)], lo, hi, units)
    _shape_panel(fig, (ncols,), ncols, f"optimised at t = {t_last:g} s (orange), target (grey)",
                 [(x_tgt[-1], grey, 1.2), (x_opt, "C1", 0.7)], lo, hi, units)

    # The path of the driven nodes, per component.
    kt = np.asarray(c["keyframe_time"], float)
    t_end = float(opt.time[-1])
    # The keyframe times themselves among the samples: the path's corners.
    tt = np.union1d(np.linspace(0.0, max(t_end, kt[-1]), 400), kt)
    ax = fig.add_subplot(2, 2, 3)
    hist = np.asarray(c["keyframe_history"], float)
    for n, comp in enumerate(COMPONENTS):
        colour = f"C{n + 2}"
        for off in hist[1:-1]:
            ax.plot(tt, path_offsets(kt, off, tt)[:, n], color=colour, lw=0.4, alpha=0.25)
        ax.plot(tt, path_offsets(kt, np.asarray(c["initial_offset"]), tt)[:, n], "--", color=colour, lw=1.2)
        ax.plot(tt, path_offsets(kt, np.asarray(c["keyframe_offset"]), tt)[:, n], "-", color=colour, lw=1.8,
                label=f"{comp} (dashed: initial)")
        ax.plot(kt, np.asarray(c["keyframe_offset"])[:, n], "o", color=colour, ms=4)
        if target_path is not None:
            ax.plot(kt, np.asarray(target_path)[:, n], "x", color="k", ms=7,
                    label="the path that made the target" if n == 0 else None)
    for t in t_tgt[t_tgt > 0]:
        ax.axvline(t, color="0.3", lw=0.8, ls=":")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(plotting.length_label("offset of the driven nodes from rest", units))
    ax.set_title("keyframe path (dots: keyframes; dotted: target times; thin: TAO iterates)", fontsize="medium")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")

    speed = float(np.ravel(c.get("max_speed", [np.inf]))[0])
    bound = "no speed bound" if not np.isfinite(speed) else f"speed bound {speed:g} {units}/s"
    plotting.objective_panel(fig.add_subplot(2, 2, 4), c["objective_history"], units,
                             f"objective per iteration ({c.get('components', '')}; {bound})", color="C1")
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "control_plot")
    p.add_argument("run", help="output file of a &control run (.h5)")
    p.add_argument("--target", required=True, help="the target file of that run (.h5)")
    p.add_argument("--initial", default=None, help="a run of the scene with the initial keyframes (.h5)")
    cli.add_output(p, "control")
    return p


def _body(args):
    opt = cli.load_run(args.run)
    initial = cli.load_run(args.initial) if args.initial else None
    fig = build_figure(opt, read_states(args.target), initial)
    plotting.save(fig, args.output or cli.default_output(args.run, "control"), args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
