# SPDX-License-Identifier: BSD-2-Clause
"""Contact of the cloth's triangles and edges with obstacles (issue 47 item 3;
docs/design.md, "Contact", faces and edges): obstacles thinner than the
lattice spacing, rising at 0.1 m/s into a free 11 x 11 cloth of spacing
1 cm at rest (no gravity), between its nodes, where no node comes within
the barrier's reach, with contact_faces = .true.:

- a capsule of radius 1 mm along y, halfway between two node columns;
- a box turned 45 degrees about x, its top edge along x halfway between two
  node rows (across the middle of a row of quads), 4 cm long, its two top
  corners inside triangles, so that they press into triangles too;
- a sphere of radius 2 mm under the centroid of one triangle.

Each lifts the cloth: the run completes with no retried step, and after
contact the cloth's centre of mass rises with the obstacle (at the end
above 40 % of the obstacle's top's rise beyond the cloth, and moving up
at more than half its speed). No cloth triangle or edge is inside the
obstacle at any output step: the gaps are computed here from the output
positions with closed forms of our own (the distance from the capsule's
axis to each cloth edge, projected on the x-z plane where the axis is a
point; the sphere's centre to each triangle, Ericson's closest point; the
box's ridge to each cloth edge, Ericson's closest points of two segments),
not from nuno's; every one at least the acceptance floor, 1e-6
contact_dhat. Each on 1 and 2 ranks (11 rows: the strips meet between
rows 5 and 6, where the box's ridge lies and the capsule crosses), and
1 and 2 ranks agree.

On main before this change the three obstacles pass through the cloth
(contact was of the nodes only): the cloth never moves."""
import numpy as np
import pytest

from nunorun import run
from postprocess.reader import read_run

DHAT = 1e-3
V = 0.1           # the obstacles' speed [m/s]
H = 0.01          # lattice spacing [m]
Z0 = -3e-3        # the obstacle's top at t = 0 [m]
RISE = 0.012      # its travel [m]
T_END = RISE / V


def groups(obstacle, faces=True):
    keys = (f"obstacle_n_keyframes(1)=2 obstacle_time(1:2,1)=0.0,{T_END!r} "
            f"obstacle_offset(:,2,1)=0.0,0.0,{RISE!r}")
    return dict(
        scene="scene='flat' gravity=0.0,0.0,0.0 units='SI'",
        lattice="nx=11 ny=11 lx=0.1 ly=0.1 total_mass=0.001 mass_distribution='area'",
        material="e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='energy' k_b=1e-3 eta_b=1e-6",
        contact=(f"n_obstacles=1 {obstacle} {keys} contact_dhat={DHAT} contact_stiffness=1.0 "
                 f"contact_faces={'.true.' if faces else '.false.'}"),
        time=f"t_end={T_END!r} dt=1e-3",
        output=f"output_interval={T_END / 24!r}",
    )


R_CAP = 1e-3
XC = 5.5 * H      # halfway between columns 5 and 6
CAPSULE = (f"obstacle_shape(1)='capsule' obstacle_point(:,1)={XC!r},-0.01,{Z0 - R_CAP!r} "
           f"obstacle_end(:,1)={XC!r},0.11,{Z0 - R_CAP!r} obstacle_radius(1)={R_CAP!r}")

HB = 4e-3         # the box's half extents across its ridge [m]
YC = 5.5 * H      # the ridge halfway between rows 5 and 6
A = float(1.0 / np.sqrt(2.0))
ZB = float(Z0 - HB * np.sqrt(2.0))   # the box's centre: its ridge at Z0
XB = 0.0525       # the ridge from x = 0.0325 to 0.0725: its ends inside quads
BOX = (f"obstacle_shape(1)='box' obstacle_point(:,1)={XB!r},{YC!r},{ZB!r} "
       f"obstacle_normal(:,1)=0.0,{-A!r},{A!r} obstacle_axis(:,1)=1.0,0.0,0.0 "
       f"obstacle_half_size(:,1)=0.02,{HB!r},{HB!r}")

R_SPH = 2e-3
SX, SY = 5 * H + 2 * H / 3, 5 * H + H / 3    # the centroid of triangle (5,5),(6,5),(6,6)
SPHERE = (f"obstacle_shape(1)='sphere' obstacle_point(:,1)={SX!r},{SY!r},{Z0 - R_SPH!r} "
          f"obstacle_radius(1)={R_SPH!r}")


