#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""What `contact_faces` changes in a scene: the cloth's elements against
its spheres and capsules, read from nuno's HDF5 output (docs/contact.md,
"Faces and edges", the paragraph on the shipped scenes).

    python3 bench/face_gaps.py drape_off.h5 drape_on.h5
    python3 bench/face_gaps.py gripper_off.h5 gripper_on.h5 --time 2.0

For each file: the run's Newton and inner iterations and retried steps
(/diagnostics at its last output, /run retried_steps), then the smallest
gap over the output steps of each kind of element: the nodes, the x- and
y-links, the diagonals (i,j)-(i+1,j+1) and the two triangles of each
quad (nuno's split, docs/contact.md), with the time and the element where
it is smallest. A gap is the exact Euclidean distance of the element to
the obstacle's core (a sphere's centre, a capsule's axis segment) less
the radius and contact_thickness [length of the run, m for SI]; negative:
the element cuts the obstacle that deep. The obstacles' poses are those
of postprocess.contact_plot (the keyframes of /config/contact, linear
between keyframes, as obstacle_motion moves them), at each output time.
Output steps that are the TS's interpolant (after a retried step the
steps no longer end on the output times) are linear in the positions
between two accepted states and may cut by what a chord sags.
With two files: the largest node distance between them at each common
output time, and over the run. Planes need only the nodes (a plane and
a flat element meet first at a node) and are left out; a box is not
measured (exit 2).

--time T prints the gaps at the output time nearest T as well.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from postprocess import contact_plot  # noqa: E402
from postprocess.reader import read_run  # noqa: E402

TINY = 1.0e-300


def point_segment(p, a, b):
    """Distances [m] of points p [m][3] to segments a-b [m][3] (broadcast)."""
    ab = b - a
    t = np.einsum("...k,...k->...", p - a, ab) / np.maximum(np.einsum("...k,...k->...", ab, ab), TINY)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def segment_segment(p1, q1, p2, q2):
    """Distances [m] between segments p1-q1 and p2-q2 (broadcast; Ericson,
    Real-Time Collision Detection 5.1.9, exact also for parallel segments)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...k,...k->...", d1, d1)
    e = np.einsum("...k,...k->...", d2, d2)
    f = np.einsum("...k,...k->...", d2, r)
    c = np.einsum("...k,...k->...", d1, r)
    b = np.einsum("...k,...k->...", d1, d2)
    denom = a * e - b * b
    s = np.where(denom > 1e-14 * a * e, np.clip((b * f - c * e) / np.maximum(denom, TINY), 0, 1), 0.0)
    t = (b * s + f) / np.maximum(e, TINY)
    s = np.where(t < 0, np.clip(-c / np.maximum(a, TINY), 0, 1), s)
    s = np.where(t > 1, np.clip((b - c) / np.maximum(a, TINY), 0, 1), s)
    t = np.clip(t, 0, 1)
    c1 = p1 + s[..., None] * d1
    c2 = p2 + t[..., None] * d2
    return np.linalg.norm(c1 - c2, axis=-1)


def point_triangle(p, a, b, c):
    """Distances [m] of points p to triangles abc (broadcast): the plane's
    distance where p's foot falls inside, else the nearest edge's."""
    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n, axis=-1)
    n = n / np.maximum(nn, TINY)[..., None]
    h = np.einsum("...k,...k->...", p - a, n)
    foot = p - h[..., None] * n
    inside = np.ones(np.broadcast(h, nn).shape, dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...k,...k->...", np.cross(v - u, foot - u), n) >= 0
    edge = np.minimum(np.minimum(point_segment(p, a, b), point_segment(p, b, c)), point_segment(p, c, a))
    return np.where(inside, np.abs(h), edge)


def segment_triangle(p, q, a, b, c):
    """Distances [m] of segment p-q to triangles abc (broadcast): 0 where it
    crosses one, else the least of its ends against the triangle and of it
    against the triangle's edges."""
    d = np.minimum(point_triangle(p, a, b, c), point_triangle(q, a, b, c))
    for u, v in ((a, b), (b, c), (c, a)):
        d = np.minimum(d, segment_segment(p, q, u, v))
    n = np.cross(b - a, c - a)
    hp = np.einsum("...k,...k->...", p - a, n)
    hq = np.einsum("...k,...k->...", q - a, n)
    cross = hp * hq < 0
    w = hp / np.where(cross, hp - hq, 1.0)
    x = p + w[..., None] * (q - p)
    inside = cross.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...k,...k->...", np.cross(v - u, x - u), n) >= 0
    return np.where(inside, 0.0, d)


def elements(pos):
    """The cloth's elements of one output step, pos [ny][nx][3] (node (i, j)
    at pos[j, i]): {kind: (arrays of end points, labels)}."""
    p00, p10, p01, p11 = pos[:-1, :-1], pos[:-1, 1:], pos[1:, :-1], pos[1:, 1:]
    return {
        "nodes": (pos,),
        "x-links": (pos[:, :-1], pos[:, 1:]),
        "y-links": (pos[:-1, :], pos[1:, :]),
        "diagonals": (p00, p11),
        "triangles": np.stack([np.stack([p00, p10, p11], 0), np.stack([p00, p11, p01], 0)], 0),
    }


