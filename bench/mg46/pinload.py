#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 3: the scalar model (model.py) under hang's own load.

The growth of the cycles with N that is left after the rediscretised
coarse levels shows only under the load of hang's first step (gravity on
the area masses, zero at the two pinned corners), not under a random
right-hand side (redisc_gmres.py: 6 iterations at 33..257). This script
counts flexible GMRES iterations to 1e-3 (nuno's outer method, the bw
mode's tolerance) with one cycle as the preconditioner, and the level
visits an iteration in finest-level sizes (in brackets), for two
hierarchies on
the same transfers (P cubic, its columns at the pinned coarse nodes zero;
R bilinear, no right-hand side at the pinned coarse nodes; one symmetric
Gauss-Seidel sweep a smoothing):

  r  the rediscretised coarse levels (nuno's default with bending),
  g  the Galerkin products P^T A P of the same P (pinned rows a m I),
  s  non-Galerkin: P^T A_l P sparsified onto the rediscretised reach-2
     stencil, each row's action on the polynomials of degree --degree
     kept (module sparsify; level l + 1 from the sparsified level l),
  f  the rediscretised levels with the rows and columns within
     --fixwidth nodes of an edge taken from s,
  S, F  as s and f, but each level from the exact Galerkin chain's
     product P^T G_l P (G_1 = A), not from the sparsified level above,
  e  diag(a m) plus the coarse bending triples (1, -2, 1) with weights
     >= 0 fitted to P^T A_l P's row moments of degrees 2-4 (SPD by
     construction; module sparsify's fitted),

and the cycles (--cycles) K (kaskade), V, W, and the K-cycles of Notay and
Vassilevski: C (each coarse level but the coarsest solved by at most two
flexible CG iterations preconditioned by its V-cycle, the second only if
the first leaves more than --threshold of the level's residual) and J
(the same on kaskade). --ends F: the rediscretised levels' bending
triples that reach an edge scaled by F (a boundary correction); --corners F: their diagonal triples at a
corner's 2 x 2 nodes scaled by F. --band W: every level's smoothing followed by an
exact solve of the band W nodes wide along its edges. --sweeps S: S
symmetric sweeps a smoothing. --smoother rows|cols|alt|zebra: block-line
Gauss-Seidel instead of the point sweep, each line's banded block
(pentadiagonal at reach 2) solved exactly; rows (nuno's strips hold whole
rows), columns, rows then columns (alternating), or rows in zebra order
(j mod 3). --deflate K: after each coarse correction the error made
A-orthogonal to P U (x += W (W^T A W)^-1 W^T r, W = P U), U the K
softest generalised eigenvectors of (A_c, P^T A P) on each coarse level
(the corner twists where the rediscretised correction overshoots);
--deflate-kind window: U the unit vectors of the coarse nodes in
--window x --window at each of the four corners (W^T A W their Galerkin
block; --window -c: c bending lengths of each level). With --eig it prints the extreme
generalised eigenvalues of the rediscretised level 2 against P^T A P and
where the smallest one's vector peaks (the free nodes; < 1: the
rediscretised operator is softer there, its correction overshoots by the
inverse).

With --where: the residual one kaskade cycle leaves, and how much of it
lies near the pins.

With --pins edge the whole edge j = ny-1 is pinned instead of its corners.

  python3 pinload.py [--load gravity|random] [--pins corners|edge] [--cycles KVWCJ]
      [--levels rg] [--threshold T] [--ends F] [--corners F] [--band W] [--sweeps S]
      [--smoother point|rows|cols|alt|zebra] [--deflate K] [--deflate-kind eig|window]
      [--window W] [--degree D] [--fixwidth W] [--eig | --where] SIZES
"""
import argparse
import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from model import bending, prolong, Level, ETA_B, K_B, A_SHIFT, MASS
import sparsify

COEF = ETA_B + K_B / A_SHIFT


PINS = 'corners'
END_SCALE = 1.0   # the coarse levels' bending triples that reach an edge scaled by it (--ends)
CORNER_SCALE = 1.0   # the coarse levels' diagonal triples at a corner's 2 x 2 nodes scaled by it (--corners)
BAND = 0          # after each smoothing, the band this many nodes wide along the edges solved exactly (--band)
SMOOTHER = 'point'  # point Gauss-Seidel or block-line Gauss-Seidel (--smoother)
DEFLATE = 0       # coarse modes made exact after each coarse correction (--deflate)
DEFLATE_KIND = 'eig'  # eig: the softest generalised eigenvectors; window: every coarse node near a corner
SWEEPS = 1        # symmetric sweeps a smoothing (--sweeps)
WINDOW = 2        # the corner windows' width in coarse nodes (--window)
DEGREE = 2        # the sparsified coarse rows keep their action on polynomials of this degree (--degree)
FIXWIDTH = 2      # variant f: the rows within this many nodes of an edge from the sparsified product (--fixwidth)


def line_orders(n, kind):
    """The lines of a block-line sweep on an n x n lattice (p = i + n j), in
    the order of the forward sweep: rows (j fixed, nuno's strips hold whole
    rows: no communication inside a line), columns (i fixed), or the rows
    in zebra order (j mod 3: with reach 2 a row couples to j +- 1, j +- 2,
    so three colours decouple)."""
    rows = [np.arange(n) + n * j for j in range(n)]
    cols = [i + n * np.arange(n) for i in range(n)]
    if kind == 'rows':
        return [rows]
    if kind == 'cols':
        return [cols]
    if kind == 'alt':
        return [rows, cols]
    if kind == 'zebra':
        return [[rows[j] for c in range(3) for j in range(c, n, 3)]]
    raise ValueError(kind)


class LineSweep:
    """One block Gauss-Seidel sweep over lines: each line's block (banded,
    pentadiagonal at reach 2) solved exactly with the newest values of the
    lines before it: x += M^-1 (b - A x), M the block lower triangle of A in
    the lines' order (factored once; no fill beyond a line's band)."""
    def __init__(self, A, lines):
        n = A.shape[0]
        perm = np.concatenate(lines)
        blk = np.empty(n, dtype=int)
        for k, ln in enumerate(lines):
            blk[ln] = k
        C = A.tocoo()
        keep = blk[C.row] >= blk[C.col]
        M = sp.csc_matrix((C.data[keep], (C.row[keep], C.col[keep])), shape=A.shape)
        Mp = M[perm][:, perm].tocsc()
        self.perm = perm
        self.lu = spla.splu(Mp, permc_spec='NATURAL', diag_pivot_thresh=0.0)

    def apply(self, r):
        out = np.empty_like(r)
        out[self.perm] = self.lu.solve(r[self.perm])
        return out


class LineLevel(Level):
    """A level whose smoother is block-line Gauss-Seidel (SMOOTHER): a
    symmetric sweep is the lines forward, then backward; 'alt' does rows
    then columns forward, columns then rows backward."""
    def __init__(self, A, n):
        super().__init__(A)
        self.fwd, self.bwd = [], []
        for lines in line_orders(n, SMOOTHER):
            self.fwd.append(LineSweep(self.A, lines))
            self.bwd.insert(0, LineSweep(self.A, lines[::-1]))

    def sgs(self, x, b, sweeps=1):
        for _ in range(sweeps):
            for s in self.fwd + self.bwd:
                x = x + s.apply(b - self.A @ x)
        return x


def deflation(Af, P, Ac, nc):
    """W = P U for the coarse vectors U whose correction is made exact:
    the DEFLATE softest generalised eigenvectors of (Ac, P^T Af P) (where
    the rediscretised correction overshoots most), or the unit vectors of
    the coarse nodes in WINDOW x WINDOW windows at the four corners; and
    the factored W^T Af W = U^T (P^T Af P) U."""
    G = (P.T @ Af @ P).tocsr()
    free = np.setdiff1d(np.arange(nc * nc), pins(nc))
    if DEFLATE_KIND == 'eig':
        Gf = G[free][:, free].tocsc()
        Acf = Ac[free][:, free].tocsc()
        _, V = spla.eigsh(Acf, k=DEFLATE, M=Gf, sigma=0.0, which='LM')
        U = np.zeros((nc * nc, DEFLATE))
        U[free] = V
        U = sp.csr_matrix(U)
    else:
        jj, ii = np.mgrid[0:nc, 0:nc]
        # a fixed width, or (WINDOW < 0) -WINDOW bending lengths of the level
        w = WINDOW if WINDOW > 0 else int(np.ceil(-WINDOW * (COEF / (A_SHIFT * MASS)) ** 0.25 * (nc - 1)))
        near = (np.minimum(ii, nc - 1 - ii) < w) & (np.minimum(jj, nc - 1 - jj) < w)
        idx = np.intersect1d(np.flatnonzero(near.reshape(-1)), free)
        U = sp.csr_matrix((np.ones(idx.size), (idx, np.arange(idx.size))), shape=(nc * nc, idx.size))
    W = (P @ U).tocsr()
    E = (U.T @ G @ U).toarray()
    return W, sl.cho_factor(E)


def deflate(lv, x, b):
    """x += W (W^T A W)^-1 W^T (b - A x): the error made A-orthogonal to
    span W (the coarse correction exact in the softest modes' span)."""
    if lv.W is None:
        return x
    return x + lv.W @ sl.cho_solve(lv.E, lv.W.T @ (b - lv.A @ x))


class BandLevel(Level):
    """A level whose smoothing ends with an exact solve of the band of BAND
    nodes along its four edges (the boundary layer's share of the residual
    removed on every level)."""
    def __init__(self, A, n):
        super().__init__(A)
        jj, ii = np.mgrid[0:n, 0:n]
        band = (ii < BAND) | (ii >= n - BAND) | (jj < BAND) | (jj >= n - BAND)
        self.band = np.flatnonzero(band.reshape(-1))
        self.blu = spla.splu(self.A[self.band][:, self.band].tocsc())

    def sgs(self, x, b, sweeps=1):
        x = super().sgs(x, b, sweeps)
        x[self.band] += self.blu.solve((b - self.A @ x)[self.band])
        return x


def pins(n):
    """hang's two pinned corners of row n-1, or (PINS = 'edge') all of it."""
    if PINS == 'edge':
        return [i + n * (n - 1) for i in range(n)]
    return [0 + n * (n - 1), (n - 1) + n * (n - 1)]


def operator(n, end_scale=1.0, corner_scale=1.0):
    """S_z of model.py with the nodes pins(n) constrained (rows a m I);
    end_scale: its bending triples that reach an edge scaled by it;
    corner_scale: its diagonal triples at a corner's 2 x 2 nodes."""
    S = bending(n, COEF, pins=False, end_scale=end_scale, corner_scale=corner_scale).tolil()
    am = mass_diagonal(n)
    for p in pins(n):
        S[p, :] = 0.0
        S[:, p] = 0.0
        S[p, p] = am[p]
    return S.tocsr()


def mass_diagonal(n):
    """a m_p, the area masses' part of S_z's diagonal (n^2)."""
    m = np.full((n, n), MASS / (n - 1) ** 2)
    m[0, :] *= 0.5; m[-1, :] *= 0.5; m[:, 0] *= 0.5; m[:, -1] *= 0.5
    return A_SHIFT * m.T.reshape(-1)


def coarse_from_product(G, R, nc, kind):
    """The coarse operator of kind g (the Galerkin product G itself), s (G
    sparsified onto R's reach-2 pattern, its rows' action on the
    polynomials of degree DEGREE kept: module sparsify), f (R with the
    rows and columns within FIXWIDTH nodes of an edge taken from the
    sparsified G) or e (triples fitted to G's moments); R the
    rediscretised operator. Pinned rows keep R's."""
    if kind == 'g':
        return G
    free = np.ones(nc * nc, dtype=bool)
    free[pins(nc)] = False
    if kind == 'e':
        A, _ = sparsify.fitted(G, nc, free, COEF * (nc - 1) ** 2, mass_diagonal(nc))
        return A
    R = R.tocsr()
    R.eliminate_zeros()
    pattern = R
    if kind == 'b':   # the 5 x 5 box (reach 2 in the max norm, 24 offsets) of G
        C = G.tocoo()
        box = (np.abs(C.col % nc - C.row % nc) <= 2) & (np.abs(C.col // nc - C.row // nc) <= 2) & (C.data != 0)
        pattern = sp.csr_matrix((C.data[box], (C.row[box], C.col[box])), shape=G.shape)
    S = sparsify.sparsified(G, pattern, nc, DEGREE, keep=free)
    if kind == 'b':
        return S
    if kind == 's':
        return S
    return sparsify.fixrows(R, S, sparsify.band(nc, FIXWIDTH) & free)


def hierarchy(n, galerkin, levels=None):
    """The levels, interpolations and restrictions; galerkin: True or 'g'
    (P^T A P), False or 'r' (rediscretised), 's', 'f' or 'e'
    (coarse_from_product of the level above's product), 'S' or 'F' (of
    the exact Galerkin chain's product)."""
    kind = {True: 'g', False: 'r'}.get(galerkin, galerkin)
    levels = levels or int(np.log2(n - 1)) - 1
    make = (lambda A, m: BandLevel(A, m)) if BAND else (lambda A, m: Level(A))
    if SMOOTHER != 'point':
        make = LineLevel
    levs, Ps, Rs = [make(operator(n), n)], [], []
    exact = levs[0].A     # the Galerkin chain's operator of this level (kinds S, F)
    for _ in range(levels - 1):
        nc = (n - 1) // 2 + 1
        P = prolong(n, True).tolil()
        P[:, pins(nc)] = 0.0
        P = P.tocsr()
        R = prolong(n, False).T.tolil()
        R[pins(nc), :] = 0.0
        R = R.tocsr()
        Ac = operator(nc, END_SCALE, CORNER_SCALE)
        if kind != 'r':
            # s, f, e: from the product of the level above as it is;
            # S, F: from the exact Galerkin chain's product
            G = (P.T @ (exact if kind in 'SF' else levs[-1].A) @ P).tolil()
            for p in pins(nc):
                G[p, p] = Ac[p, p]
            exact = G.tocsr()
            Ac = coarse_from_product(exact, Ac, nc, kind.lower())
        levs[-1].W = None
        if DEFLATE and kind == 'r':
            levs[-1].W, levs[-1].E = deflation(levs[-1].A, P, Ac, nc)
        levs.append(make(Ac, nc))
        Ps.append(P)
        Rs.append(R)
        n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs


WORK = [0.0]     # level visits a preconditioner application, in finest-level sizes
THRESHOLD = 0.25  # the adaptive K-cycle's second inner iteration only if ||r1|| > t ||r0||


def krylov2(levs, Ps, Rs, b, l, kind):
    """Notay and Vassilevski's K-cycle on level l: at most two iterations of
    flexible CG preconditioned by the cycle of level l, the second only if
    the first leaves more than THRESHOLD of the residual."""
    A = levs[l].A
    c = cycle(levs, Ps, Rs, b, l, kind)
    v = A @ c
    rho1, a1 = c @ v, c @ b
    r1 = b - a1 / rho1 * v
    if np.linalg.norm(r1) <= THRESHOLD * np.linalg.norm(b):
        return a1 / rho1 * c
    d = cycle(levs, Ps, Rs, r1, l, kind)
    w = A @ d
    gam, beta, a2 = d @ v, d @ w, d @ r1
    rho2 = beta - gam * gam / rho1
    return (a1 / rho1 - gam * a2 / (rho1 * rho2)) * c + a2 / rho2 * d


def cycle(levs, Ps, Rs, b, l, kind):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]
    WORK[0] += 4.0 ** -l
    coarse = cycle if kind in 'KVW' or l + 2 >= len(levs) else krylov2
    if kind in 'KJ':
        return lv.sgs(deflate(lv, Ps[l] @ coarse(levs, Ps, Rs, Rs[l] @ b, l + 1, kind), b), b, SWEEPS)
    if kind == 'C':
        x = lv.sgs(np.zeros_like(b), b, SWEEPS)
        x = x + Ps[l] @ coarse(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, kind)
        return lv.sgs(deflate(lv, x, b), b, SWEEPS)
    x = lv.sgs(np.zeros_like(b), b, SWEEPS)
    for _ in range(2 if kind == 'W' and l + 2 < len(levs) else 1):
        x = x + Ps[l] @ cycle(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, kind)
        x = deflate(lv, x, b)
    return lv.sgs(x, b, SWEEPS)


def load(n, kind):
    if kind == 'random':
        b = np.random.default_rng(1).standard_normal(n * n)
    else:
        m = np.ones((n, n))
        m[0, :] *= 0.5; m[-1, :] *= 0.5; m[:, 0] *= 0.5; m[:, -1] *= 0.5
        b = m.T.reshape(-1).copy()
    b[pins(n)] = 0.0
    return b


def fgmres(A, M, b, rtol, maxiter=100):
    """Flexible GMRES (nuno's outer Krylov method, -reduced_ksp_type fgmres):
    right-preconditioned by M, which may change from one iteration to the
    next (a K-cycle does); the iterations to ||r|| <= rtol ||b||. (scipy's
    gmres is not flexible: with a K-cycle its true residual misses.)"""
    beta = np.linalg.norm(b)
    V, Z = [b / beta], []
    H = np.zeros((maxiter + 1, maxiter))
    for k in range(maxiter):
        Z.append(M(V[k]))
        w = A @ Z[k]
        for i in range(k + 1):
            H[i, k] = w @ V[i]
            w = w - H[i, k] * V[i]
        H[k + 1, k] = np.linalg.norm(w)
        V.append(w / H[k + 1, k])
        e1 = np.zeros(k + 2)
        e1[0] = beta
        y = np.linalg.lstsq(H[:k + 2, :k + 1], e1, rcond=None)[0]
        if np.linalg.norm(e1 - H[:k + 2, :k + 1] @ y) <= rtol * beta:
            return k + 1
    return maxiter


RTOL = 1e-3      # FGMRES's relative tolerance (--rtol; nuno's bw mode's)


def iterations(n, galerkin, kind, b, rtol=None):
    """FGMRES iterations to rtol with one cycle as the preconditioner, and
    the level visits an iteration (WORK)."""
    levs, Ps, Rs = hierarchy(n, galerkin)
    WORK[0] = 0.0
    its = fgmres(levs[0].A, lambda v: cycle(levs, Ps, Rs, v, 0, kind), b, rtol or RTOL)
    return its, WORK[0] / its


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


def level2_eigs(n, kind='r'):
    """The extreme generalised eigenvalues of level 2 of kind `kind`
    against P^T A P, and the node where the smallest one's vector peaks."""
    (_, r), _, _ = hierarchy(n, kind, 2)
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
    ap.add_argument('--cycles', default='KVW',
                    help='K kaskade, V, W, C K-cycle (V-cycle on each level, two flexible CG iterations on each coarse one), J K-cycle of kaskade')
    ap.add_argument('--levels', default='rg',
                    help='r rediscretised, g Galerkin, s sparsified Galerkin (non-Galerkin, reach 2), f rediscretised with the edge rows from s, S and F the same from the exact Galerkin chain, e triples fitted to the Galerkin moments')
    ap.add_argument('--degree', type=int, choices=[1, 2, 3], default=2,
                    help="levels s, f: the sparsified rows keep their action on the polynomials of this degree (3: 2 where the stencil is whole, else 1)")
    ap.add_argument('--fixwidth', type=int, default=2, help='levels f: the rows within this many nodes of an edge from s')
    ap.add_argument('--threshold', type=float, default=0.25, help="the K-cycle's second inner iteration only if ||r1|| > t ||r0|| (0: always)")
    ap.add_argument('--ends', type=float, default=1.0,
                    help="the rediscretised levels' bending triples that reach an edge scaled by it (per edge)")
    ap.add_argument('--band', type=int, default=0,
                    help='after each smoothing the band this many nodes wide along the edges solved exactly (0: none)')
    ap.add_argument('--corners', type=float, default=1.0,
                    help="the rediscretised levels' diagonal triples at a corner's 2 x 2 nodes scaled by it")
    ap.add_argument('--smoother', choices=['point', 'rows', 'cols', 'alt', 'zebra'], default='point',
                    help='point Gauss-Seidel, or block-line Gauss-Seidel over rows, columns, rows then columns, rows in zebra order (j mod 3)')
    ap.add_argument('--deflate', type=int, default=0,
                    help='after each coarse correction the error made A-orthogonal to P U, U the K softest generalised eigenvectors of (A_c, P^T A P) (0: none)')
    ap.add_argument('--deflate-kind', choices=['eig', 'window'], default='eig',
                    help='eig: U the softest eigenvectors; window: the unit vectors of the coarse nodes in --window x --window at each corner')
    ap.add_argument('--rtol', type=float, default=1e-3, help="FGMRES's relative tolerance (1e-3: the bw mode's)")
    ap.add_argument('--sweeps', type=int, default=1, help='symmetric sweeps a smoothing')
    ap.add_argument('--window', type=int, default=2, help="the corner windows' width in coarse nodes (< 0: -W bending lengths of the level, at least 1 node)")
    args = ap.parse_args()
    global SMOOTHER, DEFLATE, DEFLATE_KIND, WINDOW, SWEEPS, DEGREE, FIXWIDTH
    DEGREE, FIXWIDTH = args.degree, args.fixwidth
    SWEEPS = args.sweeps
    global RTOL
    RTOL = args.rtol
    SMOOTHER, DEFLATE, DEFLATE_KIND, WINDOW = args.smoother, args.deflate, args.deflate_kind, args.window
    if args.deflate_kind == 'window' and not DEFLATE:
        DEFLATE = 1
    global PINS, THRESHOLD, END_SCALE, BAND, CORNER_SCALE
    CORNER_SCALE = args.corners
    BAND = args.band
    THRESHOLD = args.threshold
    END_SCALE = args.ends
    PINS = args.pins
    for n in args.sizes:
        if args.eig:
            for h in args.levels.replace('g', ''):
                lo, hi, at = level2_eigs(n, h)
                print(f'N={n} level 2: eigenvalues of (P^T A P)^-1 A_{h} {lo:.3f} .. {hi:.3f}, smallest at node {at}')
            continue
        b = load(n, args.load)
        if args.where:
            rel, share = where(n, b)
            print(f'N={n} {args.load}: one kaskade cycle leaves {rel:.3f} of the residual, {share:.3f} of its square within 8 nodes of the pins')
            continue
        out = []
        for h in args.levels:
            for k in args.cycles:
                its, work = iterations(n, h, k, b)
                out.append(f'{h}-{k} {its} ({work:.2f})')
        print(f'N={n} {args.load}:', '  '.join(out), flush=True)


if __name__ == '__main__':
    main()
