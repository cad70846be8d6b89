# SPDX-License-Identifier: BSD-2-Clause
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
from matplotlib.ticker import Formatter, MaxNLocator, NullFormatter
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
    """Write the figure (format from the file name; PNG by default), its
    labels placed first (finish)."""
    fig.set_dpi(dpi)
    finish(fig)
    fig.savefig(path, dpi=dpi)


def finish(fig) -> None:
    """What a figure needs once everything is drawn on it, before it is
    written (save) or its frames grabbed (the animations): y labels that fit
    their panel (wrap_tall_labels), 3-D z labels beside their own box and
    every 3-D label inside the canvas (settle_3d), no two tick labels of an
    axis on each other (unpile_tick_labels)."""
    wrap_tall_labels(fig)
    settle_3d(fig)
    unpile_tick_labels(fig)


def _renderer(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def wrap_tall_labels(fig) -> None:
    """A y label taller than its panel reaches into the title above it (a
    unit that collided with the suptitle): its unit goes on a second line,
    and a label still too tall is wrapped further."""
    import textwrap

    r = _renderer(fig)
    tall = [ax for ax in panels(fig) if ax.name != "3d" and ax.yaxis.label.get_text()
            and ax.yaxis.label.get_window_extent(r).height > ax.get_window_extent(r).height]
    for ax in tall:
        name, sep, unit = ax.yaxis.label.get_text().rpartition(" [")
        if sep:
            ax.set_ylabel(f"{name}\n[{unit}")
    r = _renderer(fig) if tall else r
    for ax in tall:
        label = ax.yaxis.label
        if label.get_window_extent(r).height > ax.get_window_extent(r).height:
            name, sep, unit = label.get_text().rpartition("\n[")
            name = name or label.get_text()
            lines = textwrap.wrap(name, max(8, len(name) // 2 + 1)) + ([f"[{unit}"] if sep else [])
            ax.set_ylabel("\n".join(lines))


def _zoom(ax) -> float:
    return getattr(ax, "_nuno_zoom", 1.0)


def _set_zoom(ax, zoom: float) -> None:
    """The 3-D box at this zoom, its scales kept (equal on x, y, z)."""
    ax.set_box_aspect(tuple(np.ptp([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()], axis=1)), zoom=zoom)
    ax._nuno_zoom = zoom


def _tick_labels(axis, r) -> list:
    """(location, text, window box, minor) of the tick labels drawn: only
    ticks inside the axis' limits (3-D axes keep stale labels outside)."""
    lo, hi = sorted(axis.get_view_interval())
    span = hi - lo
    out = []
    for minor, ticks in ((False, axis.get_major_ticks()), (True, axis.get_minor_ticks())):
        for t in ticks:
            loc = t.get_loc()
            if loc is None or not lo - 1e-9 * span <= loc <= hi + 1e-9 * span:
                continue
            lab = t.label1
            if lab.get_visible() and lab.get_text():
                out.append((loc, lab.get_text(), lab.get_window_extent(r), minor))
    return out


def _axes_of(ax) -> list:
    return [ax.xaxis, ax.yaxis] + ([ax.zaxis] if ax.name == "3d" else [])


def _label_boxes(ax, r) -> list:
    return [lab.get_window_extent(r) for lab in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label)
            if lab.get_visible() and lab.get_text()] + \
        [b for axis in _axes_of(ax) for _, _, b, _ in _tick_labels(axis, r)]


def _corners(box) -> np.ndarray:
    return np.array([[box.x0, box.y0], [box.x0, box.y1], [box.x1, box.y0], [box.x1, box.y1]])


def _axis_direction(ax, n: int) -> np.ndarray:
    """Unit vector on the display of 3-D axes ax along its data axis n (x, y, z)."""
    from mpl_toolkits.mplot3d import proj3d

    lims = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()])
    a, b = lims[:, 0].copy(), lims[:, 0].copy()
    b[n] = lims[n, 1]
    m = ax.get_proj()
    pa, pb = (proj3d.proj_transform(*p, m)[:2] for p in (a, b))
    d = ax.transData.transform([pb])[0] - ax.transData.transform([pa])[0]
    norm = float(np.hypot(*d))
    return d / norm if norm > 0 else np.array([1.0, 0.0])


