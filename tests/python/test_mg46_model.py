# SPDX-License-Identifier: BSD-2-Clause
"""The scalar model of bench/mg46/pinload.py (issue 46): its block-line
Gauss-Seidel sweep against a dense line-by-line solve, its deflation
step's A-orthogonality, and its sparsified (non-Galerkin) coarse
operators (bench/mg46/sparsify.py) against their defining properties, so
that the model's count tables in docs/performance.md ("Tried also")
rest on a correct smoother, projection and sparsification."""
import os
import sys

import numpy as np
import pytest

pytest.importorskip('scipy')
import scipy.sparse as sp  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', '..', 'bench', 'mg46'))
import pinload  # noqa: E402
import sparsify  # noqa: E402
from model import bending  # noqa: E402


def dense_line_sweep(A, lines, x, b):
    """Block Gauss-Seidel written out: each line's block solved densely with
    the newest values of every other line."""
    A = A.toarray()
    x = x.copy()
    for ln in lines:
        rest = np.setdiff1d(np.arange(A.shape[0]), ln)
        rhs = b[ln] - A[np.ix_(ln, rest)] @ x[rest]
        x[ln] = np.linalg.solve(A[np.ix_(ln, ln)], rhs)
    return x


@pytest.mark.parametrize('kind', ['rows', 'cols', 'zebra'])
def test_line_sweep_matches_dense_block_gauss_seidel(kind):
    n = 9
    A = pinload.operator(n)
    b = np.random.default_rng(3).standard_normal(n * n)
    x0 = np.random.default_rng(4).standard_normal(n * n)
    lines = pinload.line_orders(n, kind)[0]
    sweep = pinload.LineSweep(A, lines)
    got = x0 + sweep.apply(b - A @ x0)
    want = dense_line_sweep(A, lines, x0, b)
    assert np.abs(got - want).max() <= 1e-9 * np.abs(want).max()


def test_row_sweep_solves_rows_that_do_not_couple():
    # bending along the rows only plus the mass: the rows are independent,
    # so one row sweep from any start is the exact solution
    n = 9
    A = bending(n, 1.0, pins=False, lines=((1, 0),))
    xs = np.random.default_rng(5).standard_normal(n * n)
    b = A @ xs
    sweep = pinload.LineSweep(A, pinload.line_orders(n, 'rows')[0])
    x = np.zeros(n * n) + sweep.apply(b)
    assert np.abs(x - xs).max() <= 1e-9 * np.abs(xs).max()


@pytest.mark.parametrize('kind', ['eig', 'window'])
def test_deflation_leaves_residual_orthogonal_to_its_span(kind):
    pinload.DEFLATE, pinload.DEFLATE_KIND, pinload.WINDOW = 4, kind, 2
    try:
        levs, _, _ = pinload.hierarchy(17, False)
    finally:
        pinload.DEFLATE, pinload.DEFLATE_KIND, pinload.WINDOW = 0, 'eig', 2
    lv = levs[0]
    b = pinload.load(17, 'gravity')
    x = pinload.deflate(lv, np.random.default_rng(6).standard_normal(b.size), b)
    r = b - lv.A @ x
    assert np.abs(lv.W.T @ r).max() <= 1e-9 * np.abs(lv.W.T @ b).max()


def level2(n, kind):
    """Level 2 of pinload's hierarchy of kind `kind`, its lattice size and
    its free (not pinned) nodes."""
    levs, _, _ = pinload.hierarchy(n, kind, 2)
    nc = (n - 1) // 2 + 1
    free = np.ones(nc * nc, dtype=bool)
    free[pinload.pins(nc)] = False
    return levs[1].A, nc, free


def test_sparsified_rows_keep_the_reach2_pattern_and_the_galerkin_moments():
    # P^T A P of the cubic transfers sparsified row by row: every free row on
    # the rediscretised operator's pattern, and where its stencil is whole
    # (17 nodes) its action on 1, x, y, x^2, xy, y^2 centred at the row's
    # node is the Galerkin row's, computed here densely from coordinates;
    # symmetrised, the level is symmetric on the same pattern
    G, nc, free = level2(33, 'g')
    R, _, _ = level2(33, 'r')
    R = R.tocsr()
    R.eliminate_zeros()
    rows = sparsify.sparsified(G, R, nc, 2, keep=free, symmetric=False).toarray()
    S, _, _ = level2(33, 's')
    G, R, S = G.toarray(), R.toarray(), S.toarray()
    assert np.abs(S - S.T).max() <= 1e-12 * np.abs(S).max()
    assert not np.any((S != 0) & (R == 0))
    assert not np.any((rows != 0) & (R == 0))
    x = np.arange(nc * nc) % nc
    y = np.arange(nc * nc) // nc
    whole = np.flatnonzero(free & ((R != 0).sum(axis=1) == 17))
    assert whole.size == (nc - 4) ** 2 - 2   # all but the two next to a pin diagonally
    for r in whole:
        dx, dy = x - x[r], y - y[r]
        for p in (np.ones(nc * nc), dx, dy, dx * dx, dx * dy, dy * dy):
            assert abs(rows[r] @ p - G[r] @ p) <= 1e-9 * np.abs(G[r]).sum() * 4
    # and entries were dropped and moved
    assert np.abs(rows - G).max() > 1e-3 * np.abs(G).max()


def test_sparsified_level_is_nearer_the_galerkin_product_at_33():
    # the point of the non-Galerkin levels: the smallest generalised
    # eigenvalue of level 2 against P^T A P (free nodes), 0.243 for the
    # rediscretised one (its correction overshoots up to 4.1x at the
    # corners), above 0.5 for the sparsified one (0.68 measured)
    import scipy.linalg as sl
    G, _, free = level2(33, 'g')
    Gf = G.toarray()[np.ix_(free, free)]
    low = {}
    for kind in 'rs':
        A, _, _ = level2(33, kind)
        low[kind] = sl.eigh(A.toarray()[np.ix_(free, free)], Gf, eigvals_only=True)[0]
    assert 0.2 < low['r'] < 0.3
    assert low['s'] > 0.5


def test_fixrows_takes_the_rows_and_columns_of_the_band_from_the_second():
    rng = np.random.default_rng(7)
    R = rng.standard_normal((12, 12))
    R = R + R.T
    S = rng.standard_normal((12, 12))
    S = S + S.T
    rows = np.zeros(12, dtype=bool)
    rows[[0, 5, 11]] = True
    F = sparsify.fixrows(sp.csr_matrix(R), sp.csr_matrix(S), rows).toarray()
    band = rows[:, None] | rows[None, :]
    assert np.array_equal(F[band], S[band])
    assert np.array_equal(F[~band], R[~band])


def test_fitted_triples_recover_a_triple_operator_and_stay_definite():
    # fitted to the rediscretised operator itself (masses plus the coarse
    # triples with weight coef / (|s|^2 H^2)), the bounded least squares
    # finds those weights and gives it back; fitted to P^T A P (which no
    # sum of reach-2 triples matches), its level is still positive definite
    nc = 17
    free = np.ones(nc * nc, dtype=bool)
    free[pinload.pins(nc)] = False
    R = pinload.operator(nc)
    A, res = sparsify.fitted(R, nc, free, pinload.COEF * (nc - 1) ** 2, pinload.mass_diagonal(nc))
    assert np.abs(res.x - 1.0).max() <= 1e-6
    assert np.abs((A - R).toarray()).max() <= 1e-8 * np.abs(R).max()
    E, _, _ = level2(33, 'e')
    assert np.linalg.eigvalsh(E.toarray())[0] > 0.0
