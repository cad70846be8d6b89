# SPDX-License-Identifier: BSD-2-Clause
"""The scalar model of bench/mg46/pinload.py (issue 46): its block-line
Gauss-Seidel sweep against a dense line-by-line solve, and its deflation
step's A-orthogonality, so that the model's count tables in
docs/performance.md ("Tried: line smoothers and a low-rank correction")
rest on a correct smoother and projection."""
import os
import sys

import numpy as np
import pytest

pytest.importorskip('scipy')
sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', '..', 'bench', 'mg46'))
import pinload  # noqa: E402
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
