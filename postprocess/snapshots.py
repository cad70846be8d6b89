# SPDX-License-Identifier: BSD-2-Clause
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


def build_figure(run, steps, layout: str = "panels", view: str = "iso", plane: str | None = None):
    """The figure: one panel per step, or all steps in one coloured by time.

    The iso view is 3-D; the side view is drawn on 2-D axes (a 3-D box seen
    edge-on leaves its tick labels floating below it), on the vertical plane
    of the largest motion (plotting.side_plane) unless plane ('xz', 'yz')
    says which.
    """
    units = run.units()
    shown = {k: run.position[k] for k in steps}  # only the steps shown are read
    lo, hi = plotting.bounds(*shown.values())
    side = view == "side"
    if side and plane is None:
        plane = plotting.side_plane(list(shown.values()), run.rest_position)
    projection = None if side else "3d"
    if layout == "panels":
        n = len(steps)
        ncols = grid_columns(n)
        size = plotting.side_panel_size(lo, hi, plane) if side else plotting.iso_panel_size(lo, hi)
        fig, axes = plotting.new_figure(n, ncols=ncols, projection=projection, panel_size=size)
        for k, (ax, step) in enumerate(zip(axes, steps)):
            title = f"t = {run.time[step]:g} s"
            if side:
                plotting.draw_lattice_side(ax, shown[step], plane=plane)
                plotting.side_axes(ax, lo, hi, units, plane, title)
                if k % ncols:                # one vertical axis label a row
                    ax.set_ylabel("")
            else:
                plotting.draw_lattice(ax, shown[step])
                plotting.setup_3d(ax, lo, hi, units, view, title=title)
                plotting.shrink_3d_box(ax, plotting.iso_zoom(lo, hi))
        if not side:
            plotting.room_for_3d_labels(fig)
        return fig
    size = plotting.side_panel_size(lo, hi, plane, width=6.0) if side else (6.5, 5.0)
    fig, (ax,) = plotting.new_figure(1, ncols=1, projection=projection,
                                     panel_size=(size[0] + 1.0, size[1]))
    color, mappable = plotting.time_colormap(run.time[steps[0]], run.time[steps[-1]])
    for k in steps:
        if side:
            plotting.draw_lattice_side(ax, shown[k], color=color(run.time[k]), plane=plane)
        else:
            plotting.draw_lattice(ax, shown[k], color=color(run.time[k]))
    if side:
        plotting.side_axes(ax, lo, hi, units, plane)
    else:
        plotting.setup_3d(ax, lo, hi, units, view)
        plotting.shrink_3d_box(ax, 0.85)    # the x and z labels inside the canvas
    # clear of the 3-D box's z label
    fig.colorbar(mappable, ax=ax, label="t [s]", shrink=0.7, pad=0.02 if side else 0.1)
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "snapshots")
    p.add_argument("run", help="nuno output file (.h5)")
    p.add_argument("--times", type=float, nargs="+", default=None,
                   help="times to show (nearest output step); default: 4 evenly spaced steps")
    p.add_argument("--layout", choices=("panels", "overlay"), default="panels",
                   help="one subplot per time, or all times in one coloured by time")
    p.add_argument("--view", choices=tuple(plotting.VIEWS), default="iso",
                   help="iso: oblique 3-D; side: 2-D, onto the vertical plane of the largest "
                        "motion (x-z or y-z; --plane picks one)")
    p.add_argument("--plane", choices=plotting.PLANES, default=None,
                   help="the side view's plane (default: that of the largest motion)")
    cli.add_output(p, "snapshots")
    return p


def _body(args):
    run = cli.load_run(args.run)
    steps = choose_steps(run, args.times)
    if args.plane and args.view != "side":
        raise cli.UsageError("--plane goes with --view side")
    fig = build_figure(run, steps, args.layout, args.view, args.plane)
    plotting.save(fig, args.output or cli.default_output(args.run, "snapshots"), args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
