#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 3: the scalar model (model.py) under hang's own load.

The growth of the cycles with N that is left after the rediscretised
coarse levels shows only under the load of hang's first step (gravity on
the area masses, zero at the two pinned corners), not under a random
right-hand side (redisc_gmres.py: 6 iterations at 33..257). This script
counts right-preconditioned GMRES iterations to 1e-3 (the bw mode's
tolerance) with one cycle as the preconditioner, for two hierarchies on
the same transfers (P cubic, its columns at the pinned coarse nodes zero;
R bilinear, no right-hand side at the pinned coarse nodes; one symmetric
Gauss-Seidel sweep a smoothing):

  r  the rediscretised coarse levels (nuno's default with bending),
  g  the Galerkin products P^T A P of the same P (pinned rows a m I),

and the cycles K (kaskade), V and W. With --eig it prints the extreme
generalised eigenvalues of the rediscretised level 2 against P^T A P and
where the smallest one's vector peaks (the free nodes; < 1: the
rediscretised operator is softer there, its correction overshoots by the
inverse).

With --where: the residual one kaskade cycle leaves, and how much of it
lies near the pins.

With --pins edge the whole edge j = ny-1 is pinned instead of its corners.

  python3 pinload.py [--load gravity|random] [--pins corners|edge] [--eig | --where] SIZES
"""
import argparse
import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from model import bending, prolong, Level, ETA_B, K_B, A_SHIFT, MASS

COEF = ETA_B + K_B / A_SHIFT


PINS = 'corners'


def pins(n):
    """hang's two pinned corners of row n-1, or (PINS = 'edge') all of it."""
    if PINS == 'edge':
        return [i + n * (n - 1) for i in range(n)]
    return [0 + n * (n - 1), (n - 1) + n * (n - 1)]


def operator(n):
    """S_z of model.py with the nodes pins(n) constrained (rows a m I)."""
    S = bending(n, COEF, pins=False).tolil()
    m = np.full((n, n), MASS / (n - 1) ** 2)
    m[0, :] *= 0.5; m[-1, :] *= 0.5; m[:, 0] *= 0.5; m[:, -1] *= 0.5
    m = m.T.reshape(-1)
    for p in pins(n):
        S[p, :] = 0.0
        S[:, p] = 0.0
        S[p, p] = A_SHIFT * m[p]
    return S.tocsr()


def hierarchy(n, galerkin, levels=None):
    levels = levels or int(np.log2(n - 1)) - 1
    levs, Ps, Rs = [Level(operator(n))], [], []
    for _ in range(levels - 1):
        nc = (n - 1) // 2 + 1
        P = prolong(n, True).tolil()
        P[:, pins(nc)] = 0.0
        P = P.tocsr()
        R = prolong(n, False).T.tolil()
        R[pins(nc), :] = 0.0
        R = R.tocsr()
        Ac = operator(nc)
        if galerkin:
            G = (P.T @ levs[-1].A @ P).tolil()
            for p in pins(nc):
                G[p, p] = Ac[p, p]
            Ac = G.tocsr()
        levs.append(Level(Ac))
        Ps.append(P)
        Rs.append(R)
        n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs


def cycle(levs, Ps, Rs, b, l, kind):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]
    if kind == 'K':
        return lv.sgs(Ps[l] @ cycle(levs, Ps, Rs, Rs[l] @ b, l + 1, kind), b, 1)
    x = lv.sgs(np.zeros_like(b), b, 1)
    for _ in range(2 if kind == 'W' and l + 2 < len(levs) else 1):
        x = x + Ps[l] @ cycle(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, kind)
    return lv.sgs(x, b, 1)


def load(n, kind):
    if kind == 'random':
        b = np.random.default_rng(1).standard_normal(n * n)
    else:
        m = np.ones((n, n))
        m[0, :] *= 0.5; m[-1, :] *= 0.5; m[:, 0] *= 0.5; m[:, -1] *= 0.5
        b = m.T.reshape(-1).copy()
    b[pins(n)] = 0.0
    return b


def iterations(n, galerkin, kind, b, rtol=1e-3):
    levs, Ps, Rs = hierarchy(n, galerkin)
    A = levs[0].A
    N = A.shape[0]
    AM = spla.LinearOperator((N, N), matvec=lambda v: A @ cycle(levs, Ps, Rs, v, 0, kind))
    its = [0]

    def count(_):
        its[0] += 1
    spla.gmres(AM, b, rtol=rtol, restart=50, maxiter=100, callback=count, callback_type='pr_norm')
    return its[0]


def where(n, b):
    """One kaskade cycle (rediscretised) on b: the relative residual and the
    share of its square within 8 nodes of the pins."""
    levs, Ps, Rs = hierarchy(n, False)
    r = b - levs[0].A @ cycle(levs, Ps, Rs, b, 0, 'K')
    jj, ii = np.mgrid[0:n, 0:n]
    near = np.zeros((n, n), dtype=bool)
    for p in pins(n):
        near |= np.hypot(ii - p % n, jj - p // n) < 8
    near = near.reshape(-1)
    return np.linalg.norm(r) / np.linalg.norm(b), (r[near] ** 2).sum() / (r ** 2).sum()


def level2_eigs(n):
    (_, r), _, _ = hierarchy(n, False, 2)
    (_, g), _, _ = hierarchy(n, True, 2)
    nc = (n - 1) // 2 + 1
    keep = np.setdiff1d(np.arange(nc * nc), pins(nc))
    w, V = sl.eigh(r.A.toarray()[np.ix_(keep, keep)], g.A.toarray()[np.ix_(keep, keep)])
    v = np.zeros(nc * nc)
    v[keep] = V[:, 0]
    p = int(np.abs(v).argmax())
    return w[0], w[-1], (p % nc, p // nc)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('sizes', type=int, nargs='*', default=[33, 65, 129, 257])
    ap.add_argument('--load', choices=['gravity', 'random'], default='gravity')
    ap.add_argument('--eig', action='store_true', help='level 2 against P^T A P (dense: sizes up to 129)')
    ap.add_argument('--pins', choices=['corners', 'edge'], default='corners', help="hang's two corners or the whole edge")
    ap.add_argument('--where', action='store_true', help='where one kaskade cycle leaves the residual')
    args = ap.parse_args()
    global PINS
    PINS = args.pins
    for n in args.sizes:
        if args.eig:
            lo, hi, at = level2_eigs(n)
            print(f'N={n} level 2: eigenvalues of (P^T A P)^-1 A_redisc {lo:.3f} .. {hi:.3f}, smallest at node {at}')
            continue
        b = load(n, args.load)
        if args.where:
            rel, share = where(n, b)
            print(f'N={n} {args.load}: one kaskade cycle leaves {rel:.3f} of the residual, {share:.3f} of its square within 8 nodes of the pins')
            continue
        out = [f'{h}-{k} {iterations(n, h == "g", k, b)}' for h in 'rg' for k in 'KVW']
        print(f'N={n} {args.load}:', '  '.join(out), flush=True)


if __name__ == '__main__':
    main()
