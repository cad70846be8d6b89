#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 1: a scalar model of the out-of-plane part of hang's S at
rest (flat sheet) and two-grid / multigrid convergence factors on it.

S_z = a m_p I + (k_b/a + eta_b) sum over triples (p, p+s, p+2s) of
d d^T / (|s|^2 L^2), d = (1, -2, 1): the Gauss-Newton bending at the flat
state (MODEL.md section 3: |kb| ~ |w_p - 2 w_q + w_r| / |e|), area masses,
the two corners of row ny-1 pinned (rows a m I), free edges. In-plane
springs at rest length add nothing out of plane.

Prints the spectral radius of the error propagation of one cycle
(power iteration), for transfers bilinear or cubic, coarse operators
Galerkin or rediscretised, smoother point Gauss-Seidel (lexicographic,
symmetric), over N.
"""
import argparse
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

A_SHIFT = 600.0
K_B, ETA_B, MASS = 0.1, 1e-4, 0.1


def bending(n, coef, mass_scale=1.0, periodic=False, pins=True, lines=((1, 0), (0, 1), (1, 1), (1, -1)), h=None, end_scale=1.0,
            corner_scale=1.0):
    """S_z on an n x n lattice, node p = i + n j; end_scale: the triples that
    reach an edge along their line scaled by it (per edge reached);
    corner_scale: the diagonal triples with a node in a corner's 2 x 2
    nodes scaled by it."""
    L = 1.0 / (n - 1) if h is None else h
    rows, cols, vals = [], [], []
    idx = lambda i, j: (i % n) + n * (j % n)
    for (si, sj) in lines:
        w = coef / ((si * si + sj * sj) * L * L)
        for j in range(n):
            for i in range(n):
                ii = [i, i + si, i + 2 * si]
                jj = [j, j + sj, j + 2 * sj]
                if not periodic and (min(ii) < 0 or max(ii) >= n or min(jj) < 0 or max(jj) >= n):
                    continue
                p = [idx(a, b) for a, b in zip(ii, jj)]
                d = [1.0, -2.0, 1.0]
                f = 1.0
                if si and (min(ii) == 0 or max(ii) == n - 1):
                    f *= end_scale
                if sj and (min(jj) == 0 or max(jj) == n - 1):
                    f *= end_scale
                if si and sj and any(min(a, n - 1 - a) < 2 and min(b, n - 1 - b) < 2 for a, b in zip(ii, jj)):
                    f *= corner_scale
                for x in range(3):
                    for y in range(3):
                        rows.append(p[x]); cols.append(p[y]); vals.append(w * f * d[x] * d[y])
    K = sp.csr_matrix((vals, (rows, cols)), shape=(n * n, n * n))
    m = np.full((n, n), MASS / (n - 1) ** 2)
    if not periodic:
        m[0, :] *= 0.5; m[-1, :] *= 0.5; m[:, 0] *= 0.5; m[:, -1] *= 0.5
    m = m.T.reshape(-1) * mass_scale  # m[i, j] -> p = i + n j
    S = (K + sp.diags(A_SHIFT * m)).tolil()
    if pins and not periodic:
        for p in (0 + n * (n - 1), (n - 1) + n * (n - 1)):
            S[p, :] = 0.0
            S[:, p] = 0.0
            S[p, p] = A_SHIFT * m[p]
    return S.tocsr()


def cubic_w(f, nc):
    """1-D cubic weights of nuno's module interpolation (Lagrange through 4
    coarse points, one-sided at the ends) for fine point f."""
    if f % 2 == 0:
        return [f // 2], [1.0]
    k = (f - 1) // 2
    c0 = min(max(k - 1, 0), nc - 4)
    xs = np.arange(c0, c0 + 4) * 2.0
    ws = []
    for a in range(4):
        w = 1.0
        for b in range(4):
            if b != a:
                w *= (f - xs[b]) / (xs[a] - xs[b])
        ws.append(w)
    return list(range(c0, c0 + 4)), ws


def prolong_1d(nf, cubic):
    nc = (nf - 1) // 2 + 1
    P = np.zeros((nf, nc))
    for f in range(nf):
        if cubic:
            c, w = cubic_w(f, nc)
        elif f % 2 == 0:
            c, w = [f // 2], [1.0]
        else:
            c, w = [(f - 1) // 2, (f + 1) // 2], [0.5, 0.5]
        P[f, c] = w
    return sp.csr_matrix(P)


def prolong(n, cubic):
    P1 = prolong_1d(n, cubic)
    return sp.kron(P1, P1).tocsr()   # p = i + n j: kron(Py, Px)


class Level:
    def __init__(self, A):
        self.A = A.tocsr()
        self.L = sp.tril(self.A, format='csr')
        self.U = sp.triu(self.A, format='csr')

    def sgs(self, x, b, sweeps=1):
        for _ in range(sweeps):
            x = x + spla.spsolve_triangular(self.L, b - self.A @ x, lower=True)
            x = x + spla.spsolve_triangular(self.U, b - self.A @ x, lower=False)
        return x


def hierarchy(A, n, levels, cubic):
    """Galerkin levels P^T A P, P bilinear or cubic (cubic may be a list by level)."""
    levs, Ps = [Level(A)], []
    for l in range(levels - 1):
        P = prolong(n, cubic[l] if isinstance(cubic, (list, tuple)) else cubic)
        nc = (n - 1) // 2 + 1
        Ac = P.T @ levs[-1].A @ P
        Ps.append(P)
        levs.append(Level(Ac))
        n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps


def vcycle(levs, Ps, b, l=0, nu=1, kaskade=False):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]
    if kaskade:
        xc = vcycle(levs, Ps, Ps[l].T @ b, l + 1, nu, kaskade)
        return lv.sgs(Ps[l] @ xc, b, nu)
    x = lv.sgs(np.zeros_like(b), b, nu)
    x = x + Ps[l] @ vcycle(levs, Ps, Ps[l].T @ (b - lv.A @ x), l + 1, nu, kaskade)
    return lv.sgs(x, b, nu)


def rate(levs, Ps, its=40, nu=1, kaskade=False, seed=1):
    """Spectral radius of the error propagation I - M^-1 A (power iteration)."""
    A = levs[0].A
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(A.shape[0])
    e /= np.linalg.norm(e)
    rho = 0.0
    for _ in range(its):
        e2 = e - vcycle(levs, Ps, A @ e, 0, nu, kaskade)
        rho = np.linalg.norm(e2)
        e = e2 / rho
    return rho, e


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--sizes', type=int, nargs='+', default=[33, 65, 129])
    ap.add_argument('--levels', type=int, default=2)
    ap.add_argument('--its', type=int, default=40)
    ap.add_argument('--nu', type=int, default=1)
    ap.add_argument('--kaskade', action='store_true')
    ap.add_argument('--nopins', action='store_true')
    ap.add_argument('--mass', type=float, default=1.0, help='mass scale')
    args = ap.parse_args()
    coef = ETA_B + K_B / A_SHIFT
    for n in args.sizes:
        A = bending(n, coef, args.mass, pins=not args.nopins)
        out = [f'N={n}']
        for name, cub in (('bilinear', False), ('cubic', True)):
            levs, Ps = hierarchy(A, n, min(args.levels, int(np.log2(n - 1)) - 1), cub)
            rho, _ = rate(levs, Ps, args.its, args.nu, args.kaskade)
            out.append(f'{name} {rho:.3f}')
        print('  '.join(out), flush=True)


if __name__ == '__main__':
    main()