def segment_point_2d(p, q, c):
    """Distance from point c to segments p-q (arrays [..., 2])."""
    d = q - p
    t = np.clip(np.sum((c - p) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p + t[..., None] * d - c, axis=-1)


def edges(x):
    """The cloth's edges (x-links, y-links, the quads' main diagonals) as
    end-point arrays p, q [..., 3] of positions x [ny][nx][3]."""
    p = [x[:, :-1], x[:-1, :], x[:-1, :-1]]
    q = [x[:, 1:], x[1:, :], x[1:, 1:]]
    return (np.concatenate([a.reshape(-1, 3) for a in p]), np.concatenate([b.reshape(-1, 3) for b in q]))


def capsule_gap(x, top):
    """Smallest gap of the cloth's edges to the capsule (axis along y at x =
    XC, z = top - R_CAP): in the x-z plane the axis is a point."""
    p, q = edges(x)
    c = np.array([XC, top - R_CAP])
    return segment_point_2d(p[:, [0, 2]], q[:, [0, 2]], c).min() - R_CAP


def segment_segment(p1, q1, p2, q2):
    """Distance between segments p1-q1 (arrays [n, 3]) and one segment
    p2-q2 (Ericson, Real-Time Collision Detection, 5.1.9, vectorised)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = np.sum(d1 * d1, axis=-1), d2 @ d2, r @ d2
    c, b = np.sum(r * d1, axis=-1), d1 @ d2
    den = a * e - b * b
    s = np.where(den > 1e-30 * a * e, np.clip((b * f - c * e) / np.where(den > 0, den, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / e
    s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p1 + s[:, None] * d1 - (p2 + t[:, None] * d2), axis=-1)


def ridge_gap(x, top):
    """Smallest distance of the cloth's edges to the box's ridge, the
    segment x in XB -/+ 0.02 at y = YC, z = top (where the cloth rests on
    the box: its faces slope away at 45 degrees)."""
    p, q = edges(x)
    return segment_segment(p, q, np.array([XB - 0.02, YC, top]), np.array([XB + 0.02, YC, top])).min()


def closest_on_triangle(p, a, b, c):
    """Ericson's closest point of triangle a b c to p (Real-Time Collision
    Detection, 5.1.5), one triangle."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = ab @ ap, ac @ ap
    if d1 <= 0 and d2 <= 0:
        return a
    bp = p - b
    d3, d4 = ab @ bp, ac @ bp
    if d3 >= 0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return a + d1 / (d1 - d3) * ab
    cp = p - c
    d5, d6 = ab @ cp, ac @ cp
    if d6 >= 0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return a + d2 / (d2 - d6) * ac
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)
    den = 1.0 / (va + vb + vc)
    return a + ab * (vb * den) + ac * (vc * den)


def sphere_gap(x, top):
    """Smallest gap of the cloth's triangles (main-diagonal split) to the
    sphere whose top is at z = top."""
    c = np.array([SX, SY, top - R_SPH])
    best = np.inf
    ny, nx = x.shape[:2]
    for j in range(ny - 1):
        for i in range(nx - 1):
            for tri in ((x[j, i], x[j, i + 1], x[j + 1, i + 1]), (x[j, i], x[j + 1, i + 1], x[j + 1, i])):
                best = min(best, np.linalg.norm(closest_on_triangle(c, *tri) - c))
    return best - R_SPH


CASES = {"capsule": (CAPSULE, capsule_gap), "box_edge": (BOX, ridge_gap), "sphere": (SPHERE, sphere_gap)}


def lift(tmp_path, case, nranks):
    obstacle, gap = CASES[case]
    tmp_path.mkdir()
    proc, h5 = run(tmp_path, case, nranks=nranks, timeout=300, **groups(obstacle))
    with read_run(str(h5)) as r:
        retried = r.run_info["retried_steps"]
        t = np.asarray(r.time)
        x = np.asarray(r.position)                   # [t][ny][nx][3]
    top = Z0 + V * t
    gaps = np.array([gap(x[k], top[k]) for k in range(len(t))])
    com = x[..., 2].mean(axis=(1, 2))                # equal masses but the edges': a lower bound of motion is enough
    assert retried == 0, proc.stdout[-2000:]
    assert np.all(gaps >= 1e-6 * DHAT), (case, gaps.min())            # none inside nor below the floor
    assert com[-1] > 0.4 * top[-1], (com[-1], top[-1])                # lifted with the obstacle
    vz = (com[-1] - com[-2]) / (t[-1] - t[-2])
    assert vz > 0.5 * V, vz / V
    return x


@pytest.mark.parametrize("case", sorted(CASES))
def test_thin_obstacle_lifts_the_cloth(tmp_path, case):
    x1 = lift(tmp_path / "one", case, 1)
    x2 = lift(tmp_path / "two", case, 2)
    assert np.abs(x1 - x2).max() < 1e-9, np.abs(x1 - x2).max()      # 1 and 2 ranks agree


def test_without_faces_the_capsule_passes_through(tmp_path):
    """contact_faces = .false. (input/README.md, the default): the nodes alone;
    the capsule between two columns then passes through the cloth's edges,
    and the cloth never moves."""
    g = groups(CAPSULE, faces=False)
    _, h5 = run(tmp_path, "nodes", **g)
    with read_run(str(h5)) as r:
        t = np.asarray(r.time)
        x = np.asarray(r.position)
    assert np.abs(x[-1] - x[0]).max() < 1e-12
    assert min(capsule_gap(x[k], Z0 + V * t[k]) for k in range(len(t))) < 0.0    # through the edges
