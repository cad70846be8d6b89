"""Issue 46: the bilinear Galerkin operator with its pure fourth x- and
y-differences halved (the consistent coarse bending, reach 2)."""
import sys, numpy as np, scipy.sparse as sp, scipy.sparse.linalg as spla
from model import *

def halve4(G, n):
    """Per row p and side s: b = sum_t G(p, p + (2s, t)); G(p, p + (2s, 0)) -= b/2,
    G(p, p + (s, 0)) += 2 b, diagonal -= 1.5 b; the same along y. Row sums kept."""
    G = G.tocsr(); out = G.tolil(copy=True)
    for p in range(n * n):
        i, j = p % n, p // n
        row = G.getrow(p); cols = row.indices; vals = row.data
        for s in (-1, 1):
            bx = sum(v for q, v in zip(cols, vals) if q % n - i == 2 * s)
            by = sum(v for q, v in zip(cols, vals) if q // n - j == 2 * s)
            if bx != 0.0:
                out[p, p + 2 * s] -= bx / 2; out[p, p + s] += 2 * bx; out[p, p] -= 1.5 * bx
            if by != 0.0:
                out[p, p + 2 * s * n] -= by / 2; out[p, p + s * n] += 2 * by; out[p, p] -= 1.5 * by
    return out.tocsr()

def build(A, n, levels, fix, cubic_up):
    levs, Ps, Rs = [Level(A)], [], []
    for l in range(levels - 1):
        Pl = prolong(n, False); nc = (n - 1) // 2 + 1
        G = Pl.T @ levs[-1].A @ Pl
        if fix: G = halve4_sym(G, nc)
        levs.append(Level(G)); Rs.append(Pl.T); Ps.append(prolong(n, True) if cubic_up else Pl); n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs

def halve4_sym(G, n):
    """Subtract, for every coarse triple (q - e, q, q + e) along x and y with all
    three nodes in the lattice, w_q d d^T with d = (1, -2, 1) and
    w_q = 1/4 (sum_t G(q - e, q + e + t f) + sum_t G(q + e, q - e + t f)),
    f the other axis, |t| <= 2: half of the pure fourth difference of a
    reach-2 bilinear Galerkin operator, symmetric, row sums kept."""
    G = G.tocsr(); out = G.tolil(copy=True)
    for ex, fx in ((1, n), (n, 1)):
        for q in range(n * n):
            i, j = q % n, q // n
            c = i if ex == 1 else j
            if c - 1 < 0 or c + 1 > n - 1:
                continue
            o = (j if ex == 1 else i)
            w = 0.0
            for t in range(-2, 3):
                if 0 <= o + t < n:
                    w += G[q - ex, q + ex + t * fx] + G[q + ex, q - ex + t * fx]
            w /= 4.0
            nodes = (q - ex, q, q + ex); d = (1.0, -2.0, 1.0)
            for a in range(3):
                for b in range(3):
                    out[nodes[a], nodes[b]] -= w * d[a] * d[b]
    return out.tocsr()


if __name__ == '__main__':
    from pg import rate3
    coef = ETA_B + K_B / A_SHIFT
    grow = int(sys.argv[1]); kask = sys.argv[2] == 'k'
    for n in [int(a) for a in sys.argv[3:]]:
        A = bending(n, coef); out = [f'N={n}']
        for name, fix, cu in (('bilinear', False, False), ('halved', True, False), ('halved+cubic_up', True, True)):
            levs, Ps, Rs = build(A, n, int(np.log2(n - 1)) - 1, fix, cu)
            out.append(f'{name} {rate3(levs, Ps, Rs, 25, 1, grow, kask):.3f}')
        print(('kaskade' if kask else 'V(1,1)'), f'nu x{grow}', '  '.join(out), flush=True)

