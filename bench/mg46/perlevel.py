import sys, numpy as np, scipy.sparse.linalg as spla
from model import *
coef = ETA_B + K_B / A_SHIFT
n = int(sys.argv[1]); cubic = sys.argv[2] == 'cubic'
A = bending(n, coef)
levs, Ps = hierarchy(A, n, int(np.log2(n - 1)) - 1, cubic)
for l in range(len(levs) - 1):
    sub = [Level(levs[l].A), Level(levs[l + 1].A)]
    sub[-1].lu = spla.splu(sub[-1].A.tocsc())
    rho, _ = rate(sub, [Ps[l]], 30)
    d = levs[l].A.diagonal(); nn = int(round(np.sqrt(levs[l].A.shape[0])))
    nnz = levs[l].A.getrow(nn * (nn // 2) + nn // 2).nnz
    print(f'level {l+1} ({nn}x{nn}, {nnz} entries a row): two-grid V(1,1) with level {l+2} exact: {rho:.3f}', flush=True)
