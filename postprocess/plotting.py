"""Shared plotting helpers: headless figures, equal-scale 3-D axes, unit labels.

Figures are plain ``matplotlib.figure.Figure`` objects on an Agg canvas: no
pyplot, no GUI backend, no global state, so the scripts run headless and a
test can inspect the figure that a script builds.
"""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers projection='3d')

CMAP = "viridis"  # perceptually uniform
VIEWS = {"iso": (25.0, -60.0), "side": (0.0, -90.0)}  # (elevation, azimuth)
COLORBAR_LABEL = "<colorbar>"  # matplotlib's label of colorbar axes


def blank_figure(figsize=(8.0, 6.0)):
    """An empty headless figure (Agg canvas) for custom layouts."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def new_figure(n_panels: int, ncols: int | None = None, projection: str | None = None,
               panel_size=(4.2, 3.4)):
    """A figure with n_panels subplots on a grid; returns (fig, list of axes)."""
    ncols = ncols or min(n_panels, 3)
    nrows = -(-n_panels // ncols)
    fig = blank_figure((panel_size[0] * ncols, panel_size[1] * nrows))
    axes = [fig.add_subplot(nrows, ncols, k + 1, projection=projection)
            for k in range(n_panels)]
    return fig, axes


def panels(fig) -> list:
    """The plot axes of a figure, colorbars left out."""
    return [ax for ax in fig.axes if ax.get_label() != COLORBAR_LABEL]


def save(fig, path, dpi: int = 120) -> None:
    """Write the figure (format from the file name; PNG by default)."""
    fig.savefig(path, dpi=dpi)


def length_label(axis: str, units: str) -> str:
    return f"{axis} [{units}]"


def quantity_label(kind: str, units: str) -> str:
    """Axis label for energy, momentum or angular momentum in the run's units."""
    mass, time = ("g", "s") if units == "mm" else ("kg", "s")
    if units not in ("mm", "m"):
        return kind
    if kind == "energy":
        return "energy [J]" if units == "m" else f"energy [{mass} {units}$^2$/{time}$^2$]"
    if kind == "momentum":
        return f"momentum [{mass} {units}/{time}]"
    if kind == "angular momentum":
        return f"angular momentum [{mass} {units}$^2$/{time}]"
    return kind


def bounds(*positions) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corner over arrays of points [..., 3]."""
    pts = np.concatenate([np.asarray(p).reshape(-1, 3) for p in positions])
    return pts.min(axis=0), pts.max(axis=0)


def setup_3d(ax, lo, hi, units: str, view: str = "iso", title: str | None = None):
    """Equal scales on x, y, z over the box [lo, hi]; labels in the run's units."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    span = hi - lo
    big = max(span.max(), 1e-12)
    # A flat cloth has zero z-span: keep a thin slab so the box stays visible.
    pad = np.maximum(span, 0.05 * big) - span
    lo, hi = lo - 0.5 * pad, hi + 0.5 * pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo), zoom=1.15)  # one unit, one length on every axis
    # Three ticks an axis and padded labels keep tick labels and axis labels
    # apart at panel size.
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=3))
        axis.labelpad = 6
    ax.tick_params(labelsize="small", pad=1)
    ax.set_xlabel(length_label("x", units))
    ax.set_ylabel(length_label("y", units))
    ax.set_zlabel(length_label("z", units))
    elev, azim = VIEWS[view]
    ax.view_init(elev=elev, azim=azim)
    ax.set_proj_type("ortho")  # no perspective: lengths read off the axes
    if view == "side":
        ax.set_yticks([])  # seen edge-on along y
        ax.set_ylabel("")
        ax.xaxis.labelpad = 12  # clear of the tick labels when seen edge-on
    if title:
        ax.set_title(title)


def shrink_3d_box(ax, zoom: float = 0.9) -> None:
    """A smaller box than setup_3d's (same scales), leaving room for the z label."""
    ax.set_box_aspect(tuple(np.ptp([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()], axis=1)), zoom=zoom)


def room_for_3d_labels(fig) -> None:
    """3-D axes put each z label right of the box's tick labels, where
    constrained layout does not see it: keep a margin for the last column's."""
    fig.get_layout_engine().set(rect=(0.0, 0.0, 0.975, 1.0))


def draw_lattice(ax, pos, color="C0", linewidth=0.8, label=None):
    """The lattice lines of a position array [ny][nx][3] as a wireframe."""
    pos = np.asarray(pos)
    return ax.plot_wireframe(pos[..., 0], pos[..., 1], pos[..., 2],
                             color=color, linewidth=linewidth, label=label)


def time_colormap(t0: float, t1: float):
    """(function t -> colour, ScalarMappable for a colorbar) over [t0, t1]."""
    norm = Normalize(vmin=t0, vmax=t1 if t1 > t0 else t0 + 1.0)
    cmap = colormaps[CMAP]
    return (lambda t: cmap(norm(t))), ScalarMappable(norm=norm, cmap=cmap)


def draw_lattice_side(ax, pos, color="C0", linewidth=0.8):
    """The lattice lines of [ny][nx][3] projected onto the x-z plane, on 2-D axes.

    A side view along y without a 3-D box: rows and columns of the lattice as
    x-z polylines. The caller sets the limits and ax.set_aspect("equal").
    """
    from matplotlib.collections import LineCollection  # only this view needs it

    xz = np.asarray(pos)[..., ::2]  # [ny][nx][(x, z)]
    lines = list(xz) + list(xz.transpose(1, 0, 2))
    return ax.add_collection(LineCollection(lines, colors=[color], linewidths=linewidth))


def objective_panel(ax, history, units: str, title: str, color: str = "C0") -> None:
    """An optimiser's objective per iteration on a log axis (identification, control;
    objective in the run's length unit squared)."""
    f = np.asarray(history, dtype=float)
    ax.semilogy(np.arange(len(f)), np.where(f > 0, f, np.nan), "o-", ms=3, color=color)
    ax.set_xlabel("TAO iteration")
    ax.set_ylabel(f"objective [{units}$^2$]")
    ax.set_title(title, fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
