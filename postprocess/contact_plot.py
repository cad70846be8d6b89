# SPDX-License-Identifier: BSD-2-Clause
"""The cloth with its obstacles (&contact) at a few times, and an animation.

    nuno-contact-plot drape_sphere.h5 --times 0 0.3 0.6 1.0 -o drape.png --gif drape.gif
    nuno-contact-plot drop_table.h5 --view side --zoom each --aspect auto -o drop.png
    nuno-contact-plot gripper.h5 --view side --plane xz --times 0 0.2 0.7 1.5 2.5 -o grip.png

The obstacles are read from the file's /config/contact group (the keys as
resolved, -nuno_set overrides included), else from the namelist the file
echoes: planes (a square patch under the cloth), spheres, boxes (centre,
half extents, local axes) and capsules (two ends, radius), each where its
keyframes (obstacle_time, obstacle_offset, obstacle_close) put it at the
time drawn (from /config only: a file without it is drawn with its
obstacles at rest). A run without obstacles is drawn as the cloth alone.

--view side draws 2-D sections instead of the 3-D box: every lattice line
projected onto a vertical plane (--plane xz or yz; default the plane of
the largest motion), the obstacles as their outlines on it (filled), the
barrier's reach (contact_thickness + contact_dhat) dashed around them, and
"up" up (the plane's axis nearest to -g points up, reversed where gravity
points along it). --zoom all (one range for every panel) or each (each
panel its own) frames the cloth and the obstacle parts near it, so that a
gap of a millimetre shows; --aspect auto stretches the vertical axis.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from matplotlib import colormaps
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from . import cli, plotting
from .snapshots import choose_steps, grid_columns

# The &contact keys of an obstacle's shape (input/README.md, "&contact").
# Arrays of 3-vectors hold obstacle k in elements 3k-2..3k (Fortran
# obstacle_point(:, k)); box axes 9 a box (its three unit axes, columns).
KEY_SHAPE = "obstacle_shape"
KEY_POINT = "obstacle_point"      # plane: a point on it; sphere, box: centre; capsule: first end
KEY_NORMAL = "obstacle_normal"    # plane: outward normal
KEY_RADIUS = "obstacle_radius"    # sphere, capsule
KEY_HALF = "obstacle_half_size"    # box: half extents along its local x, y, z
KEY_AXIS = "obstacle_axis"        # box: its local x (made orthogonal to obstacle_normal, its local z;
#                                   local y = z x x, as src/model/contact_model.f90 builds it)
KEY_END = "obstacle_end"          # capsule: the second end
# Keyframed motion (input/README.md, "&contact", Motion); /config holds the
# n_keyframes(k) keyframes in use of each obstacle one after the other.
KEY_N_KEYFRAMES = "obstacle_n_keyframes"
KEY_TIME = "obstacle_time"        # [time]
KEY_OFFSET = "obstacle_offset"    # 3 a keyframe [length]
KEY_CLOSE = "obstacle_close"      # a finger's closing offset along obstacle_close_dir [length]
KEY_CLOSE_DIR = "obstacle_close_dir"
SHAPES = ("plane", "sphere", "box", "capsule")
DHAT_DEFAULT = 1.0e-3             # contact_dhat's default [length]

CLOTH = colormaps[plotting.CMAP](0.62)   # one colour for the cloth (viridis, green)
SOLID = (0.62, 0.62, 0.66, 1.0)           # obstacles: grey
TABLE = (0.78, 0.72, 0.62, 1.0)           # a plane: light wood
LIGHT = np.array([-0.35, -0.55, 0.76])    # light direction (unit-ish), from the viewer's upper left


@dataclass
class Obstacle:
    """One rigid obstacle as the file describes it (lengths in the run's unit)."""

    shape: str
    point: np.ndarray
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    radius: float = 0.0
    half: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))   # columns: the box's axes
    end: np.ndarray = field(default_factory=lambda: np.zeros(3))
    key_time: np.ndarray = field(default_factory=lambda: np.zeros(0))        # [m] keyframe times
    key_offset: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # [m][3] translations
    key_close: np.ndarray = field(default_factory=lambda: np.zeros(0))       # [m] closing offsets
    close_dir: np.ndarray = field(default_factory=lambda: np.zeros(3))       # unit closing direction

    def translation(self, t) -> np.ndarray:
        """The obstacle's translation at time t [3]: offset plus closing
        offset times close_dir, each linear between keyframes and held
        before the first and after the last (obstacle_motion's rule); zero
        for a static obstacle or t None."""
        if t is None or len(self.key_time) == 0:
            return np.zeros(3)
        tk = self.key_time
        d = np.array([np.interp(t, tk, self.key_offset[:, c]) for c in range(3)])
        return d + float(np.interp(t, tk, self.key_close)) * self.close_dir

    def at(self, t) -> "Obstacle":
        """The obstacle at time t (its geometry keys give the pose at zero offset)."""
        d = self.translation(t)
        if not np.any(d):
            return self
        return dataclasses.replace(self, point=self.point + d, end=self.end + d)