def _place_3d_labels(axes, gap_px: float) -> None:
    """Each axis label of each 3-D axes gap_px beyond its own tick labels.

    matplotlib moves a 3-D axis label out from the box's centre by
    (labelpad + 8) points times the box's spans, so on a flat or thin box
    it lands far from its axis (a z label halfway to the next panel, the y
    label of a thin box under the panel below). The position is linear in
    labelpad: two draws give the direction it moves, and labelpad is set
    so that the label's near edge lies gap_px past the tick labels' far edge
    along that direction."""
    fig = axes[0].figure
    step = 4.0
    r = _renderer(fig)
    before = {(ax, n): axis.label.get_window_extent(r) for ax in axes
              for n, axis in enumerate(_axes_of(ax))}
    for ax in axes:
        for axis in _axes_of(ax):
            axis.labelpad -= step
    r = _renderer(fig)
    for ax in axes:
        for n, axis in enumerate(_axes_of(ax)):
            axis.labelpad += step
            ticks = [b for _, _, b, _ in _tick_labels(axis, r)]
            if not axis.label.get_text() or not axis.label.get_visible() or not ticks:
                continue
            b0, b1 = before[(ax, n)], axis.label.get_window_extent(r)
            v = (np.array([b0.x0 + b0.x1, b0.y0 + b0.y1]) - [b1.x0 + b1.x1, b1.y0 + b1.y1]) / (2 * step)
            speed = float(np.hypot(*v))          # display pixels per point of labelpad
            if speed < 1e-9:
                continue
            u = v / speed
            # measured across the axis: the tick labels spread along it
            a = _axis_direction(ax, n)
            across = u - (u @ a) * a
            if np.hypot(*across) < 0.2:            # the label moves along its axis: leave it
                continue
            across /= np.hypot(*across)
            far = max(float((_corners(b) @ across).max()) for b in ticks)
            near = float((_corners(b0) @ across).min())
            axis.labelpad += (far + gap_px - near) / (speed * float(u @ across))


def settle_3d(fig, gap_pt: float = 4.0, slack: float = 1.0, rounds: int = 8) -> None:
    """3-D panels: every axis label gap_pt beyond its own tick labels
    (_place_3d_labels), and a box whose labels leave the canvas (a GIF's
    square frame cut the z label) or reach into a 2-D panel drawn smaller
    until they do not."""
    axes = [ax for ax in fig.axes if ax.name == "3d"]
    if not axes:
        return
    w, h = fig.canvas.get_width_height()
    for _ in range(rounds):
        _place_3d_labels(axes, gap_pt * fig.dpi / 72.0)
        r = _renderer(fig)
        flat = [a.get_window_extent(r) for a in panels(fig) if a.name != "3d"]
        bad = []
        for ax in axes:
            boxes = _label_boxes(ax, r)
            if any(b.x0 < -slack or b.y0 < -slack or b.x1 > w + slack or b.y1 > h + slack
                   or any(b.overlaps(f) for f in flat) for b in boxes):
                bad.append(ax)
        if not bad:
            return
        for ax in bad:
            if _zoom(ax) <= 0.5:
                return
            _set_zoom(ax, _zoom(ax) * 0.92)


class _Thinned(Formatter):
    """The labels of another formatter at the locations in keep only (the ticks stay)."""

    def __init__(self, inner, keep):
        self.inner, self.keep = inner, sorted(keep)

    def _kept(self, v) -> bool:
        return any(abs(v - k) <= 1e-9 * max(abs(k), 1e-300) for k in self.keep)

    def set_locs(self, locs):
        self.inner.set_locs(locs)

    def format_ticks(self, values):
        labels = self.inner.format_ticks(values)
        return [lab if self._kept(v) else "" for v, lab in zip(values, labels)]

    def __call__(self, x, pos=None):
        return self.inner(x, pos) if self._kept(x) else ""

    def get_offset(self):
        return self.inner.get_offset()


