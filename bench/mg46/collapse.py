"""Collapse of a coarse operator onto reach R (model of issue 46's fix):
every coupling at offset (di, dj) beyond reach R goes to the offsets within
reach R with the weights of Lagrange interpolation in di and dj (nodes: the
offsets -R..R that lie in the lattice), so that the row's moments
sum_o B_o o^alpha of degree <= 2R in each direction are kept; the row sums
(the mass) unchanged, the diagonal D - sum B."""
import sys
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from model import *


def lagrange(x, nodes):
    return np.array([np.prod([(x - b) / (a - b) for b in nodes if b != a]) for a in nodes])


def collapse(A, n, R=2):
    A = A.tocsr()
    rows, cols, vals = [], [], []
    rs = np.asarray(A.sum(axis=1)).ravel()
    for p in range(n * n):
        i, j = p % n, p // n
        nx_ = [d for d in range(-R, R + 1) if 0 <= i + d < n]
        ny_ = [d for d in range(-R, R + 1) if 0 <= j + d < n]
        acc = {}
        s, e = A.indptr[p], A.indptr[p + 1]
        for q, v in zip(A.indices[s:e], A.data[s:e]):
            if q == p:
                continue
            di, dj = q % n - i, q // n - j
            wx = {di: 1.0} if abs(di) <= R else dict(zip(nx_, lagrange(di, nx_)))
            wy = {dj: 1.0} if abs(dj) <= R else dict(zip(ny_, lagrange(dj, ny_)))
            for a, u in wx.items():
                for b, w in wy.items():
                    if a == 0 and b == 0:
                        continue
                    acc[(a, b)] = acc.get((a, b), 0.0) + u * w * v
        off = 0.0
        for (a, b), v in acc.items():
            rows.append(p); cols.append(i + a + n * (j + b)); vals.append(v); off += v
        rows.append(p); cols.append(p); vals.append(rs[p] - off)
    return sp.csr_matrix((vals, (rows, cols)), shape=A.shape)


def hierarchy_c(A, n, levels, mode):
    """mode: 'collapse' (cubic Galerkin collapsed to reach 2), 'redisc'
    (bilinear Galerkin of the mass + bending rediscretised), 'cubic', 'bilinear'."""
    levs, Ps = [Level(A)], []
    coef = ETA_B + K_B / A_SHIFT
    M = sp.diags(bending(n, 0.0).diagonal())
    for l in range(levels - 1):
        nc = (n - 1) // 2 + 1
        if mode == 'redisc':
            Pl = prolong(n, False)
            M = Pl.T @ M @ Pl
            Ac = (M + bending(nc, coef, 0.0, pins=False)).tolil()
            P = prolong(n, True)
        else:
            P = prolong(n, mode != 'bilinear')
            Ac = P.T @ levs[-1].A @ P
            if mode == 'collapse':
                Ac = collapse(Ac, nc)
        Ps.append(P)
        levs.append(Level(sp.csr_matrix(Ac)))
        n = nc
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps


if __name__ == '__main__':
    coef = ETA_B + K_B / A_SHIFT
    kask = 'kaskade' in sys.argv
    for n in [int(a) for a in sys.argv[1:] if a.isdigit()]:
        A = bending(n, coef)
        out = [f'N={n}']
        for mode in ('bilinear', 'cubic', 'collapse', 'redisc'):
            levs, Ps = hierarchy_c(A, n, int(np.log2(n - 1)) - 1, mode)
            rho, _ = rate(levs, Ps, 30, 1, kask)
            out.append(f'{mode} {rho:.3f}')
        print(('kaskade ' if kask else 'V(1,1) ') + '  '.join(out), flush=True)