def _contact_keys(run) -> dict:
    """{key: value} of the run's &contact: /config/contact, else the echoed namelist."""
    if run.config.get("contact"):
        return dict(run.config["contact"])
    try:
        import f90nml
        nml = f90nml.reads(run.namelist)
    except Exception:  # an unreadable echoed namelist: no obstacles from it
        return {}
    group = nml.get("contact", {})
    out = {}
    for k, v in group.items():
        # f90nml drops the unset elements before the first one given
        # (obstacle_radius(2) = 0.5 reads as [0.5], starting at 2): pad them
        start = getattr(group, "start_index", {}).get(k)
        if isinstance(v, list) and start:
            first = start[-1] if start[-1] is not None else 1
            v = [None] * (first - 1) + v
        out[k] = v
    return out


def _floats(value, n: int, width: int, default) -> np.ndarray:
    """value (a flat list, nested lists from f90nml, or an array) as [n][width],
    entries that are missing (None, or past the end) taken from default."""
    flat = []

    def walk(v):
        if isinstance(v, (list, tuple, np.ndarray)):
            for w in v:
                walk(w)
        else:
            flat.append(v)

    if value is not None:
        walk(value if isinstance(value, (list, tuple, np.ndarray)) else [value])
    out = np.tile(np.asarray(default, float).ravel(), n)
    for k, v in enumerate(flat[: n * width]):
        if v is not None and str(v).strip() != "":
            out[k] = float(v)
    return out.reshape(n, width)


def _shapes(value, n: int) -> list[str]:
    if value is None:
        return ["plane"] * n
    if isinstance(value, str):
        names = [s.strip().strip("'\"").lower() for s in value.split(",")]
    else:
        names = [str(s or "plane").strip().lower() for s in np.ravel(np.asarray(value, dtype=object))]
    return (names + ["plane"] * n)[:n]


def _box_axes(normal, axis) -> np.ndarray:
    """A box's local axes as columns: x = axis made orthogonal to the unit
    normal (local z), y = z x x; the identity where axis is parallel to it."""
    ex = np.asarray(axis, float) - np.dot(axis, normal) * normal
    if np.linalg.norm(ex) < 1e-12:
        return np.eye(3)
    ex /= np.linalg.norm(ex)
    return np.column_stack([ex, np.cross(normal, ex), normal])


