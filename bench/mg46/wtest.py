import sys, numpy as np
from model import *
coef = ETA_B + K_B / A_SHIFT
def cyc(levs, Ps, b, l, nu, gamma, grow):
    if l == len(levs) - 1:
        return levs[l].lu.solve(b)
    lv = levs[l]; m = nu * (grow ** l)
    x = lv.sgs(np.zeros_like(b), b, m)
    for g in range(gamma if l > 0 else 1):
        x = x + Ps[l] @ cyc(levs, Ps, Ps[l].T @ (b - lv.A @ x), l + 1, nu, gamma, grow)
    return lv.sgs(x, b, m)
def rate2(levs, Ps, its, nu, gamma, grow):
    A = levs[0].A; e = np.random.default_rng(1).standard_normal(A.shape[0]); e /= np.linalg.norm(e)
    for _ in range(its):
        e2 = e - cyc(levs, Ps, A @ e, 0, nu, gamma, grow); rho = np.linalg.norm(e2); e = e2 / rho
    return rho
gamma = int(sys.argv[1]); grow = int(sys.argv[2])
for n in (33, 65, 129, 257):
    A = bending(n, coef); out = [f'N={n}']
    for name, cub in (('bilinear', False), ('cubic', True)):
        levs, Ps = hierarchy(A, n, int(np.log2(n - 1)) - 1, cub)
        out.append(f'{name} {rate2(levs, Ps, 25, 1, gamma, grow):.3f}')
    print(f'gamma {gamma} nu x{grow}/level ', '  '.join(out), flush=True)
