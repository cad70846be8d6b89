#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 2: right-preconditioned GMRES iterations to 1e-3 on the
scalar model (model.py) with one cycle as the preconditioner: Galerkin
hierarchies against rediscretised ones (redisc.py), the coarse
correction zero on the pinned coarse nodes (a pinned coarse node takes no
restricted residual)."""
import sys
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from model import bending, prolong, Level, ETA_B, K_B, A_SHIFT

coef = ETA_B + K_B / A_SHIFT
SMOOTH = False


def pins(n):
    return [0 + n * (n - 1), (n - 1) + n * (n - 1)]


def build(n, levels, mode):
    """mode: galerkin-cubic 'gc', today's 'today' (level 1 -> 2 bilinear with
    a cubic correction, then cubic), rediscretised 'rcc', 'rcl'."""
    A = bending(n, coef)
    levs, Ps, Rs = [Level(A)], [], []
    for l in range(levels - 1):
        Pl, Pc = prolong(n, False), prolong(n, True)
        nc = (n - 1) // 2 + 1
        if mode == 'gc':
            P, R = Pc, Pc.T
            Ac = R @ levs[-1].A @ P
        elif mode == 'today':
            P, R = (Pc, Pl.T) if l == 0 else (Pc, Pc.T)
            Ac = (Pl.T @ levs[-1].A @ Pl) if l == 0 else (R @ levs[-1].A @ P)
        else:
            P = Pc.tolil()
            P[:, pins(nc)] = 0.0
            P = P.tocsr()
            R = P.T if mode == 'rcc' else Pl.T.tolil()
            if mode == 'rcl':
                R[pins(nc), :] = 0.0
                R = R.tocsr()
            Ac = bending(nc, coef)
        levs.append(Level(Ac))
        Ps.append(P)
        Rs.append(R)
        n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs


def cyc(levs, Ps, Rs, b, l, kask, nu=1):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]
    if kask:
        return lv.sgs(Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ b, l + 1, kask, nu), b, nu)
    x = lv.sgs(np.zeros_like(b), b, nu)
    x = x + Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, kask, nu)
    return lv.sgs(x, b, nu)


def gmres_its(levs, Ps, Rs, kask, rtol=1e-3, seed=1):
    A = levs[0].A
    n = A.shape[0]
    b = np.random.default_rng(seed).standard_normal(n)
    if SMOOTH:
        b = A @ np.ones(n) + 1e-3 * A.diagonal() * b
    M = spla.LinearOperator((n, n), matvec=lambda v: cyc(levs, Ps, Rs, v, 0, kask))
    AM = spla.LinearOperator((n, n), matvec=lambda v: A @ M.matvec(v))
    its = [0]
    def cb(_):
        its[0] += 1
    spla.gmres(AM, b, rtol=rtol, restart=50, maxiter=200, callback=cb, callback_type='pr_norm')
    return its[0]


if __name__ == '__main__':
    kask = sys.argv[1].upper().startswith('K')
    SMOOTH = sys.argv[1].upper().endswith('S')
    modes = sys.argv[2].split(',')
    sizes = [int(s) for s in sys.argv[3:]] or [33, 65, 129, 257]
    for n in sizes:
        out = [f'N={n}']
        for mode in modes:
            levs, Ps, Rs = build(n, int(np.log2(n - 1)) - 1, mode)
            out.append(f'{mode} {gmres_its(levs, Ps, Rs, kask)}')
        print('kaskade' if kask else 'V(1,1)', '  '.join(out), flush=True)