def _keyframes(keys: dict, n: int) -> list[tuple]:
    """(times [m], offsets [m][3], closing [m], close_dir [3]) of each of the
    n obstacles from /config's packed keyframe keys (m = 0: static). Read
    from /config only: the echoed namelist's arrays of keyframes are not
    unpacked here (obstacles drawn at rest)."""
    none = [(np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(3))] * n
    if KEY_N_KEYFRAMES not in keys or KEY_TIME not in keys:
        return none
    m = [int(round(float(v))) for v in np.ravel(np.asarray(keys[KEY_N_KEYFRAMES], dtype=float))][:n]
    m += [0] * (n - len(m))
    time = np.ravel(np.asarray(keys[KEY_TIME], dtype=float))
    offset = np.ravel(np.asarray(keys.get(KEY_OFFSET, np.zeros(3 * sum(m))), dtype=float))
    close = np.ravel(np.asarray(keys.get(KEY_CLOSE, np.zeros(sum(m))), dtype=float))
    close_dir = _floats(keys.get(KEY_CLOSE_DIR), n, 3, [0.0, 0.0, 0.0])
    if len(time) < sum(m) or len(offset) < 3 * sum(m) or len(close) < sum(m):
        return none           # not the layout this script knows: at rest
    out, start = [], 0
    for k in range(n):
        sl = slice(start, start + m[k])
        cd = close_dir[k]
        cd = cd / np.linalg.norm(cd) if np.linalg.norm(cd) > 0 else cd
        out.append((time[sl].copy(), offset[3 * start: 3 * (start + m[k])].reshape(-1, 3).copy(),
                    close[sl].copy(), cd))
        start += m[k]
    return out


def obstacles(run) -> list[Obstacle]:
    """The run's obstacles, in the order of &contact, at zero keyframe
    offset (Obstacle.at(t) moves one to time t); empty without any."""
    keys = _contact_keys(run)
    n = int(np.asarray(keys.get("n_obstacles", 0)).ravel()[0]) if keys else 0
    if n <= 0:
        return []
    shapes = _shapes(keys.get(KEY_SHAPE), n)
    point = _floats(keys.get(KEY_POINT), n, 3, [0.0, 0.0, 0.0])
    normal = _floats(keys.get(KEY_NORMAL), n, 3, [0.0, 0.0, 1.0])
    radius = _floats(keys.get(KEY_RADIUS), n, 1, [0.0])[:, 0]
    half = _floats(keys.get(KEY_HALF), n, 3, [0.0, 0.0, 0.0])
    axis = _floats(keys.get(KEY_AXIS), n, 3, [1.0, 0.0, 0.0])
    end = _floats(keys.get(KEY_END), n, 3, [0.0, 0.0, 0.0])
    frames = _keyframes(keys, n)
    out = []
    for k in range(n):
        nrm = normal[k] / max(np.linalg.norm(normal[k]), 1e-300)
        tk, off, close, cdir = frames[k]
        out.append(Obstacle(shapes[k], point[k], nrm, float(radius[k]), half[k],
                            _box_axes(nrm, axis[k]), end[k], tk, off, close, cdir))
    return out


def reach(run) -> float:
    """How far from an obstacle the barrier acts: contact_thickness + contact_dhat [length]."""
    keys = _contact_keys(run)

    def value(key, default):
        v = keys.get(key, default)
        return float(np.ravel(np.asarray(v if v is not None else default, dtype=float))[0])

    return value("contact_thickness", 0.0) + value("contact_dhat", DHAT_DEFAULT)


# ---------------------------------------------------------------- geometry as quads


def cloth_quads(pos, stride: int = 1) -> np.ndarray:
    """The lattice [ny][nx][3] as quads [m][4][3] (every stride-th line kept)."""
    p = np.asarray(pos, float)
    ny, nx = p.shape[:2]
    js = sorted(set(range(0, ny, stride)) | {ny - 1})
    is_ = sorted(set(range(0, nx, stride)) | {nx - 1})
    p = p[np.ix_(js, is_)]
    return np.stack([p[:-1, :-1], p[:-1, 1:], p[1:, 1:], p[1:, :-1]], axis=2).reshape(-1, 4, 3)


