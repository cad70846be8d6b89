# SPDX-License-Identifier: BSD-2-Clause
"""Order of accuracy against an exact solution. With spring_model='linear'
and no bending the cloth is a linear system M xddot + C xdot + K (x - X) = 0
(docs/model.md section 2). The test builds K and C itself from the links of the
lattice, solves the first-order system exactly by eigen-decomposition, and
compares with nuno's positions at t_end as dt halves: backward Euler must
converge at order 1, Crank-Nicolson (cn and theta 0.5) at order 2."""
import numpy as np
import pytest

from nunorun import run_and_read

NX, NY = 5, 4
E_S, ETA_S, E_D, ETA_D = 1.0, 0.2, 0.7, 0.1
T_END = 1.0
GROUPS = dict(scene="scene='lift_release' lift_length=50 lift_height=20",
              lattice=f"nx={NX} ny={NY} lx=100 ly=60 total_mass=1.0",
              material=f"spring_model='linear' bending_model='none' e_s={E_S} eta_s={ETA_S} "
                       f"e_d={E_D} eta_d={ETA_D}")


def exact_positions(x0, mass, t):
    """Exact x(t) [ny][nx][3] of the linear lattice from rest at x0, edge i = 0 pinned."""
    ny, nx = mass.shape
    n = nx * ny
    idx = lambda i, j: j * nx + i  # noqa: E731
    K = np.zeros((n, n))
    C = np.zeros((n, n))
    for j in range(ny):
        for i in range(nx):
            for di, dj in ((1, 0), (0, 1), (1, 1), (-1, 1)):
                a, b = i + di, j + dj
                if not (0 <= a < nx and 0 <= b < ny):
                    continue
                e, eta = (E_S, ETA_S) if di == 0 or dj == 0 else (E_D, ETA_D)
                p, q = idx(i, j), idx(a, b)
                for (u, w, s) in ((p, p, 1), (q, q, 1), (p, q, -1), (q, p, -1)):
                    K[u, w] += s * e
                    C[u, w] += s * eta
    free = np.array([idx(i, j) for j in range(ny) for i in range(nx) if i > 0])
    m = mass.reshape(n)[free]
    Kf, Cf = K[np.ix_(free, free)], C[np.ix_(free, free)]
    nf = len(free)
    A = np.block([[np.zeros((nf, nf)), np.eye(nf)],
                  [-Kf / m[:, None], -Cf / m[:, None]]])
    lam, V = np.linalg.eig(A)
    rest = np.zeros((ny, nx, 3))
    rest[..., 0] = np.arange(nx)[None, :] * 100.0 / (nx - 1)
    rest[..., 1] = np.arange(ny)[:, None] * 60.0 / (ny - 1)
    u0 = (x0 - rest).reshape(n, 3)[free]        # displacement from rest, per component
    out = x0.reshape(n, 3).copy()
    for c in range(3):                          # the components decouple
        y0 = np.concatenate([u0[:, c], np.zeros(nf)])
        y = (V @ (np.exp(lam * t) * np.linalg.solve(V, y0))).real
        out[free, c] = rest.reshape(n, 3)[free, c] + y[:nf]
    return out.reshape(ny, nx, 3)


def errors(tmp_path, options, dts):
    errs = []
    for k, dt in enumerate(dts):
        _, r = run_and_read(tmp_path, f"lin{k}", options=options,
                            time=f"t_end={T_END} dt={dt}", output=f"output_interval={T_END}", **GROUPS)
        assert r.complete and abs(r.time[-1] - T_END) < 1e-12
        x_exact = exact_positions(r.position[0], r.mass, T_END)
        moved = np.abs(x_exact - r.position[0]).max()
        assert moved > 1.0                      # the cloth really moves [mm]
        errs.append(np.abs(r.position[-1] - x_exact).max())
    return np.array(errs)


def order(dts, errs):
    return np.polyfit(np.log(dts), np.log(errs), 1)[0]


DTS = [0.04, 0.02, 0.01, 0.005]


@pytest.mark.parametrize("options,expected", [
    (("-ts_type", "beuler"), 1.0),
    (("-ts_type", "cn"), 2.0),
    (("-ts_type", "theta", "-ts_theta_theta", "0.5", "-ts_theta_endpoint"), 2.0),
])
def test_order_of_accuracy(tmp_path, options, expected):
    tight = ("-snes_rtol", "1e-12", "-ksp_rtol", "1e-13")
    errs = errors(tmp_path, options + tight, DTS)
    p = order(DTS, errs)
    assert abs(p - expected) < 0.15, f"{options}: errors {errs}, order {p:.3f}"
    assert errs[-1] < errs[0]
