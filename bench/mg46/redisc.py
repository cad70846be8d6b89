#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 2: the scalar model (model.py) with coarse levels
rediscretised (the same cloth on the lattice coarsened by 2: bending with
the same coefficient at spacing 2h, area masses at 2h, the corners pinned)
instead of Galerkin products; transfers: P cubic with R = P^T ('cc'), P
cubic with R bilinear ('cl'), both bilinear ('ll').

python3 redisc.py V|K [SIZES]: factor of one cycle (all levels) by size.
"""
import sys
import numpy as np
import scipy.sparse.linalg as spla
from model import bending, prolong, Level, ETA_B, K_B, A_SHIFT

coef = ETA_B + K_B / A_SHIFT


def build(n, levels, mode):
    levs, Ps, Rs = [Level(bending(n, coef))], [], []
    for _ in range(levels - 1):
        Pl, Pc = prolong(n, False), prolong(n, True)
        P = Pl if mode == 'll' else Pc
        R = Pc.T if mode == 'cc' else Pl.T
        n = (n - 1) // 2 + 1
        levs.append(Level(bending(n, coef)))
        Ps.append(P)
        Rs.append(R)
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs


def cyc(levs, Ps, Rs, b, l, kask):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]
    if kask:
        return lv.sgs(Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ b, l + 1, kask), b, 1)
    x = lv.sgs(np.zeros_like(b), b, 1)
    x = x + Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, kask)
    return lv.sgs(x, b, 1)


def rate(levs, Ps, Rs, kask, its=30):
    A = levs[0].A
    e = np.random.default_rng(1).standard_normal(A.shape[0])
    e /= np.linalg.norm(e)
    rho = 0.0
    for _ in range(its):
        e2 = e - cyc(levs, Ps, Rs, A @ e, 0, kask)
        rho = np.linalg.norm(e2)
        e = e2 / rho
    return rho


if __name__ == '__main__':
    kask = sys.argv[1].upper() == 'K'
    sizes = [int(s) for s in sys.argv[2:]] or [33, 65, 129, 257]
    for n in sizes:
        out = [f'N={n}']
        for lv in (2, int(np.log2(n - 1)) - 1):
            for mode in ('cc', 'cl', 'll'):
                levs, Ps, Rs = build(n, lv, mode)
                out.append(f'{lv}lev {mode} {rate(levs, Ps, Rs, kask):.3f}')
        print('kaskade' if kask else 'V(1,1)', '  '.join(out), flush=True)
