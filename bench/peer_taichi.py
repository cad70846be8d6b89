#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The peer of issue 46: a matrix-free Baraff-Witkin PCG cloth in Taichi.

The same scene as input/hang.nml at N x N nodes: 1 m x 1 m, 0.1 kg with
area masses, the two corners of the edge j = N-1 pinned, gravity
(0, 0, -9.81) m/s^2, released flat and at rest. Springs to 12 neighbours a
node (each spring counted at both ends: 6 a node): 4 structural, 4 shear and
4 two-hop ones (the peer's bending), all axial Voigt elements with
E = --stiffness N/m (default 100, hang's E) and eta = --damping N s/m
(default 0.1, hang's eta), rest length their rest distance.

One backward-Euler step linearised once (Baraff and Witkin 1998) a time
step: (M - dt D - dt^2 K) dv = dt (f + dt K v), K and D the spring Jacobians
(K with the transverse term clamped at >= 0, as the peers do, so that the
matrix stays symmetric positive definite), applied matrix-free: every
product recomputes each spring's direction from x (no stored blocks).
Jacobi-preconditioned CG to relative residual --rtol (1e-3), from the last
step's dv, pinned nodes filtered out (dv = 0 there). float64 throughout.

The first call creates runs/peer-venv and installs taichi from PyPI there,
then every call runs inside that venv (re-executed). Prints one line:
  peer N=... threads=... steps=... cg_iterations_per_step=... node_steps_per_s=...
timed over --steps steps after one warm-up step (the JIT compiles there).
"""
import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                epilog="run: python3 bench/peer_taichi.py --n 257 --steps 30")
    p.add_argument("--n", type=int, default=257, help="nodes along each side (default 257)")
    p.add_argument("--steps", type=int, default=30, help="timed steps after the warm-up step (default 30)")
    p.add_argument("--threads", type=int, default=1, help="CPU threads of Taichi (default 1)")
    p.add_argument("--dt", type=float, default=1.0 / 600, help="time step [s] (default 1/600)")
    p.add_argument("--rtol", type=float, default=1e-3, help="CG relative residual (default 1e-3)")
    p.add_argument("--stiffness", type=float, default=100.0, help="E of every spring [N/m] (default 100)")
    p.add_argument("--damping", type=float, default=0.1, help="eta of every spring [N s/m] (default 0.1)")
    p.add_argument("--venv", default=os.path.join(ROOT, "runs", "peer-venv"),
                   help="virtual environment with taichi (default runs/peer-venv)")
    a = p.parse_args()
    if a.n < 3 or a.steps < 1 or a.threads < 1:
        p.error(f"need --n >= 3, --steps >= 1, --threads >= 1 (got {a.n}, {a.steps}, {a.threads})")
    return a


def enter_venv(venv):
    """Re-execute inside venv, creating it and installing taichi first if needed."""
    if os.path.realpath(sys.prefix) == os.path.realpath(venv):
        return
    py = os.path.join(venv, "bin", "python")
    if not os.path.exists(py):
        subprocess.run([sys.executable, "-m", "venv", venv], check=True)
    if subprocess.run([py, "-c", "import taichi"], capture_output=True).returncode != 0:
        subprocess.run([py, "-m", "pip", "install", "-q", "taichi"], check=True)
    os.execv(py, [py, os.path.abspath(__file__)] + sys.argv[1:])


def main():
    a = parse()
    enter_venv(a.venv)
    import taichi as ti
    ti.init(arch=ti.cpu, default_fp=ti.f64, cpu_max_num_threads=a.threads, log_level=ti.WARN)
    n, dt, E, eta = a.n, a.dt, a.stiffness, a.damping
    h = 1.0 / (n - 1)                      # spacing [m]
    vec = ti.Vector.field
    x, v, dv, b, r, z, p, q = (vec(3, ti.f64, shape=(n, n)) for _ in range(8))   # [m], [m/s], ...
    mass = ti.field(ti.f64, shape=(n, n))  # area masses [kg]
    diag = vec(3, ti.f64, shape=(n, n))    # diagonal of A [kg]
    free = ti.field(ti.f64, shape=(n, n))  # 0 at the pinned corners, 1 elsewhere
    offs = ti.Matrix([[1, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [-1, -1], [1, -1], [-1, 1],
                      [2, 0], [-2, 0], [0, 2], [0, -2]], ti.i32)   # the 12 neighbours

    @ti.kernel
    def init():
        for i, j in x:
            x[i, j] = ti.Vector([i * h, j * h, 0.0])
            v[i, j] = ti.Vector([0.0, 0.0, 0.0])
            dv[i, j] = ti.Vector([0.0, 0.0, 0.0])
            w = (0.5 if i == 0 or i == n - 1 else 1.0) * (0.5 if j == 0 or j == n - 1 else 1.0)
            mass[i, j] = 0.1 * h * h * w   # areal density 0.1 kg/m^2
            free[i, j] = 0.0 if j == n - 1 and (i == 0 or i == n - 1) else 1.0

    @ti.func
    def spring(i, j, k):
        """Direction n, rest length L, length l of the spring from (i,j) to its k-th neighbour."""
        ii, jj = i + offs[k, 0], j + offs[k, 1]
        d = x[i, j] - x[ii, jj]
        l = d.norm()
        L = h * ti.sqrt(ti.cast(offs[k, 0] ** 2 + offs[k, 1] ** 2, ti.f64))
        return ii, jj, d / l, L, l

    @ti.func
    def inside(i, j, k):
        ii, jj = i + offs[k, 0], j + offs[k, 1]
        return 0 <= ii < n and 0 <= jj < n

    @ti.func
    def apply_K(i, j, k, nn, L, l, u):
        """K_s u for one spring: E [n n^T + max(0, 1 - L/l) (I - n n^T)] u  [N/m * u]."""
        un = nn.dot(u) * nn
        return E * (un + ti.max(0.0, 1.0 - L / l) * (u - un))

    @ti.kernel
    def rhs():
        """b = dt (f + dt K v), f = gravity + springs (axial Voigt); diag of A."""
        for i, j in x:
            f = mass[i, j] * ti.Vector([0.0, 0.0, -9.81])
            kv = ti.Vector([0.0, 0.0, 0.0])
            dg = ti.Vector([mass[i, j], mass[i, j], mass[i, j]])
            for k in ti.static(range(12)):
                if inside(i, j, k):
                    ii, jj, nn, L, l = spring(i, j, k)
                    rel = v[i, j] - v[ii, jj]
                    f -= (E * (l - L) + eta * nn.dot(rel)) * nn
                    kv -= apply_K(i, j, k, nn, L, l, rel)
                    c = ti.max(0.0, 1.0 - L / l)
                    dg += dt * dt * E * (nn * nn + c * (1.0 - nn * nn)) + dt * eta * nn * nn
            b[i, j] = free[i, j] * dt * (f + dt * kv)
            diag[i, j] = dg

    @ti.kernel
    def matvec():
        """q = A p, A = M - dt D - dt^2 K, recomputed from x (matrix-free)."""
        for i, j in p:
            u0 = p[i, j]
            y = mass[i, j] * u0
            for k in ti.static(range(12)):
                if inside(i, j, k):
                    ii, jj, nn, L, l = spring(i, j, k)
                    rel = u0 - p[ii, jj]
                    y += dt * dt * apply_K(i, j, k, nn, L, l, rel) + dt * eta * nn.dot(rel) * nn
            q[i, j] = free[i, j] * y

    @ti.kernel
    def residual() -> ti.f64:
        """r = b - A dv (q holds A dv), z = D^-1 r, p = z; returns r.z."""
        s = 0.0
        for i, j in r:
            r[i, j] = b[i, j] - q[i, j]
            z[i, j] = r[i, j] / diag[i, j]
            p[i, j] = z[i, j]
            s += r[i, j].dot(z[i, j])
        return s

    @ti.kernel
    def norm2(a: ti.template()) -> ti.f64:
        s = 0.0
        for i, j in a:
            s += a[i, j].dot(a[i, j])
        return s

    @ti.kernel
    def pq() -> ti.f64:
        s = 0.0
        for i, j in p:
            s += p[i, j].dot(q[i, j])
        return s

    @ti.kernel
    def update(alpha: ti.f64) -> ti.types.vector(2, ti.f64):
        """dv += alpha p, r -= alpha q, z = D^-1 r; returns (r.z, r.r)."""
        s = 0.0
        t = 0.0
        for i, j in r:
            dv[i, j] += alpha * p[i, j]
            r[i, j] -= alpha * q[i, j]
            z[i, j] = r[i, j] / diag[i, j]
            s += r[i, j].dot(z[i, j])
            t += r[i, j].dot(r[i, j])
        return ti.Vector([s, t])

    @ti.kernel
    def direction(beta: ti.f64):
        for i, j in p:
            p[i, j] = z[i, j] + beta * p[i, j]

    @ti.kernel
    def advance():
        for i, j in x:
            v[i, j] += free[i, j] * dv[i, j]
            x[i, j] += dt * v[i, j]

    def step():
        """One Baraff-Witkin step; returns the CG iterations."""
        rhs()
        bnorm = norm2(b) ** 0.5
        p.copy_from(dv)        # warm start from the last step's dv
        matvec()
        rz = residual()
        rr = norm2(r)
        it = 0
        while rr ** 0.5 > a.rtol * bnorm and it < 10000:
            matvec()
            rz_new, rr = update(rz / pq())
            direction(rz_new / rz)
            rz = rz_new
            it += 1
        advance()
        return it

    init()
    step()                     # warm-up: the JIT compiles every kernel here
    ti.sync()
    t0 = time.perf_counter()
    its = sum(step() for _ in range(a.steps))
    ti.sync()
    sec = time.perf_counter() - t0
    print(f"peer N={n} threads={a.threads} steps={a.steps} cg_iterations_per_step={its / a.steps:.2f} "
          f"node_steps_per_s={n * n * a.steps / sec:.4g}", flush=True)


if __name__ == "__main__":
    main()
