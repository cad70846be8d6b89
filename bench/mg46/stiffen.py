#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Issue 46, phase 2: symbols of the periodic scalar model's coarse
bending: the Galerkin product of the cubic P against the rediscretised
one, and the rediscretised one stiffened at high frequencies by reach-2
sixth- and eighth-order mixed terms, alpha (dx^4 dy^2 + dx^2 dy^4) +
beta dx^4 dy^4 (they vanish on smooth fields faster than the bending, so
the coarse operator stays consistent). Prints max and min of G / A_c."""
import numpy as np


def symbols(alpha, beta, m=129):
    th = np.linspace(0, np.pi, m)[1:]
    tx, ty = np.meshgrid(th, th, indexing='ij')

    def d4(t):
        return 16 * np.sin(t / 2) ** 4

    def d2(t):
        return 4 * np.sin(t / 2) ** 2

    def bend(t1, t2, h):   # the four line directions, coefficient 1, spacing h
        return (d4(t1) + d4(t2) + (d4(t1 + t2) + d4(t1 - t2)) / 2) / h ** 2

    # cubic interpolation symbol along one direction for fine frequency p
    def p1(p):
        return 1 + 9 / 8 * np.cos(p) - 1 / 8 * np.cos(3 * p)

    # Galerkin: sum over the 4 fine harmonics (tx/2 + a pi, ty/2 + b pi)
    g = 0.0
    for a in (0, 1):
        for b in (0, 1):
            fx, fy = tx / 2 + a * np.pi, ty / 2 + b * np.pi
            g = g + (p1(fx) * p1(fy)) ** 2 * bend(fx, fy, 1.0)
    g = g / 4   # the normalisation of R = P^T onto coarse nodes with 4x area
    ac = bend(tx, ty, 2.0) * 4 / 4
    extra = (alpha * (d4(tx) * d2(ty) + d2(tx) * d4(ty)) + beta * d4(tx) * d4(ty)) / 4.0
    return g, ac, extra


if __name__ == '__main__':
    g, ac, _ = symbols(0, 0)
    r = g / ac
    print(f'rediscretised: G/Ac at small theta {r[0, 0]:.3f}, max {r.max():.3f}, min {r.min():.3f}')
    best = None
    for alpha in np.linspace(0, 0.6, 25):
        for beta in np.linspace(0, 0.3, 16):
            g, ac, ex = symbols(alpha, beta)
            r = g / (ac + ex)
            score = r.max() / r.min()
            if best is None or score < best[0]:
                best = (score, alpha, beta, r.max(), r.min())
    print('best alpha %.3f beta %.3f: max %.3f min %.3f (ratio %.3f)' % (best[1], best[2], best[3], best[4], best[0]))
