import sys, numpy as np, scipy.sparse.linalg as spla
from model import *
coef = ETA_B + K_B / A_SHIFT
class H: pass
def build(A, n, levels, mode):
    levs, Ps, Rs = [Level(A)], [], []
    for l in range(levels - 1):
        Pl, Pc = prolong(n, False), prolong(n, True)
        if mode == 'pg':      R, P = Pl.T, Pc
        elif mode == 'cubic': R, P = Pc.T, Pc
        elif mode == 'bilinear': R, P = Pl.T, Pl
        elif mode == 'pgT':   R, P = Pc.T, Pl
        levs.append(Level(R @ levs[-1].A @ P)); Ps.append(P); Rs.append(R); n = (n - 1) // 2 + 1
    levs[-1].lu = spla.splu(levs[-1].A.tocsc())
    return levs, Ps, Rs
def cyc(levs, Ps, Rs, b, l, nu, grow, kask):
    if l == len(levs) - 1: return levs[l].lu.solve(b)
    lv = levs[l]; m = nu * grow ** l
    if kask:
        return lv.sgs(Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ b, l + 1, nu, grow, kask), b, m)
    x = lv.sgs(np.zeros_like(b), b, m)
    x = x + Ps[l] @ cyc(levs, Ps, Rs, Rs[l] @ (b - lv.A @ x), l + 1, nu, grow, kask)
    return lv.sgs(x, b, m)
def rate3(levs, Ps, Rs, its, nu, grow, kask):
    A = levs[0].A; e = np.random.default_rng(1).standard_normal(A.shape[0]); e /= np.linalg.norm(e)
    for _ in range(its):
        e2 = e - cyc(levs, Ps, Rs, A @ e, 0, nu, grow, kask); rho = np.linalg.norm(e2); e = e2 / rho
    return rho
if __name__ == "__main__":
  grow = int(sys.argv[1]); kask = sys.argv[2] == "k"; modes = sys.argv[3].split(",")
  sizes = [int(s) for s in sys.argv[4:]] or [33, 65, 129, 257]
  for n in sizes:
      A = bending(n, coef); out = [f'N={n}']
      for mode in modes:
          levs, Ps, Rs = build(A, n, int(np.log2(n - 1)) - 1, mode)
          out.append(f'{mode} {rate3(levs, Ps, Rs, 25, 1, grow, kask):.3f}')
      print(('kaskade' if kask else 'V(1,1)'), f'nu x{grow}/level', '  '.join(out), flush=True)
