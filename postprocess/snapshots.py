"""Lattice wireframes at chosen times (in the manner of the report's Figs. 3-5).

    python3 -m postprocess.snapshots run.h5 --times 0 0.5 1.0 --view side -o fig3.png
"""

from __future__ import annotations

import numpy as np

from postprocess import cli, plotting


def choose_steps(run, times=None, count: int = 4) -> list[int]:
    """Output-step indices nearest to the given times, or `count` evenly spaced."""
    if times:
        return [run.step_index(t) for t in times]
    n = min(count, run.nt)
    return [int(k) for k in np.unique(np.rint(np.linspace(0, run.nt - 1, n)).astype(int))]


def build_figure(run, steps, layout: str = "panels", view: str = "iso"):
    """The figure: one 3-D panel per step, or all steps in one coloured by time."""
    units = run.units()
    shown = {k: run.position[k] for k in steps}  # only the steps shown are read
    lo, hi = plotting.bounds(*shown.values())
    if layout == "panels":
        fig, axes = plotting.new_figure(len(steps), projection="3d")
        for ax, k in zip(axes, steps):
            plotting.draw_lattice(ax, shown[k])
            plotting.setup_3d(ax, lo, hi, units, view, title=f"t = {run.time[k]:g} s")
        return fig
    fig, (ax,) = plotting.new_figure(1, ncols=1, projection="3d", panel_size=(6.5, 5.0))
    color, mappable = plotting.time_colormap(run.time[steps[0]], run.time[steps[-1]])
    for k in steps:
        plotting.draw_lattice(ax, shown[k], color=color(run.time[k]))
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
