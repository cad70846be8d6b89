import numpy as np
from model import *
n = 33; nc = 17
def halve(G, n, axis_order=('x', 'y')):
    """Halve the 4th-difference component along x (then y) of each row of a
    reach-2 operator: B(+-2) -> B/2, B(+-1) += 2 B(+-2)_old (per side, in the
    same row/column of the stencil)."""
    G = G.tolil().copy(); Gd = G.toarray(); out = Gd.copy()
    for ax in axis_order:
        src = out.copy()
        for p in range(n * n):
            i, j = p % n, p // n
            for t in range(-2, 3):            # the other coordinate's offset
                for sgn in (-1, 1):
                    if ax == 'x':
                        q2, q1 = (i + 2 * sgn, j + t), (i + sgn, j + t)
                    else:
                        q2, q1 = (i + t, j + 2 * sgn), (i + t, j + sgn)
                    if not (0 <= q2[0] < n and 0 <= q2[1] < n):
                        continue
                    b = src[p, q2[0] + n * q2[1]]
                    out[p, q2[0] + n * q2[1]] -= b / 2
                    out[p, q1[0] + n * q1[1]] += 2 * b
                    out[p, p] -= 1.5 * b
    return out
def moments(G, n):
    p = n // 2 + n * (n // 2); row = G[p] if isinstance(G, np.ndarray) else G.getrow(p).toarray().ravel()
    m = {}
    for q in np.nonzero(row)[0]:
        di, dj = q % n - n // 2, q // n - n // 2
        for a in range(5):
            for b in range(5 - a):
                if a + b in (0, 2, 4):
                    m[(a, b)] = m.get((a, b), 0) + row[q] * di ** a * dj ** b
    return {k: round(v, 4) for k, v in sorted(m.items()) if abs(v) > 1e-9}
for line in ((1, 0), (1, 1), (1, -1)):
    A = bending(n, 1.0, 0.0, pins=False, lines=(line,), h=1.0)
    Gl = (prolong(n, False).T @ A @ prolong(n, False))
    Gc = (prolong(n, True).T @ A @ prolong(n, True))
    print('line', line)
    print('  cubic   ', moments(Gc, nc))
    print('  bilinear', moments(Gl, nc))
    print('  halved  ', moments(halve(Gl, nc), nc))