def _grid_quads(origin, u, v, n: int) -> np.ndarray:
    """An n x n grid of quads over the parallelogram origin + [0,1] u + [0,1] v."""
    s = np.linspace(0.0, 1.0, n + 1)
    g = origin + s[None, :, None] * u + s[:, None, None] * v   # [n+1][n+1][3]
    return np.stack([g[:-1, :-1], g[:-1, 1:], g[1:, 1:], g[1:, :-1]], axis=2).reshape(-1, 4, 3)


def _tangents(n):
    """Two unit vectors orthogonal to the unit vector n and to each other."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def plane_quads(ob: Obstacle, lo, hi, n: int = 8) -> np.ndarray:
    """A square patch of the plane under the box [lo, hi] (the cloth's), 1.3 times its size."""
    centre = 0.5 * (np.asarray(lo) + np.asarray(hi))
    c = centre - np.dot(centre - ob.point, ob.normal) * ob.normal   # centre projected on the plane
    size = 1.3 * max(float(np.max(np.asarray(hi) - np.asarray(lo))), 1e-12)
    u, v = _tangents(ob.normal)
    return _grid_quads(c - 0.5 * size * (u + v), size * u, size * v, n)


def sphere_quads(centre, r: float, n_lat: int = 14, n_lon: int = 28, lat_range=(-90.0, 90.0),
                 axis=None) -> np.ndarray:
    """Quads of a sphere (or a latitude band of it) about axis (default z)."""
    lat = np.radians(np.linspace(*lat_range, n_lat + 1))
    lon = np.linspace(0.0, 2.0 * math.pi, n_lon + 1)
    ez = np.array([0.0, 0.0, 1.0]) if axis is None else np.asarray(axis, float)
    ex, ey = _tangents(ez)
    pts = (np.cos(lat)[:, None, None] * (np.cos(lon)[None, :, None] * ex + np.sin(lon)[None, :, None] * ey)
           + np.sin(lat)[:, None, None] * ez)
    g = np.asarray(centre, float) + r * pts
    return np.stack([g[:-1, :-1], g[:-1, 1:], g[1:, 1:], g[1:, :-1]], axis=2).reshape(-1, 4, 3)


def box_quads(ob: Obstacle, n: int = 4) -> np.ndarray:
    """The six faces of a box, each as n x n quads."""
    faces = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        ea, eb, ec = (ob.axes[:, k] * ob.half[k] for k in (a, b, c))
        for sgn in (-1.0, 1.0):
            faces.append(_grid_quads(ob.point + sgn * ea - eb - ec, 2.0 * eb, 2.0 * ec, n))
    return np.concatenate(faces)


def capsule_quads(ob: Obstacle, n_lon: int = 24) -> np.ndarray:
    """A capsule: the cylinder between its ends and a half sphere on each."""
    p, q = np.asarray(ob.point, float), np.asarray(ob.end, float)
    axis = q - p
    length = np.linalg.norm(axis)
    ez = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    ex, ey = _tangents(ez)
    lon = np.linspace(0.0, 2.0 * math.pi, n_lon + 1)
    ring = ob.radius * (np.cos(lon)[:, None] * ex + np.sin(lon)[:, None] * ey)   # [n+1][3]
    s = np.linspace(0.0, 1.0, max(2, int(np.ceil(4 * length / max(ob.radius, 1e-300)))) + 1)
    g = p + s[:, None, None] * axis + ring[None, :, :]
    cyl = np.stack([g[:-1, :-1], g[:-1, 1:], g[1:, 1:], g[1:, :-1]], axis=2).reshape(-1, 4, 3)
    caps = [sphere_quads(p, ob.radius, 6, n_lon, (-90.0, 0.0), ez),
            sphere_quads(q, ob.radius, 6, n_lon, (0.0, 90.0), ez)]
    return np.concatenate([cyl, *caps])


def solid_quads(ob: Obstacle) -> np.ndarray | None:
    """The quads of an obstacle other than a plane (None for a shape this script does not know)."""
    if ob.shape == "sphere":
        return sphere_quads(ob.point, ob.radius)
    if ob.shape == "box":
        return box_quads(ob)
    if ob.shape == "capsule":
        return capsule_quads(ob)
    return None


def quads_bounds(quads) -> tuple[np.ndarray, np.ndarray]:
    pts = np.asarray(quads).reshape(-1, 3)
    return pts.min(axis=0), pts.max(axis=0)


def shaded(quads, rgba) -> np.ndarray:
    """Face colours of quads: rgba lit from LIGHT (Lambert, both sides lit alike)."""
    q = np.asarray(quads)
    nrm = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    light = LIGHT / np.linalg.norm(LIGHT)
    k = 0.45 + 0.55 * np.abs(nrm @ light)
    out = np.tile(np.asarray(rgba, float), (len(q), 1))
    out[:, :3] *= k[:, None]
    return out


# ---------------------------------------------------------------- drawing


class Scene:
    """The obstacles of a run as quads, made once for every frame or panel."""

    def __init__(self, run, steps, stride: int = 1, solids_first: bool = False):
        self.obstacles = obstacles(run)
        self.stride = stride
        self.solids_first = solids_first
        lo, hi = plotting.bounds(*(run.position[k] for k in steps))
        self.cloth_lo, self.cloth_hi = lo, hi
        times = [float(run.time[k]) for k in steps] or [None]
        self._planes = [o for o in self.obstacles if o.shape == "plane"]
        self._solids = [(o, solid_quads(o)) for o in self.obstacles if o.shape != "plane"]
        self._solids = [(o, q) for o, q in self._solids if q is not None]   # a shape not known: not drawn
        # every pose the steps show: the box holds the obstacles wherever they move
        parts = [np.stack([lo, hi])]
        for t in times:
            parts += [np.asarray(quads_bounds(q)) for q in self.planes(t) + self.solids(t)]
        allpts = np.concatenate(parts)
        self.lo, self.hi = allpts.min(axis=0), allpts.max(axis=0)

    def planes(self, t=None) -> list:
        """The plane patches at time t (under the cloth's box of all steps)."""
        return [plane_quads(o.at(t), self.cloth_lo, self.cloth_hi) for o in self._planes]

    def solids(self, t=None) -> list:
        """The solid obstacles' quads at time t (None: at zero offset)."""
        return [q + o.translation(t) for o, q in self._solids]

    def draw(self, ax, pos, t=None, edges: bool = True):
        """The plane patches (behind everything: the cloth cannot be below them)
        and one collection of cloth and solid quads, depth-sorted together;
        with solids_first the solids too are drawn before the cloth: a cloth
        resting 2 mm above a box's top is seen over it from above, while the
        sort by quad centroids put the box's large top quads over the cloth
        (input/table_edge.nml). Obstacles where they are at time t."""
        artists = []
        for q in self.planes(t):
            pc = Poly3DCollection(q, facecolors=shaded(q, TABLE), edgecolors="none", zorder=1)
            ax.add_collection3d(pc)
            artists.append(pc)
        cloth = cloth_quads(pos, self.stride)
        solids = self.solids(t)
        if self.solids_first and solids:
            pc = Poly3DCollection(np.concatenate(solids), facecolors=np.concatenate([shaded(s, SOLID) for s in solids]),
                                  edgecolors="none", zorder=1)
            ax.add_collection3d(pc)
            artists.append(pc)
            solids = []
        quads = [cloth] + solids
        colors = [shaded(cloth, CLOTH)] + [shaded(s, SOLID) for s in solids]
        edge = np.concatenate([np.tile([0.1, 0.15, 0.3, 0.6 if edges else 0.0], (len(cloth), 1))]
                              + [np.zeros((len(s), 4)) for s in solids])
        pc = Poly3DCollection(np.concatenate(quads), facecolors=np.concatenate(colors),
                              edgecolors=edge, linewidths=0.3, zorder=2)
        ax.add_collection3d(pc)
        artists.append(pc)
        return artists


def _axes(ax, scene, units, view, elev, azim, title=None):
    plotting.setup_3d(ax, scene.lo, scene.hi, units, view, title=title)
    if elev is not None or azim is not None:
        e0, a0 = plotting.VIEWS[view]
        ax.view_init(elev=e0 if elev is None else elev, azim=a0 if azim is None else azim)
    ax.computed_zorder = False      # the planes first, then the sorted quads


def lattice_stride(run, max_lines: int) -> int:
    """Every how many lattice lines to draw, so at most about max_lines a direction."""
    return max(1, math.ceil((max(run.nx, run.ny) - 1) / max(max_lines, 1)))


def build_figure(run, steps, units: str, view: str = "iso", elev=None, azim=None,
                 max_lines: int = 64, title: str | None = None, solids_first: bool = False):
    """One 3-D panel a step: the cloth and its obstacles, one box for all panels."""
    scene = Scene(run, steps, lattice_stride(run, max_lines), solids_first)
    n = len(steps)
    ncols = grid_columns(n)
    size = plotting.iso_panel_size(scene.lo, scene.hi)
    fig, axes = plotting.new_figure(n, ncols=ncols, projection="3d", panel_size=size)
    for ax, k in zip(axes, steps):
        scene.draw(ax, run.position[k], float(run.time[k]))
        _axes(ax, scene, units, view, elev, azim, title=f"t = {run.time[k]:.3g} s")
        plotting.shrink_3d_box(ax, plotting.iso_zoom(scene.lo, scene.hi))
    plotting.room_for_3d_labels(fig)
    if title:
        fig.suptitle(title)
    return fig, scene


def section(run, steps, plane=None, zoom: str = "all", hlim=None, vlim=None, max_lines: int = 64):
    """The side sections (contact_section.Section) of the steps: on plane
    ('xz', 'yz', 'xy'), default the vertical plane of the largest motion."""
    from . import contact_section   # it builds on this module's shapes

    if plane is None:
        plane = plotting.side_plane([run.position[k] for k in steps], run.rest_position)
    return contact_section.Section(run, steps, obstacles(run), plane, reach(run), zoom, hlim, vlim,
                                   lattice_stride(run, max_lines))


def panel_title(run, k, units: str) -> str:
    """'t = 0.1 s' and, with /contact, the smallest gap of the step."""
    from .contact_section import gap_text

    title = f"t = {run.time[k]:.3g} s"
    gaps = run.contact.get("min_gap")
    if gaps is not None and np.isfinite(gaps[k]):
        title += f"\nsmallest gap {gap_text(float(gaps[k]), units)}"
    return title


def build_side_figure(run, steps, units: str, plane=None, zoom: str = "all", aspect: str = "equal",
                      hlim=None, vlim=None, title: str | None = None):
    """One 2-D side section a step (contact_section): the cloth's lattice
    lines and the obstacles' outlines, the barrier's reach dashed."""
    sec = section(run, steps, plane, zoom, hlim, vlim)
    n = len(steps)
    ncols = grid_columns(n)
    fig, axes = plotting.new_figure(n, ncols=ncols, panel_size=sec.panel_size(aspect))
    for j, (ax, k) in enumerate(zip(axes, steps)):
        # one vertical label a row where the panels share the range
        sec.draw(ax, k, units, aspect, panel_title(run, k, units), ylabel=zoom != "all" or j % ncols == 0)
    from .contact_section import legend_handles
    fig.legend(handles=legend_handles(sec.obstacles, sec.reach, units), loc="outside lower center",
               ncols=3, fontsize="small")
    if title:
        fig.suptitle(title)
    return fig, sec


def frame_steps(run, frames: int) -> list[int]:
    """At most `frames` output steps, evenly spaced, the first and last included."""
    if frames < 2:
        raise cli.UsageError(f"--frames {frames}: at least 2")
    n = min(frames, run.nt)
    return [int(k) for k in np.unique(np.rint(np.linspace(0, run.nt - 1, n)).astype(int))]


def animation_figure(run, steps, units: str, size_px: int = 400, view: str = "iso", elev=None,
                     azim=None, max_lines: int = 40, solids_first: bool = False, dpi: int = 100):
    """(figure, 3-D axes, scene) every frame of the GIF is drawn on: one
    box for all frames, its axis labels placed inside the square frame
    (plotting.finish, with a frame's title)."""
    scene = Scene(run, steps, lattice_stride(run, max_lines), solids_first)
    fig, (ax,) = plotting.new_figure(1, ncols=1, projection="3d",
                                     panel_size=(size_px / dpi, size_px / dpi))
    fig.set_dpi(dpi)
    _axes(ax, scene, units, view, elev, azim)
    plotting.shrink_3d_box(ax, plotting.iso_zoom(scene.lo, scene.hi))
    plotting.room_for_3d_labels(fig)
    ax.set_title(f"t = {run.time[steps[-1]]:.2f} s", fontsize="medium")
    plotting.finish(fig)
    return fig, ax, scene


def write_animation(run, output: str, units: str, frames: int = 60, size_px: int = 400,
                    fps: float = 12.0, view: str = "iso", elev=None, azim=None,
                    max_lines: int = 40, colors: int = 64, solids_first: bool = False,
                    plane=None, aspect: str = "equal", hlim=None, vlim=None) -> int:
    """A GIF of the run (Pillow): the cloth and obstacles in one fixed box
    (view 'side': one fixed 2-D section, contact_section, of every frame).
    Each frame is reduced to `colors` colours without dithering (flat
    shading compresses well that way: a 400 px frame of 60 takes some
    10-30 KB). Returns the number of frames."""
    from matplotlib.animation import PillowWriter
    from PIL import Image

    if not output.lower().endswith(".gif"):
        raise cli.UsageError(f"--gif {output}: the animation is a .gif")
    steps = frame_steps(run, frames)
    dpi = 100
    if view == "side":
        sec = section(run, steps, plane, "all", hlim, vlim, max_lines)
        fig, (ax,) = plotting.new_figure(1, ncols=1, panel_size=(size_px / dpi, size_px / dpi))
        fig.set_dpi(dpi)
    else:
        fig, ax, scene = animation_figure(run, steps, units, size_px, view, elev, azim, max_lines,
                                          solids_first, dpi)

    class Quantized(PillowWriter):
        """PillowWriter whose frames are reduced to a few colours, undithered."""

        def grab_frame(self, **kwargs):
            super().grab_frame(**kwargs)
            im = self._frames[-1].convert("RGB")
            self._frames[-1] = im.quantize(colors, method=Image.Quantize.MEDIANCUT,
                                           dither=Image.Dither.NONE)

    writer = Quantized(fps=fps)
    artists = []
    with writer.saving(fig, output, dpi):
        for k in steps:
            if view == "side":
                ax.cla()
                sec.draw(ax, k, units, aspect, f"t = {run.time[k]:.2f} s")
                plotting.finish(fig)
            else:
                for a in artists:
                    a.remove()
                artists = scene.draw(ax, run.position[k], float(run.time[k]))
                ax.set_title(f"t = {run.time[k]:.2f} s", fontsize="medium")
            writer.grab_frame()
    return len(steps)


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "contact_plot")
    p.add_argument("run", help="nuno output file (.h5)")
    p.add_argument("--times", type=float, nargs="+", default=None,
                   help="times to show (nearest output step); default: 4 evenly spaced steps")
    p.add_argument("--view", choices=("iso", "side"), default="iso",
                   help="iso: the 3-D box; side: 2-D sections on a vertical plane (--plane), "
                        "obstacles as outlines, the barrier's reach dashed, up up")
    p.add_argument("--elev", type=float, default=None, help="iso: view elevation [degree] (default: the view's)")
    p.add_argument("--azim", type=float, default=None, help="iso: view azimuth [degree] (default: the view's)")
    p.add_argument("--plane", choices=("xz", "yz", "xy"), default=None,
                   help="side: the plane (default: the vertical plane of the largest motion)")
    p.add_argument("--zoom", choices=("all", "each", "obstacles"), default="all",
                   help="side: one range for every panel (all), or each panel its own (each): "
                        "the cloth and the obstacle parts near it; obstacles: each panel on the "
                        "solid obstacles where they are (a gripper's fingers; default all)")
    p.add_argument("--aspect", choices=("equal", "auto"), default="equal",
                   help="side: equal scales, or the vertical stretched to the panel (auto)")
    p.add_argument("--hlim", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                   help="side: the horizontal axis's range (length unit), for every panel")
    p.add_argument("--vlim", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                   help="side: the vertical axis's range (length unit), for every panel")
    p.add_argument("--units", default=None,
                   help="length unit of the labels (default: the file's units attribute)")
    p.add_argument("--title", default=None, help="a title over the panels")
    p.add_argument("--solids-first", action="store_true",
                   help="draw the solid obstacles before the cloth, not depth-sorted with it "
                        "(a cloth lying on a box's top, seen from above)")
    p.add_argument("--gif", default=None, metavar="FILE.gif", help="also write an animation")
    p.add_argument("--frames", type=int, default=60, help="animation: most frames (default 60)")
    p.add_argument("--size", type=int, default=400, help="animation: width and height in pixels (default 400)")
    p.add_argument("--fps", type=float, default=12.0, help="animation: frames per second (default 12)")
    cli.add_output(p, "contact")
    return p