def gaps(pos, ob, thickness):
    """{kind: gap array [m]} of one output step against obstacle ob."""
    el = elements(pos)
    if ob.shape == "sphere":
        cen, cut = ob.point, ob.radius + thickness
        tri = el["triangles"]
        return {
            "nodes": np.linalg.norm(pos - cen, axis=-1) - cut,
            "x-links": point_segment(cen, *el["x-links"]) - cut,
            "y-links": point_segment(cen, *el["y-links"]) - cut,
            "diagonals": point_segment(cen, *el["diagonals"]) - cut,
            "triangles": point_triangle(cen, tri[:, 0], tri[:, 1], tri[:, 2]) - cut,
        }
    if ob.shape == "capsule":
        a, b, cut = ob.point, ob.end, ob.radius + thickness
        tri = el["triangles"]
        return {
            "nodes": point_segment(pos, a, b) - cut,
            "x-links": segment_segment(a, b, *el["x-links"]) - cut,
            "y-links": segment_segment(a, b, *el["y-links"]) - cut,
            "diagonals": segment_segment(a, b, *el["diagonals"]) - cut,
            "triangles": segment_triangle(a, b, tri[:, 0], tri[:, 1], tri[:, 2]) - cut,
        }
    raise ValueError(ob.shape)


def thickness_of(run):
    keys = run.config.get("contact", {}) or {}
    return float(np.ravel(np.asarray(keys.get("contact_thickness", 0.0), dtype=float))[0])


def where(kind, idx):
    """The element's lattice index as text (idx of the gap array, C order [..., j, i])."""
    if kind == "triangles":
        half, j, i = idx
        return f"quad ({i},{j}) triangle {half + 1}"
    j, i = idx
    return f"({i},{j})"


def report(path, at_time=None):
    run = read_run(path)
    obs = [o for o in contact_plot.obstacles(run) if o.shape != "plane"]
    if any(o.shape == "box" for o in obs):
        print(f"{path}: a box is not measured here", file=sys.stderr)
        sys.exit(2)
    attrs = dict(run.file["run"].attrs)
    diag = run.file["diagnostics"]
    faces = (run.config.get("contact", {}) or {}).get("contact_faces", "?")
    print(f"{path}: build {attrs.get('git_commit', b'?').decode()}, {int(attrs.get('n_ranks', 0))} ranks, "
          f"contact_faces = {faces}, t = {float(run.time[-1]):g}: Newton {int(diag['newton_iterations'][-1])}, "
          f"inner {int(diag['linear_iterations'][-1])}, rejected {int(diag['rejected_steps'][-1])}, "
          f"retried {int(attrs.get('retried_steps', -1))}")
    th = thickness_of(run)
    near = int(np.argmin(np.abs(run.time - at_time))) if at_time is not None else None
    for k, ob0 in enumerate(contact_plot.obstacles(run)):
        if ob0.shape == "plane":
            continue
        best = {}
        for s in range(run.nt):
            t = float(run.time[s])
            g = gaps(np.asarray(run.position[s]), ob0.at(t), th)
            for kind, arr in g.items():
                idx = np.unravel_index(int(np.argmin(arr)), arr.shape)
                if kind not in best or arr[idx] < best[kind][0]:
                    best[kind] = (float(arr[idx]), t, where(kind, idx))
            if s == near:
                line = ", ".join(f"{kind} {float(np.min(arr)):.3e}" for kind, arr in g.items())
                print(f"  obstacle {k + 1} ({ob0.shape}) at t = {t:g}: least gap {line}")
        for kind, (gmin, t, at) in best.items():
            print(f"  obstacle {k + 1} ({ob0.shape}): least gap of the {kind:9s} {gmin: .3e} at t = {t:g}, {at}")
    return run


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", help="one or two nuno HDF5 outputs of the same scene (off, on)")
    ap.add_argument("--time", type=float, default=None, help="also print the gaps at this output time [s]")
    args = ap.parse_args(argv)
    runs = [report(f, args.time) for f in args.files]
    if len(runs) == 2:
        a, b = runs
        worst, last = (0.0, 0.0), None
        for s in range(a.nt):
            t = float(a.time[s])
            m = np.flatnonzero(np.abs(b.time - t) <= 1e-9 * max(1.0, abs(t)))
            if m.size == 0:
                continue
            d = float(np.max(np.linalg.norm(np.asarray(a.position[s]) - np.asarray(b.position[m[0]]), axis=-1)))
            last = (d, t)
            if d > worst[0]:
                worst = (d, t)
        if last is None:
            print("the two runs share no output time")
        else:
            print(f"largest node distance between the two runs: {worst[0]:.3e} at t = {worst[1]:g} "
                  f"(at their last common output, t = {last[1]:g}: {last[0]:.3e})")

if __name__ == "__main__":
    main()
