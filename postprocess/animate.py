# SPDX-License-Identifier: BSD-2-Clause
"""Animation of a run: GIF (Pillow), or MP4 when ffmpeg is on PATH.

    nuno-animate run.h5 --stride 2 -o run.gif
"""

from __future__ import annotations

import shutil
import sys

import numpy as np
from matplotlib.animation import FFMpegWriter, PillowWriter

from . import cli, plotting


def frame_steps(run, stride: int = 1) -> list[int]:
    """Output steps shown: every stride-th, starting at the first."""
    if stride < 1:
        raise ValueError("--stride must be at least 1")
    return list(range(0, run.nt, stride))


def make_writer(output: str, fps: float):
    """PillowWriter for .gif, FFMpegWriter for .mp4 (needs ffmpeg on PATH)."""
    name = output.lower()
    if name.endswith(".mp4"):
        if shutil.which("ffmpeg") is None:
            raise ValueError("ffmpeg not found on PATH: write a .gif instead")
        return FFMpegWriter(fps=fps)
    if name.endswith(".gif"):
        return PillowWriter(fps=fps)
    raise ValueError(f"{output}: unsupported animation format (use .gif or .mp4)")


def progress(done: int, total: int, stream=None, width: int = 40) -> None:
    """A one-line text progress bar, redrawn in place (on stderr by default)."""
    stream = stream or sys.stderr
    filled = int(width * done / max(total, 1))
    stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} frames")
    if done == total:
        stream.write("\n")
    stream.flush()


def animation_figure(run, steps, view: str = "iso", dpi: int = 100):
    """(figure, 3-D axes) every frame is drawn on: one box over the steps
    (read one at a time: bounded memory), its labels placed inside the
    frame (plotting.finish) with the longest title a frame will have."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for k in steps:
        a, b = plotting.bounds(run.position[k])
        lo, hi = np.minimum(lo, a), np.maximum(hi, b)
    fig, (ax,) = plotting.new_figure(1, ncols=1, projection="3d", panel_size=(6.0, 5.0))
    fig.set_dpi(dpi)
    plotting.setup_3d(ax, lo, hi, run.units(), view)
    plotting.shrink_3d_box(ax)
    plotting.room_for_3d_labels(fig)
    ax.set_title(f"t = {run.time[steps[-1]]:.4g} s")
    plotting.finish(fig)
    return fig, ax


def write_animation(run, output: str, stride: int = 1, fps: float = 10.0,
                    view: str = "iso", dpi: int = 100, show_progress: bool = True) -> int:
    """Write the animation; returns the number of frames."""
    steps = frame_steps(run, stride)
    writer = make_writer(output, fps)
    fig, ax = animation_figure(run, steps, view, dpi)
    wire = None
    with writer.saving(fig, output, dpi):
        for n, k in enumerate(steps, start=1):
            if wire is not None:
                wire.remove()
            wire = plotting.draw_lattice(ax, run.position[k])
            ax.set_title(f"t = {run.time[k]:.4g} s")
            writer.grab_frame()
            if show_progress:
                progress(n, len(steps))
    return len(steps)


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "animate")
    p.add_argument("run", help="nuno output file (.h5)")
    p.add_argument("-o", "--output", default=None,
                   help="output .gif or .mp4 (default: <input stem>_animation.gif)")
    p.add_argument("--stride", type=int, default=1, help="use every N-th output step (default 1)")
    p.add_argument("--fps", type=float, default=10.0, help="frames per second (default 10)")
    p.add_argument("--view", choices=tuple(plotting.VIEWS), default="iso")
    p.add_argument("--dpi", type=int, default=100, help="resolution (default 100)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    return p


def _body(args):
    run = cli.load_run(args.run)
    output = args.output or cli.default_output(args.run, "animation", ".gif")
    write_animation(run, output, args.stride, args.fps, args.view, args.dpi,
                    show_progress=not args.no_progress)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