def _piled(boxes) -> bool:
    return any(a.overlaps(b) for k, a in enumerate(boxes) for b in boxes[k + 1:])


def unpile_tick_labels(fig, rounds: int = 6) -> None:
    """No two tick labels of an axis drawn over each other: where they pile
    (a log axis over less than a decade labels every minor tick; a short
    3-D axis), the minor labels go first while two major labels remain, else
    every second label of the piled kind; the ticks themselves stay."""
    for _ in range(rounds):
        r = _renderer(fig)
        piled = []
        for ax in panels(fig):
            for axis in _axes_of(ax):
                labels = _tick_labels(axis, r)
                if _piled([b for _, _, b, _ in labels]):
                    piled.append((axis, labels))
        if not piled:
            return
        for axis, labels in piled:
            majors = [loc for loc, _, _, minor in labels if not minor]
            minors = [loc for loc, _, _, minor in labels if minor]
            if minors and len(majors) >= 2:
                axis.set_minor_formatter(NullFormatter())
            elif minors:
                axis.set_minor_formatter(_Thinned(axis.get_minor_formatter(), sorted(minors)[::2]))
            else:
                axis.set_major_formatter(_Thinned(axis.get_major_formatter(), sorted(majors)[::2]))


def length_label(axis: str, units: str) -> str:
    return f"{axis} [{units}]"


def quantity_label(kind: str, units: str) -> str:
    """Axis label for energy, momentum, angular momentum or force in the run's units."""
    mass, time = ("g", "s") if units == "mm" else ("kg", "s")
    if units not in ("mm", "m"):
        return kind
    if kind == "energy":
        return "energy [J]" if units == "m" else f"energy [{mass} {units}$^2$/{time}$^2$]"
    if kind == "momentum":
        return f"momentum [{mass} {units}/{time}]"
    if kind == "angular momentum":
        return f"angular momentum [{mass} {units}$^2$/{time}]"
    if kind == "force":
        return "force [N]" if units == "m" else f"force [{mass} {units}/{time}$^2$]"
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
    ax._nuno_zoom = 1.15
    # Three ticks an axis and padded labels keep tick labels and axis labels
    # apart at panel size.
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=3))
        axis.labelpad = 6
    # A short z axis (a near-flat cloth) has room for fewer labels: three
    # ticks on a box a tenth as tall as wide pile their labels on each other.
    frac = (hi[2] - lo[2]) / max((hi - lo).max(), 1e-300)
    if frac < 0.2:
        ax.set_zticks([_one_tick(lo[2], hi[2])])
        # seen flat, the x and y tick labels sit lower: the axis labels below them
        ax.xaxis.labelpad = ax.yaxis.labelpad = 10
    elif frac < 0.45:
        ax.zaxis.set_major_locator(MaxNLocator(nbins=1))
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


