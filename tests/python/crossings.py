# SPDX-License-Identifier: BSD-2-Clause
"""A check that a cloth never passes through itself, written here in numpy
from the positions of the output alone (independent of nuno's contact
kernels): the cloth's surface is the lattice's triangles, each quad
(i, j)..(i+1, j+1) split along its (i, j)-(i+1, j+1) diagonal (the split of
docs/self-contact.md, "Primitives"). Between two consecutive output steps a
node crosses a triangle that does not have it as a corner when its signed
distance to the triangle's plane changes sign while it is near (|distance|
below `near`) and its projection lies inside the triangle (barycentric
coordinates >= -tol) at both steps. With output at every time step a node
moves a small part of the lattice spacing between steps, so a crossing
cannot slip between two output steps unseen; a node that passes beside a
triangle's edge is not inside it and is not counted."""
import numpy as np


def triangles(ny, nx):
    """The lattice's triangles as (ntri, 3) flat node numbers g = i + nx j."""
    j, i = np.meshgrid(np.arange(ny - 1), np.arange(nx - 1), indexing="ij")
    c1 = (i + nx * j).ravel()
    c2, c3, c4 = c1 + 1, c1 + nx, c1 + nx + 1
    return np.concatenate([np.stack([c1, c2, c4], 1), np.stack([c1, c4, c3], 1)])


def _side_and_inside(x, tri, near, tol):
    """Signed distances s[node, tri] of every node to every triangle's
    plane, and whether the node is near and projects inside."""
    a, b, c = x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n, axis=1)
    n = n / area2[:, None]
    d = x[:, None, :] - a[None, :, :]                     # [node][tri][3]
    s = np.einsum("ptk,tk->pt", d, n)
    q = d - s[..., None] * n[None]                        # projection, from a
    e1, e2 = (b - a)[None], (c - a)[None]
    d11, d12, d22 = (e1 * e1).sum(-1), (e1 * e2).sum(-1), (e2 * e2).sum(-1)
    q1, q2 = (q * e1).sum(-1), (q * e2).sum(-1)
    det = d11 * d22 - d12 ** 2
    u = (d22 * q1 - d12 * q2) / det
    v = (d11 * q2 - d12 * q1) / det
    inside = (u >= -tol) & (v >= -tol) & (u + v <= 1 + tol) & (np.abs(s) < near)
    return s, inside


def crossings(position, near, tol=1e-9):
    """Node-triangle crossings between consecutive frames of position
    [nt][ny][nx][3]: a list of (frame k, node g, triangle number) where the
    node is on the other side of the triangle at frame k than at k - 1."""
    nt, ny, nx, _ = position.shape
    tri = triangles(ny, nx)
    own = np.zeros((ny * nx, len(tri)), bool)
    for c in range(3):
        own[tri[:, c], np.arange(len(tri))] = True
    found = []
    s0, in0 = _side_and_inside(position[0].reshape(-1, 3), tri, near, tol)
    for k in range(1, nt):
        s1, in1 = _side_and_inside(position[k].reshape(-1, 3), tri, near, tol)
        flip = (np.sign(s0) != np.sign(s1)) & in0 & in1 & ~own
        for g, t in zip(*np.nonzero(flip)):
            found.append((k, int(g), int(t)))
        s0, in0 = s1, in1
    return found
