#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 2: the rediscretised coarse operator is softer than
any Galerkin one at high coarse frequencies (the cubic product's ratio up
to 3.1, the Schur complement's 2.3: stiffen.py), so its correction
overshoots there. A low-pass filter of the coarse correction before the
interpolation, F = Fx Fy, Fx = I - g/4 (dx^2) (reach 1; its symbol
1 - g sin^2(theta/2)), scales those modes down. Two-grid factor (V(1,1),
exact coarse solve) of the scalar model (model.py), free edges and pins,
for g = 0 (plain rediscretisation) and a few g."""
import sys
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from model import bending, prolong, Level
from redisc import coef, rate


def filt1(n, g):
    """1-D filter I - g/4 (second difference) with the free-end rows
    reflecting (the filter keeps constants)."""
    F = sp.lil_matrix((n, n))
    for i in range(n):
        F[i, i] = 1 - g / 2
        for k in (i - 1, i + 1):
            kk = k if 0 <= k < n else 2 * i - k
            F[i, kk] += g / 4
    return F.tocsr()


def pinned(n):
    return [0 + n * (n - 1), (n - 1) + n * (n - 1)]


if __name__ == '__main__':
    gs = [float(x) for x in sys.argv[1].split(',')] if len(sys.argv) > 1 else [0, 0.5, 1.0]
    sizes = [int(s) for s in sys.argv[2:]] or [33, 65, 129]
    for n in sizes:
        nc = (n - 1) // 2 + 1
        A = bending(n, coef)
        Ac = bending(nc, coef)
        P = prolong(n, True).tolil()
        P[:, pinned(nc)] = 0.0
        P = P.tocsr()
        out = [f'N={n}']
        for g in gs:
            F = sp.kron(filt1(nc, g), filt1(nc, g)).tocsr().tolil()
            F[pinned(nc), :] = 0.0
            F = F.tocsr()
            levs = [Level(A), Level(Ac)]
            levs[-1].lu = spla.splu(levs[-1].A.tocsc())
            out.append(f'g={g}: {rate(levs, [P @ F], [P.T], False):.3f}')
        print('  '.join(out), flush=True)


def stiffness_filter(Ac, mass_diag, omega):
    """x -> x - omega D^{-1} (A_c - M_c) x, D = diag(A_c): a damped Jacobi
    step of the stiffness part normalised by the whole diagonal (mass
    included), so that where the mass dominates it does nothing."""
    L = Ac - sp.diags(mass_diag)
    return (sp.identity(Ac.shape[0]) - omega * sp.diags(1.0 / Ac.diagonal()) @ L).tocsr()


def run_operator_filter(omegas, sizes):
    for n in sizes:
        nc = (n - 1) // 2 + 1
        A = bending(n, coef)
        Ac = bending(nc, coef)
        md = bending(nc, 0.0).diagonal()      # the mass term alone (pinned rows too)
        P = prolong(n, True).tolil()
        P[:, pinned(nc)] = 0.0
        P = P.tocsr()
        out = [f'N={n}']
        for om in omegas:
            F = stiffness_filter(Ac, md, om).tolil()
            F[pinned(nc), :] = 0.0
            levs = [Level(A), Level(Ac)]
            levs[-1].lu = spla.splu(levs[-1].A.tocsc())
            out.append(f'w={om}: {rate(levs, [P @ F.tocsr()], [P.T], False):.3f}')
        print('  '.join(out), flush=True)


def filt2(nc, g, h):
    """F = I - g/4 (dx^2 + dy^2) + h/16 dx^2 dy^2 (symbol 1 - g (sx + sy)
    + h sx sy, s = sin^2(theta/2)), ends reflecting."""
    Ix = sp.identity(nc)
    D = (filt1(nc, 1.0) - Ix) * 4.0       # the reflected second difference dx^2 (symbol -4 s)
    return (sp.kron(Ix, Ix) + g / 4 * (sp.kron(Ix, D) + sp.kron(D, Ix)) + h / 16 * sp.kron(D, D)).tocsr()


def run_filt2(params, sizes):
    for n in sizes:
        nc = (n - 1) // 2 + 1
        A = bending(n, coef)
        Ac = bending(nc, coef)
        P = prolong(n, True).tolil()
        P[:, pinned(nc)] = 0.0
        P = P.tocsr()
        out = [f'N={n}']
        for g, h in params:
            F = filt2(nc, g, h).tolil()
            F[pinned(nc), :] = 0.0
            levs = [Level(A), Level(Ac)]
            levs[-1].lu = spla.splu(levs[-1].A.tocsc())
            out.append(f'g={g},h={h}: {rate(levs, [P @ F.tocsr()], [P.T], False):.3f}')
        print('  '.join(out), flush=True)
