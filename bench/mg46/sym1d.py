import numpy as np
from model import prolong_1d
n = 129
A = np.zeros((n, n))
for i in range(n - 2):
    d = np.zeros(n); d[i:i+3] = [1, -2, 1]; A += np.outer(d, d)
for cub in (False, True):
    P = prolong_1d(n, cub).toarray()
    G = P.T @ A @ P
    mid = G.shape[0] // 2
    st = G[mid, mid-5:mid+6]
    print('cubic' if cub else 'bilinear', np.round(st, 5), 'sum*o^4/24:', sum(st[k] * (k-5)**4 for k in range(11)) / 24)
print('consistent (rediscretised, x2 Galerkin scale):', 2 * np.array([1,-4,6,-4,1]) / 16, 2 * 24 / 16 / 24)
# collapse cubic onto reach 2 by Lagrange weights (degree 4)
P = prolong_1d(n, True).toarray(); G = P.T @ A @ P; mid = G.shape[0]//2; st = G[mid, mid-5:mid+6]
nodes = np.arange(-2, 3)
def lag(x):
    return np.array([np.prod([(x - b) / (a - b) for b in nodes if b != a]) for a in nodes])
col = np.zeros(5)
for k, o in enumerate(range(-5, 6)):
    if abs(o) <= 2:
        col[o + 2] += st[k]
    else:
        col += st[k] * lag(o)
print('collapsed', np.round(col, 5))
th = np.linspace(0, np.pi, 7)
for name, s, offs in (('bilin', None, None),):
    pass
def symb(s, offs):
    return np.array([sum(c * np.cos(o * t) for c, o in zip(s, offs)) for t in th])
print('theta', np.round(th, 2))
print('cubic symbol', np.round(symb(st, range(-5, 6)), 4))
print('collapsed   ', np.round(symb(col, range(-2, 3)), 4))
print('consistent  ', np.round(symb(2*np.array([1,-4,6,-4,1])/16, range(-2, 3)), 4))
