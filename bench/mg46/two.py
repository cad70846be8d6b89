import sys, numpy as np, scipy.sparse.linalg as spla
from model import *
from halve import build
from pg import rate3
coef = ETA_B + K_B / A_SHIFT
for n in (33, 65, 129):
    A = bending(n, coef); out = [f'N={n}']
    for name, fix, cu in (('bilinear', False, False), ('bilinear+cubic_up', False, True), ('halved+cubic_up', True, True)):
        levs, Ps, Rs = build(A, n, 2, fix, cu)
        out.append(f'{name} kaskade {rate3(levs, Ps, Rs, 25, 1, 1, True):.3f} V {rate3(levs, Ps, Rs, 25, 1, 1, False):.3f}')
    print('2-level', '  '.join(out), flush=True)