def _one_tick(lo: float, hi: float) -> float:
    """A round value inside [lo, hi] (0 when it is inside)."""
    if lo <= 0.0 <= hi:
        return 0.0
    ticks = [t for t in MaxNLocator(nbins=2).tick_values(lo, hi) if lo <= t <= hi]
    return float(ticks[len(ticks) // 2]) if ticks else 0.5 * (lo + hi)


def iso_panel_size(lo, hi, width: float = 4.2) -> tuple[float, float]:
    """(width, height) of a 3-D panel: a flat box needs less height than a cube."""
    span = np.asarray(hi, float) - np.asarray(lo, float)
    frac = span[2] / max(span.max(), 1e-300)      # how tall the box is
    return width, width * (0.55 + 0.3 * min(1.0, frac))


def iso_zoom(lo, hi) -> float:
    """The 3-D box's zoom in a panel: a flat box may fill more of its width
    (its labels need less height), a cube keeps room for them."""
    span = np.asarray(hi, float) - np.asarray(lo, float)
    frac = span[2] / max(span.max(), 1e-300)
    return 0.9 + 0.35 * max(0.0, 1.0 - frac / 0.4)


def shrink_3d_box(ax, zoom: float = 0.9) -> None:
    """A smaller box than setup_3d's (same scales), leaving room for the z label."""
    _set_zoom(ax, zoom)


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


PLANES = ("xz", "yz")
_AXIS = {"x": 0, "y": 1, "z": 2}


def side_plane(positions, reference=None) -> str:
    """'xz' or 'yz': the vertical plane of largest horizontal motion.

    positions: arrays [ny][nx][3] (the states shown); the motion of a node
    is its displacement from `reference` (e.g. the rest lattice), or from the
    first state; the plane is x-z when the nodes move further along x than
    along y, else y-z (hang swings in y-z: its x-z projection shows little).
    """
    pts = [np.asarray(p, float) for p in positions]
    ref = np.asarray(reference, float) if reference is not None else pts[0]
    d = np.stack([p - ref for p in pts])
    spread = np.ptp(d[..., 0]) + np.abs(d[..., 0]).max(), np.ptp(d[..., 1]) + np.abs(d[..., 1]).max()
    return "xz" if spread[0] >= spread[1] else "yz"


def draw_lattice_side(ax, pos, color="C0", linewidth=0.8, plane: str = "xz", label=None):
    """The lattice lines of [ny][nx][3] projected onto the x-z or y-z plane, on 2-D axes.

    A side view without a 3-D box: rows and columns of the lattice as
    polylines. The caller sets the limits and equal aspect (side_axes).
    """
    from matplotlib.collections import LineCollection  # only this view needs it

    cols = [_AXIS[plane[0]], _AXIS[plane[1]]]
    uv = np.asarray(pos)[..., cols]  # [ny][nx][(u, z)]
    lines = list(uv) + list(uv.transpose(1, 0, 2))
    return ax.add_collection(LineCollection(lines, colors=[color], linewidths=linewidth,
                                            label=label))


def side_axes(ax, lo, hi, units, plane: str = "xz", title=None, labels: bool = True):
    """2-D side-view axes over the box [lo, hi]: equal scales, nothing clipped."""
    u, v = _AXIS[plane[0]], _AXIS[plane[1]]
    pad = 0.04 * max(hi[u] - lo[u], hi[v] - lo[v], 1e-12)
    # Equal scales by widening the limits to the panel, not by shrinking the
    # box: a near-flat sheet seen edge-on would leave a sliver of axes with
    # its tick labels piled up and the canvas empty. (Autoscaled limits, not
    # set ones, which the aspect would override with a warning.)
    ax.update_datalim([(lo[u] - pad, lo[v] - pad), (hi[u] + pad, hi[v] + pad)])
    ax.margins(0.0)
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    # Few ticks: side-by-side panels of a narrow plane pile long labels.
    ax.xaxis.set_major_locator(MaxNLocator(nbins=4))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=4))
    if labels:
        ax.set_xlabel(length_label(plane[0], units))
        ax.set_ylabel(length_label(plane[1], units))
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title)


def side_panel_size(lo, hi, plane: str, width: float = 3.6) -> tuple[float, float]:
    """(width, height) in inches of a side-view panel whose plot fills it:
    the data's aspect plus room for the title and the tick and axis labels."""
    u, v = _AXIS[plane[0]], _AXIS[plane[1]]
    aspect = (hi[v] - lo[v] + 1e-12) / (hi[u] - lo[u] + 1e-12)
    return width, max(1.7, min(1.6 * width, (width - 0.8) * aspect + 1.1))


def objective_panel(ax, history, units: str, title: str, color: str = "C0") -> None:
    """An optimiser's objective per iteration on a log axis (identification, control;
    objective in the run's length unit squared)."""
    f = np.asarray(history, dtype=float)
    ax.semilogy(np.arange(len(f)), np.where(f > 0, f, np.nan), "o-", ms=3, color=color)
    ax.set_xlabel("TAO iteration")
    ax.set_ylabel(f"objective [{units}$^2$]")
    ax.set_title(title, fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