def _body(args):
    # every argument checked before anything is written
    if args.gif is not None and not args.gif.lower().endswith(".gif"):
        raise cli.UsageError(f"--gif {args.gif}: the animation is a .gif")
    if args.size < 100:
        raise cli.UsageError(f"--size {args.size}: at least 100 pixels")
    if args.frames < 2:
        raise cli.UsageError(f"--frames {args.frames}: at least 2")
    if args.view != "side":
        given = [o for o, v in (("--plane", args.plane), ("--hlim", args.hlim), ("--vlim", args.vlim),
                                ("--zoom", args.zoom != "all" or None),
                                ("--aspect", args.aspect != "equal" or None)) if v is not None]
        if given:
            raise cli.UsageError(f"{given[0]} goes with --view side")
    elif args.elev is not None or args.azim is not None or args.solids_first:
        raise cli.UsageError("--elev, --azim and --solids-first go with --view iso")
    for name, lim in (("--hlim", args.hlim), ("--vlim", args.vlim)):
        if lim is not None and not lim[0] < lim[1]:
            raise cli.UsageError(f"{name} {lim[0]:g} {lim[1]:g}: LOW < HIGH")
    run = cli.load_run(args.run)
    units = args.units or run.units()
    steps = choose_steps(run, args.times)
    unknown = sorted({o.shape for o in obstacles(run)} - set(SHAPES))
    if unknown:
        raise ValueError(f"{args.run}: obstacle shape {', '.join(unknown)}: not one this script draws "
                         f"({', '.join(SHAPES)})")
    if args.view == "side":
        fig, _ = build_side_figure(run, steps, units, args.plane, args.zoom, args.aspect, args.hlim, args.vlim,
                                   title=args.title)
    else:
        fig, _ = build_figure(run, steps, units, args.view, args.elev, args.azim, title=args.title,
                              solids_first=args.solids_first)
    plotting.save(fig, args.output or cli.default_output(args.run, "contact"), args.dpi)
    if args.gif:
        write_animation(run, args.gif, units, args.frames, args.size, args.fps, args.view, args.elev, args.azim,
                        solids_first=args.solids_first, plane=args.plane, aspect=args.aspect,
                        hlim=args.hlim, vlim=args.vlim)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
