# SPDX-License-Identifier: BSD-2-Clause
"""2-D side sections of a run with obstacles (nuno-contact-plot --view side).

A 3-D box at equal scales cannot show a 1 mm gap under a 1 m cloth, nor a
finger of 1 cm against a sheet seen from above. A side section can: every
lattice line projected onto a vertical plane, each obstacle as its outline
on that plane (the convex hull of its projected surface: exact for the
convex shapes nuno has), the barrier's reach (contact_thickness +
contact_dhat) as a dashed outline around it, and limits that frame the
cloth and the obstacle parts near it, one range for all panels or one a
panel. The plane's axis nearest to -g points up (gravity along +x, as in
input/gripper.nml: x grows downwards).
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.ticker import MaxNLocator

from . import cli, plotting
from .contact_plot import SOLID, TABLE, solid_quads

_AXIS = {"x": 0, "y": 1, "z": 2}
PLANES = ("xz", "yz", "xy")
EDGE = (0.25, 0.25, 0.28, 1.0)            # obstacles' outlines
CLOTH_LINE = (0.05, 0.35, 0.30, 1.0)      # the cloth: viridis' green, darker (thin lines on white)


def view_axes(plane: str, g=None) -> tuple[int, int, bool]:
    """(horizontal, vertical, flip) axis indices of the side view on plane
    ('xz': x and z): vertical is the plane's axis along which gravity
    points most (the second letter without gravity in the plane), flip
    where gravity points along +vertical (that axis then grows downwards)."""
    a, b = _AXIS[plane[0]], _AXIS[plane[1]]
    if g is None or abs(g[a]) + abs(g[b]) == 0.0:
        return a, b, False
    h, v = (b, a) if abs(g[a]) > abs(g[b]) else (a, b)
    return h, v, bool(g[v] > 0.0)


def convex_hull(points) -> np.ndarray:
    """The convex hull of 2-D points [n][2], counter-clockwise (monotone chain)."""
    p = np.unique(np.asarray(points, float).reshape(-1, 2), axis=0)
    if len(p) < 3:
        return p

    def turns_left(o, a, b) -> bool:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]) > 0.0

    def half(pts):
        out = []
        for q in pts:
            while len(out) >= 2 and not turns_left(out[-2], out[-1], q):
                out.pop()
            out.append(q)
        return out

    pts = [tuple(q) for q in p]
    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _disc(r: float, n: int = 32) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return r * np.column_stack([np.cos(a), np.sin(a)])


def outline(quads, h: int, v: int, grow: float = 0.0) -> np.ndarray:
    """The outline [k][2] on the (h, v) plane of a convex solid given by its
    surface quads: the hull of their projected vertices; grown by `grow`
    (the solid's points within that distance: the hull plus a disc)."""
    hull = convex_hull(np.asarray(quads).reshape(-1, 3)[:, [h, v]])
    if grow > 0.0:
        hull = convex_hull((hull[:, None, :] + _disc(grow)[None, :, :]).reshape(-1, 2))
    return hull


def plane_line(ob, h: int, v: int, depth: float):
    """(n2 [2], c): the plane's section n2 . (U, V) = c on the view plane
    at `depth` along the third axis, n2 the in-plane part of its normal
    (None where the normal is along the viewing direction)."""
    w = 3 - h - v
    n = np.asarray(ob.normal, float)
    n2 = np.array([n[h], n[v]])
    if np.linalg.norm(n2) < 1e-9:
        return None, 0.0
    c = n[h] * ob.point[h] + n[v] * ob.point[v] + n[w] * (ob.point[w] - depth)
    return n2, float(c)


def clip_halfplane(poly, n2, c) -> np.ndarray:
    """The part of the polygon [k][2] where n2 . x <= c (Sutherland-Hodgman, one edge)."""
    out = []
    poly = np.asarray(poly, float)
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        fa, fb = n2 @ a - c, n2 @ b - c
        if fa <= 0.0:
            out.append(a)
        if fa * fb < 0.0:
            out.append(a + fa / (fa - fb) * (b - a))
    return np.array(out).reshape(-1, 2)


def _line_points(n2, c, lo, hi, n: int = 41) -> np.ndarray:
    """Points of the line n2 . x = c across the box [lo, hi] (along its
    more horizontal or more vertical extent)."""
    if abs(n2[1]) >= abs(n2[0]):
        u = np.linspace(lo[0], hi[0], n)
        return np.column_stack([u, (c - n2[0] * u) / n2[1]])
    s = np.linspace(lo[1], hi[1], n)
    return np.column_stack([(c - n2[1] * s) / n2[0], s])


def _box_distance(pts, lo, hi) -> np.ndarray:
    d = np.maximum(np.maximum(lo - pts, pts - hi), 0.0)
    return np.hypot(d[:, 0], d[:, 1])


def frame(cloth_pts, obstacle_pts, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo [2], hi [2]) of a view that holds the cloth's points and the
    obstacles' points near them: those within max(1.5 x the nearest one's
    distance, 3 x reach) of the cloth's box, so that a gap shows whatever
    its size; padded by 8 % of each extent (a flat one by 5 % of the other)."""
    lo, hi = cloth_pts.min(axis=0), cloth_pts.max(axis=0)
    pts = np.concatenate([np.asarray(p, float).reshape(-1, 2) for p in obstacle_pts]) \
        if obstacle_pts else np.zeros((0, 2))
    if len(pts):
        dist = _box_distance(pts, lo, hi)
        near = pts[dist <= max(1.5 * dist.min(), 3.0 * reach)]
        lo, hi = np.minimum(lo, near.min(axis=0)), np.maximum(hi, near.max(axis=0))
    span = hi - lo
    flat = span <= 1e-9 * max(span.max(), 1e-300)      # a flat cloth alone, seen edge-on
    pad = np.where(flat, 0.05 * span.max(), 0.08 * span)
    pad = np.where(pad > 0.0, pad, 1e-3)
    return lo - pad, hi + pad


class Section:
    """The side sections of a run's steps on one plane: obstacles at each
    step's time, limits per step (zoom 'each': the cloth and the obstacle
    parts near it; 'obstacles': the solid obstacles, each step where they
    are) or one for all ('all'), optionally fixed (hlim, vlim: (low, high)
    of the horizontal and vertical axes)."""

    def __init__(self, run, steps, obstacles, plane: str, reach: float, zoom: str = "all",
                 hlim=None, vlim=None, stride: int = 1):
        self.run, self.steps, self.plane, self.reach, self.stride = run, list(steps), plane, reach, stride
        self.obstacles = obstacles
        self.h, self.v, self.flip = view_axes(plane, cli.gravity(run))
        self.w = 3 - self.h - self.v
        self.cloth = {k: np.asarray(run.position[k], float) for k in self.steps}
        self.depth = float(np.mean([p[..., self.w].mean() for p in self.cloth.values()]))
        frames = {k: frame(self._cloth_uv(k), self._near_points(k), reach) for k in self.steps}
        if zoom == "obstacles":
            frames = {k: self._solids_frame(k) or frames[k] for k in self.steps}
        if zoom == "all":
            lo = np.min([f[0] for f in frames.values()], axis=0)
            hi = np.max([f[1] for f in frames.values()], axis=0)
            frames = {k: (lo, hi) for k in self.steps}
        for k, (lo, hi) in frames.items():
            if hlim is not None:
                lo, hi = np.array([hlim[0], lo[1]]), np.array([hlim[1], hi[1]])
            if vlim is not None:
                lo, hi = np.array([lo[0], vlim[0]]), np.array([hi[0], vlim[1]])
            frames[k] = (lo, hi)
        self.frames = frames

    def _solids_frame(self, k):
        """(lo, hi): a square around the solid obstacles at step k and their
        reach, 1.3 times their larger extent (a pinch: the fingers and the
        cloth between them); None without solids."""
        pts = []
        for ob in self.obstacles:
            q = solid_quads(ob.at(self.time(k))) if ob.shape != "plane" else None
            if q is not None:
                pts.append(outline(q, self.h, self.v, self.reach))
        if not pts:
            return None
        pts = np.concatenate(pts)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        half = np.full(2, 1.3 * half.max())
        return centre - half, centre + half

    def _cloth_uv(self, k) -> np.ndarray:
        return self.cloth[k][..., [self.h, self.v]].reshape(-1, 2)

    def time(self, k) -> float:
        return float(self.run.time[k])

    def _near_points(self, k) -> list:
        """The obstacles' outline points at step k's time and those of the
        barrier's reach around them (planes: their lines across the cloth's
        horizontal range), for frame()."""
        uv = self._cloth_uv(k)
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        span = np.maximum(hi - lo, 1e-12)
        lo, hi = lo - 0.1 * span, hi + 0.1 * span
        pts = []
        for ob in self.obstacles:
            ob = ob.at(self.time(k))
            if ob.shape == "plane":
                n2, c = plane_line(ob, self.h, self.v, self.depth)
                if n2 is not None:
                    pts += [_line_points(n2, c, lo, hi), _line_points(n2, c + self.reach, lo, hi)]
            else:
                q = solid_quads(ob)
                if q is not None:
                    pts += [outline(q, self.h, self.v), outline(q, self.h, self.v, self.reach)]
        return pts

    def panel_size(self, aspect: str, width: float = 3.6) -> tuple[float, float]:
        """A panel's (width, height) in inches: the data's shape (largest
        frame) at equal scales, room for the title and labels."""
        if aspect != "equal":
            return width, 2.7
        spans = np.max([hi - lo for lo, hi in self.frames.values()], axis=0)
        ratio = spans[1] / max(spans[0], 1e-300)
        if ratio > 1.4:                               # tall: fix the height
            height = 5.5
            return max(1.9, (height - 1.2) / ratio + 1.1), height
        return width, max(1.9, min(1.6 * width, (width - 0.9) * ratio + 1.3))

    def draw(self, ax, k, units: str, aspect: str = "equal", title: str | None = None,
             ylabel: bool = True) -> None:
        """Step k's section on the 2-D axes ax."""
        lo, hi = self.frames[k]
        t = self.time(k)
        box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        for ob in self.obstacles:
            ob = ob.at(t)
            if ob.shape == "plane":
                n2, c = plane_line(ob, self.h, self.v, self.depth)
                if n2 is None:
                    continue
                region = clip_halfplane(box, n2, c)
                if len(region) >= 3:
                    ax.fill(region[:, 0], region[:, 1], color=TABLE, lw=0, zorder=1)
                for off, style in ((0.0, "-"), (self.reach, "--")):
                    line = _line_points(n2, c + off, lo, hi, 2)   # n unit: n2 . x = c + reach
                    ax.plot(line[:, 0], line[:, 1], color=EDGE, ls=style, lw=0.9 if off == 0.0 else 0.7,
                            zorder=2)
            else:
                q = solid_quads(ob)
                if q is None:
                    continue
                o = outline(q, self.h, self.v)
                ax.fill(o[:, 0], o[:, 1], facecolor=SOLID, edgecolor=EDGE, lw=0.8, zorder=2)
                g = outline(q, self.h, self.v, self.reach)
                ax.plot(np.r_[g[:, 0], g[:1, 0]], np.r_[g[:, 1], g[:1, 1]], color=EDGE, ls="--", lw=0.7,
                        zorder=2)
        uv = self.cloth[k][..., [self.h, self.v]]
        js = sorted(set(range(0, uv.shape[0], self.stride)) | {uv.shape[0] - 1})
        is_ = sorted(set(range(0, uv.shape[1], self.stride)) | {uv.shape[1] - 1})
        lines = [uv[j] for j in js] + [uv[:, i] for i in is_]
        ax.add_collection(LineCollection(lines, colors=[CLOTH_LINE], linewidths=0.9, zorder=3))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim((hi[1], lo[1]) if self.flip else (lo[1], hi[1]))
        if aspect == "equal":
            ax.set_aspect("equal", adjustable="box")
        ax.ticklabel_format(useOffset=False)
        ax.xaxis.set_major_locator(MaxNLocator(nbins=4))
        ax.yaxis.set_major_locator(MaxNLocator(nbins=5))
        names = "xyz"
        ax.set_xlabel(plotting.length_label(names[self.h], units))
        if ylabel:
            down = " (down)" if self.flip else ""
            ax.set_ylabel(plotting.length_label(names[self.v] + down, units))
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize="small")
        if title:
            ax.set_title(title, fontsize="medium")


def legend_handles(obstacles, reach: float, units: str) -> list:
    """The key to a section's lines: cloth, obstacle, the barrier's reach."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    solid = any(o.shape != "plane" for o in obstacles)
    return [Line2D([], [], color=CLOTH_LINE, lw=0.9, label="cloth (its lattice lines, projected)"),
            Patch(facecolor=SOLID if solid else TABLE, edgecolor=EDGE, label="obstacle"),
            Line2D([], [], color=EDGE, ls="--", lw=0.7,
                   label=f"barrier's reach: contact_thickness + contact_dhat = {gap_text(reach, units)}")]


def gap_text(value: float, units: str) -> str:
    """A gap for a title: '0.353 mm' (metres below 10 cm shown in mm)."""
    if units == "m" and abs(value) < 0.1:
        return f"{value * 1e3:.3g} mm"
    return f"{value:.3g} {units}"
