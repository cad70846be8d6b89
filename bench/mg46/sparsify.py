#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, open problem 1: non-Galerkin coarse operators of the scalar
model (pinload.py), in the manner of Falgout and Schroder (SIAM J. Sci.
Comput. 36 (2014) C309-C334) and Treister and Yavneh (SISC 2015).

The Galerkin product G = P^T A P of the cubic transfers reaches 4-5
nodes; sparsified(G, pattern, n) keeps only the entries on a given
pattern (the rediscretised operator's reach-2 stencil, 17 points a node
away from the edges) and changes the kept ones of each row as little as
possible (least squares) so that the row's action on the low-degree
polynomials is the Galerkin row's:

    min ||a - g_S||  subject to  sum_{j in S_i} a_j p(x_j - x_i)
                                 = sum_j G_ij p(x_j - x_i)

for p in 1, x, y (degree 1) and x^2, x y, y^2 (degree 2), in the
coarse lattice's spacings, centred at the row's node. Where a row's
stencil cannot meet them all (the constraints are then not independent
or not consistent) the correction is the minimum-norm least-squares one
(numpy's pinv). Rows are corrected one by one, so the result is then
symmetrised: (A + A^T) / 2, which keeps the rows' polynomial action
where the rows are translates of each other (away from the edges).

fixrows(R, S, rows) is variant B: the rediscretised operator R with the
entries of the rows in `rows` and of their columns taken from S (the
sparsified product), symmetric because R and S are.

fitted(G, ...) is positive definite by construction: the coarse
lattice's masses plus the coarse bending triples (1, -2, 1) of the four
line directions with weights >= 0 fitted to G's row moments.
"""
import numpy as np
import scipy.sparse as sp

QMIN = 17   # degree 3: quadratics only in the rows whose stencil holds QMIN nodes (17: the whole reach-2 star)


def monomials(dx, dy, degree):
    """The polynomials of the constraints at offsets (dx, dy), shape
    (len(dx), 3) for degree 1 or (len(dx), 6) for degree 2."""
    cols = [np.ones_like(dx), dx, dy]
    if degree >= 2:
        cols += [dx * dx, dx * dy, dy * dy]
    return np.stack(cols, axis=1).astype(float)


def sparsified(G, pattern, n, degree=2, keep=None, symmetric=True):
    """G (n^2 x n^2, node p = i + n j) sparsified onto the pattern of
    `pattern` (a sparse matrix of the same shape), each row's action on
    the polynomials of `degree` kept (3: quadratics only in the rows whose
    stencil holds QMIN nodes, linears elsewhere); rows not in `keep` (a
    boolean mask; default all) copied from G restricted to the pattern.
    Symmetrised unless symmetric is False."""
    G = G.tocsr()
    Sp = pattern.tocsr()
    N = G.shape[0]
    keep = np.ones(N, dtype=bool) if keep is None else keep
    rows, cols, vals = [], [], []
    for r in range(N):
        gc = G.indices[G.indptr[r]:G.indptr[r + 1]]
        gv = G.data[G.indptr[r]:G.indptr[r + 1]]
        sc = np.sort(Sp.indices[Sp.indptr[r]:Sp.indptr[r + 1]])
        gmap = dict(zip(gc.tolist(), gv.tolist()))
        gs = np.array([gmap.get(c, 0.0) for c in sc.tolist()])
        a = gs
        if keep[r] and sc.size:
            xr, yr = r % n, r // n
            d = degree
            if degree == 3:   # quadratics only where the stencil holds QMIN nodes
                d = 2 if sc.size >= QMIN else 1
            Vg = monomials(gc % n - xr, gc // n - yr, d)
            Vs = monomials(sc % n - xr, sc // n - yr, d)
            t = Vg.T @ gv                  # the Galerkin row's moments
            a = gs + np.linalg.pinv(Vs.T, rcond=1e-10) @ (t - Vs.T @ gs)
        rows.extend([r] * sc.size)
        cols.extend(sc.tolist())
        vals.extend(a.tolist())
    A = sp.csr_matrix((vals, (rows, cols)), shape=G.shape)
    return ((A + A.T) * 0.5).tocsr() if symmetric else A


def fixrows(R, S, rows):
    """Variant B: R with the entries (i, j) for i or j in `rows` (a boolean
    mask) taken from S; symmetric when R and S are."""
    D = sp.diags(rows.astype(float))
    # entries with row or column in `rows`: D M + M D - D M D
    part = lambda M: D @ M + M @ D - D @ M @ D
    return (R - part(R) + part(S)).tocsr()


def band(n, width):
    """The nodes within `width` nodes of an edge (the corners' 2 x 2 nodes
    and the first rows along the free edges for width 2)."""
    jj, ii = np.mgrid[0:n, 0:n]
    d = np.minimum(np.minimum(ii, n - 1 - ii), np.minimum(jj, n - 1 - jj))
    return (d < width).reshape(-1)


# the moments fitted() matches: (exponent of x, of y), centred at the row's node
FIT_MOMENTS = [(2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3),
               (4, 0), (3, 1), (2, 2), (1, 3), (0, 4)]
LINES = ((1, 0), (0, 1), (1, 1), (1, -1))


def triples(n, free):
    """The second differences (1, -2, 1) of the four line directions on an
    n x n lattice: their nodes (nt, 3), coefficients (nt, 3; zero at
    constrained nodes, free False) and squared steps |s|^2 in spacings."""
    nodes, s2 = [], []
    jj, ii = np.mgrid[0:n, 0:n]
    for si, sj in LINES:
        ok = ((ii + 2 * si >= 0) & (ii + 2 * si < n) & (jj + 2 * sj >= 0) & (jj + 2 * sj < n)).reshape(-1)
        i0, j0 = ii.reshape(-1)[ok], jj.reshape(-1)[ok]
        nodes.append(np.stack([(i0 + c * si) + n * (j0 + c * sj) for c in range(3)], axis=1))
        s2.append(np.full(i0.size, float(si * si + sj * sj)))
    nodes = np.concatenate(nodes)
    coefs = np.array([1.0, -2.0, 1.0]) * free[nodes]
    return nodes, coefs, np.concatenate(s2)


def row_moments(M, n, moments):
    """sum_j M_ij (x_j - x_i)^a (y_j - y_i)^b for each row i and (a, b):
    shape (n^2, len(moments))."""
    C = M.tocoo()
    dx, dy = C.col % n - C.row % n, C.col // n - C.row // n
    out = np.zeros((M.shape[0], len(moments)))
    for k, (a, b) in enumerate(moments):
        np.add.at(out[:, k], C.row, C.data * dx.astype(float) ** a * dy.astype(float) ** b)
    return out


def assemble(n, nodes, coefs, w, diag):
    """diag + sum_t w_t c_t c_t^T (n^2 x n^2, CSR)."""
    r = np.repeat(nodes, 3, axis=1).ravel()
    c = np.tile(nodes, (1, 3)).ravel()
    v = (w[:, None, None] * coefs[:, :, None] * coefs[:, None, :]).reshape(-1)
    return (sp.csr_matrix((v, (r, c)), shape=(n * n, n * n)) + sp.diags(diag)).tocsr()


def fitted(G, n, free, w0, mass, floor=0.1, reg=1e-3):
    """An SPD coarse operator on the rediscretised reach-2 pattern fitted to
    G: diag(mass) (the coarse lattice's a m, n^2) plus
    sum_t w_t c_t c_t^T over the coarse triples of triples(), weights
    w >= floor w0 / |s|^2 (w0: the rediscretised weight of an axis triple,
    coef / H^2), chosen by bounded least squares so that each free row's
    moments FIT_MOMENTS (degrees 2-4, each scaled by 2^-degree) are G's,
    plus reg ||w / w_R - 1||^2. A whole triple annihilates constants and
    linears, as G's bending does. SPD by construction (a positive diagonal
    plus positive multiples of c c^T)."""
    from scipy.optimize import lsq_linear
    nodes, coefs, s2 = triples(n, free.astype(float))
    wR = w0 / s2
    nt, K = nodes.shape[0], len(FIT_MOMENTS)
    x, y = nodes % n, nodes // n
    rows, cols, vals = [], [], []
    for e in range(3):
        for k, (a, b) in enumerate(FIT_MOMENTS):
            tp = sum(coefs[:, q] * (x[:, q] - x[:, e]).astype(float) ** a * (y[:, q] - y[:, e]).astype(float) ** b
                     for q in range(3))
            rows.append(nodes[:, e] * K + k)
            cols.append(np.arange(nt))
            vals.append(coefs[:, e] * tp / 2.0 ** (a + b))
    rows, cols, vals = map(np.concatenate, (rows, cols, vals))
    keep = free[rows // K] & (vals != 0.0)
    C = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n * n * K, nt))
    target = row_moments(G, n, FIT_MOMENTS) / np.array([2.0 ** (a + b) for a, b in FIT_MOMENTS])
    target[~free] = 0.0
    # unknowns u = w / wR, so that the regularisation and the bounds are relative
    Cu = C @ sp.diags(wR)
    scale = np.abs(Cu).max()
    A = sp.vstack([Cu / scale, np.sqrt(reg) * sp.identity(nt)]).tocsr()
    rhs = np.concatenate([target.ravel() / scale, np.sqrt(reg) * np.ones(nt)])
    res = lsq_linear(A, rhs, bounds=(floor, np.inf), lsmr_tol='auto', max_iter=200)
    return assemble(n, nodes, coefs, res.x * wR, mass), res
