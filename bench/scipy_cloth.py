# SPDX-License-Identifier: BSD-2-Clause
"""The cloth model of docs/model.md written again in NumPy/SciPy, as the
baseline a numerical analyst would write instead of nuno: the state
y = (x, v) of every node as one vector, the right-hand side
ydot = (v, f(x, v)/m + g) vectorised over the elements, its exact sparse
Jacobian, and scipy.integrate.solve_ivp (BDF or Radau) with that Jacobian.
It shares no code with nuno (only the namelist reader for the input file)
and so also cross-checks the model: at tight tolerances the two must agree
to the tolerance (bench/workprecision.py, docs/workprecision.md).

What it covers: the scenes of the benchmark, `hang`, `bend_release` and
`wave_point` (corner), with `spring_model = 'axial'`, `bending_model =
'energy'` or `'none'`, uniform or area masses, element constants
(`lattice_scaling = 'element'`). Anything else is refused.

The model (docs/model.md sections 1-5), node n = i + nx j:
- Voigt links to the eight neighbours, each once (anchor p, q = p + s,
  s in +x, +y, +x+y, -x+y): f_p = -(E (l - L) + eta ldot) n, f_q = -f_p;
  Jacobian blocks written out (model.md section 2).
- energy bending on every triple (p, p + s, p + 2s), same four directions:
  kb = 2 e1 x e2 / (|e1||e2| + e1.e2), W = k_b |kb|^2 / 2, Rayleigh damping
  eta_b |J v|^2 / 2, f = -k_b J^T kb - eta_b J^T J v with J = d kb/dx.
  J is written out; the position derivative of the force (the Hessian of
  kb, with the damping term when eta_b > 0) is taken by complex-step
  differentiation of that force, which is exact to rounding (no
  truncation or cancellation error: Im f(x + i h e_k)/h with h = 1e-30 L),
  the velocity derivative -eta_b J^T J is exact.
- constraints: pinned nodes (hang: corners (0, ny-1), (nx-1, ny-1)) and the
  wave_point corner (0, 0) on its piecewise linear keyframe path: on those
  nodes xdot = vbar (constant in a keyframe window), vdot = 0; the
  integration restarts at every keyframe, as nuno's does.

The linear solves (--lu): solve_ivp factors I - h J with SuperLU's
defaults (COLAMD ordering, partial pivoting). With `--lu nopivot` it takes
the diagonal pivots and a minimum-degree ordering of A^T + A instead: the
v-block's Schur complement of I - h J is M^-1 (M - h C - h^2 K), the
matrix nuno's elimination solves, so the diagonal pivots are safe, and on
hang 21 x 21 a factorisation is about 5 times cheaper with a quarter of
the fill, the same steps and the same solution to 3e-15 (what a careful
user of SciPy would do; docs/workprecision.md, bench/scipy_ratio.py).

    python3 bench/scipy_cloth.py input/bend_release_energy.nml --t-end 1 --method BDF --rtol 1e-6
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.integrate._ivp.bdf as _ivp_bdf
import scipy.integrate._ivp.radau as _ivp_radau
from scipy.integrate import solve_ivp
from scipy.sparse.linalg import splu

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from postprocess import namelist  # noqa: E402

# Scene defaults of the keys the input files of the benchmark may leave out
# (input/README.md, "Scenes"); the benchmark's files set every key.
DEFAULTS = {
    "gravity": [0.0, 0.0, 0.0], "bend_angle": 30.0, "n_keyframes": 3,
    "keyframe_time": [0.0, 0.5, 1.0], "keyframe_dz": [0.0, -10.0, 15.0],
    "wave_nodes": "corner", "spring_model": "axial", "lattice_scaling": "element",
    "initial_omega": [0.0, 0.0, 0.0], "release_time": None,
}

LINK_DIRS = [(1, 0), (0, 1), (1, 1), (-1, 1)]


def read_config(path, overrides=None) -> dict:
    """The keys of a nuno input file as one flat dict, with overrides."""
    nml = namelist.read(Path(path).read_text())
    cfg = dict(DEFAULTS)
    for group in nml:
        for key, value in nml[group].items():
            cfg[key.lower()] = value
    cfg.update(overrides or {})
    return cfg


class Cloth:
    """One scene of docs/model.md as an ODE ydot = rhs(t, y), y = (x, v)."""

    def __init__(self, cfg: dict):
        self.cfg = cfg
        scene = cfg["scene"].lower()
        if scene not in ("hang", "bend_release", "wave_point"):
            raise ValueError(f"scipy_cloth: scene {scene!r} is not covered")
        if cfg.get("spring_model", "axial").lower() != "axial":
            raise ValueError("scipy_cloth: only spring_model = 'axial'")
        if cfg.get("lattice_scaling", "element").lower() != "element":
            raise ValueError("scipy_cloth: only lattice_scaling = 'element'")
        self.bending = cfg["bending_model"].lower()
        if self.bending not in ("energy", "none"):
            raise ValueError("scipy_cloth: only bending_model = 'energy' or 'none'")
        if cfg.get("release_time") is not None:
            raise ValueError("scipy_cloth: release_time is not covered")
        if scene == "wave_point" and cfg.get("wave_nodes", "corner").lower() != "corner":
            raise ValueError("scipy_cloth: only wave_nodes = 'corner'")
        if any(w != 0 for w in cfg.get("initial_omega", [0, 0, 0])):
            raise ValueError("scipy_cloth: initial_omega is not covered")
        self.scene = scene
        nx, ny = int(cfg["nx"]), int(cfg["ny"])
        lx, ly = float(cfg["lx"]), float(cfg["ly"])
        self.nx, self.ny, self.n = nx, ny, nx * ny
        self.size = max(lx, ly)
        ax, ay = lx / (nx - 1), ly / (ny - 1)
        ii, jj = np.meshgrid(np.arange(nx), np.arange(ny))      # [ny][nx]
        ii, jj = ii.ravel(), jj.ravel()                          # node n = i + nx j
        self.rest = np.stack([ii * ax, jj * ay, np.zeros(self.n)], axis=1)
        # masses (section 1)
        if cfg["mass_distribution"].lower() == "area":
            wi = np.where((ii == 0) | (ii == nx - 1), 0.5, 1.0)
            wj = np.where((jj == 0) | (jj == ny - 1), 0.5, 1.0)
            self.mass = cfg["total_mass"] / (lx * ly) * ax * ay * wi * wj
        else:
            self.mass = np.full(self.n, cfg["total_mass"] / self.n)
        self.gravity = np.asarray(cfg.get("gravity", [0, 0, 0]), float)
        # links (section 2)
        p, q, e, eta = [], [], [], []
        for k, (di, dj) in enumerate(LINK_DIRS):
            ok = (ii + di >= 0) & (ii + di < nx) & (jj + dj < ny)
            p.append(np.flatnonzero(ok))
            q.append(np.flatnonzero(ok) + di + nx * dj)
            structural = k < 2
            e.append(np.full(ok.sum(), cfg["e_s"] if structural else cfg["e_d"], float))
            eta.append(np.full(ok.sum(), cfg["eta_s"] if structural else cfg["eta_d"], float))
        self.lp, self.lq = np.concatenate(p), np.concatenate(q)
        self.le, self.leta = np.concatenate(e), np.concatenate(eta)
        self.lrest = np.linalg.norm(self.rest[self.lp] - self.rest[self.lq], axis=1)
        # bending triples (section 3)
        if self.bending == "energy":
            tp = []
            for di, dj in LINK_DIRS:
                ok = (ii + 2 * di >= 0) & (ii + 2 * di < nx) & (jj + 2 * dj < ny)
                a = np.flatnonzero(ok)
                tp.append(np.stack([a, a + di + nx * dj, a + 2 * (di + nx * dj)], axis=1))
            self.tri = np.concatenate(tp)
            self.k_b, self.eta_b = float(cfg["k_b"]), float(cfg["eta_b"])
        else:
            self.tri = np.zeros((0, 3), int)
            self.k_b = self.eta_b = 0.0
        # initial state and constraints (sections 4 and 7)
        self.x0 = self.rest.copy()
        self.fixed = np.zeros(self.n, bool)
        self.keyframes = None
        if scene == "bend_release" and cfg["bend_angle"] > 0:
            radius = lx / np.deg2rad(cfg["bend_angle"])
            phi = (self.rest[:, 0] - 0.5 * lx) / radius
            self.x0[:, 0] = 0.5 * lx + radius * np.sin(phi)
            self.x0[:, 2] = radius * (1 - np.cos(phi))
        elif scene == "hang":
            self.fixed[[nx * (ny - 1), nx * ny - 1]] = True
        elif scene == "wave_point":
            nk = int(cfg["n_keyframes"])
            self.keyframes = (np.asarray(cfg["keyframe_time"][:nk], float),
                              np.asarray(cfg["keyframe_dz"][:nk], float))
            self.fixed[0] = True
        self.free3 = np.repeat(~self.fixed, 3)
        self.vbar = np.zeros((self.n, 3))            # prescribed velocity of the window
        self.nfev = self.njev = 0

    # ------------------------------------------------------------ constraints
    def events(self, t_end):
        if self.keyframes is None:
            return []
        kt = self.keyframes[0]
        return [t for t in kt if 0 < t < t_end]

    def path(self, t, window):
        """Prescribed offset dz and velocity of the keyframed corner in window (ta, tb)."""
        kt, kz = self.keyframes
        tm = 0.5 * (window[0] + window[1])
        m = np.searchsorted(kt, tm, side="right") - 1          # kt[m] <= tm < kt[m+1]
        if m < 0:
            return kz[0], 0.0
        if m >= len(kt) - 1:
            return kz[-1], 0.0
        vz = (kz[m + 1] - kz[m]) / (kt[m + 1] - kt[m])
        return kz[m] + (t - kt[m]) * vz, vz

    def enter_window(self, y, ta, tb):
        """Put the constrained nodes on their path at ta; fix vbar for (ta, tb)."""
        y = y.copy()
        x, v = y[:3 * self.n].reshape(-1, 3), y[3 * self.n:].reshape(-1, 3)
        self.vbar[:] = 0.0
        if self.keyframes is not None:
            dz, vz = self.path(ta, (ta, tb))
            x[0] = self.x0[0] + np.array([0.0, 0.0, dz])
            self.vbar[0] = [0.0, 0.0, vz]
        v[self.fixed] = self.vbar[self.fixed]
        return y

    # ------------------------------------------------------------------ forces
    def _links(self, x, v):
        d = x[self.lp] - x[self.lq]
        vr = v[self.lp] - v[self.lq]
        ln = np.sqrt(np.einsum("ij,ij->i", d, d))
        n = d / ln[:, None]
        ldot = np.einsum("ij,ij->i", n, vr)
        return d, vr, ln, n, ldot

    @staticmethod
    def _skew(a):
        s = np.zeros(a.shape[:-1] + (3, 3), dtype=a.dtype)
        s[..., 0, 1], s[..., 0, 2] = -a[..., 2], a[..., 1]
        s[..., 1, 0], s[..., 1, 2] = a[..., 2], -a[..., 0]
        s[..., 2, 0], s[..., 2, 1] = -a[..., 1], a[..., 0]
        return s

    def _kb_and_jac(self, x9):
        """kb [m, 3] and J = d kb / d(x_p, x_q, x_r) [m, 3, 9] of triples x9 [m, 9] (complex-safe)."""
        e1 = x9[:, 3:6] - x9[:, 0:3]
        e2 = x9[:, 6:9] - x9[:, 3:6]
        l1 = np.sqrt(np.sum(e1 * e1, axis=1))
        l2 = np.sqrt(np.sum(e2 * e2, axis=1))
        psi = l1 * l2 + np.sum(e1 * e2, axis=1)
        z = np.cross(e1, e2)
        kb = 2 * z / psi[:, None]
        g1 = (l2 / l1)[:, None] * e1 + e2                       # d psi / d e1
        g2 = (l1 / l2)[:, None] * e2 + e1                       # d psi / d e2
        # d kb / d e1 = (-2 [e2]x - kb g1^T) / psi, d kb / d e2 = (2 [e1]x - kb g2^T) / psi
        j1 = (-2 * self._skew(e2) - kb[:, :, None] * g1[:, None, :]) / psi[:, None, None]
        j2 = (2 * self._skew(e1) - kb[:, :, None] * g2[:, None, :]) / psi[:, None, None]
        jac = np.concatenate([-j1, j1 - j2, j2], axis=2)        # e1 = xq - xp, e2 = xr - xq
        return kb, jac

    def _bend_force(self, x9, v9):
        kb, jac = self._kb_and_jac(x9)
        lam = self.k_b * kb
        if self.eta_b:
            lam = lam + self.eta_b * np.einsum("mij,mj->mi", jac, v9)
        return -np.einsum("mij,mi->mj", jac, lam)               # [m, 9]

    def forces(self, x, v):
        """Internal force on every node [n, 3]."""
        f = np.zeros((self.n, 3))
        d, vr, ln, n, ldot = self._links(x, v)
        fl = -(self.le * (ln - self.lrest) + self.leta * ldot)[:, None] * n
        np.add.at(f, self.lp, fl)
        np.add.at(f, self.lq, -fl)
        if len(self.tri):
            t = self.tri
            fb = self._bend_force(x[t].reshape(-1, 9), v[t].reshape(-1, 9))
            for c in range(3):
                np.add.at(f, t[:, c], fb[:, 3 * c:3 * c + 3])
        return f

    def rhs(self, t, y):
        self.nfev += 1
        x, v = y[:3 * self.n].reshape(-1, 3), y[3 * self.n:].reshape(-1, 3)
        a = self.forces(x, v) / self.mass[:, None] + self.gravity
        xdot = v.copy()
        xdot[self.fixed] = self.vbar[self.fixed]
        a[self.fixed] = 0.0
        return np.concatenate([xdot.ravel(), a.ravel()])

    def force_jacobians(self, x, v):
        """K = df/dx and C = df/dv, sparse [3n, 3n]."""
        rows, cols, kv, cv = [], [], [], []
        d, vr, ln, n, ldot = self._links(x, v)
        eye = np.eye(3)
        P = n[:, :, None] * n[:, None, :]
        Q = eye - P
        qv = vr - ldot[:, None] * n
        E, eta, L = self.le[:, None, None], self.leta[:, None, None], self.lrest[:, None, None]
        lnb, ldb = ln[:, None, None], ldot[:, None, None]
        kp = -E * P - E * (1 - L / lnb) * Q - eta * (n[:, :, None] * qv[:, None, :] + ldb * Q) / lnb
        cp = -eta * P
        # blocks (p,p) +, (p,q) -, (q,p) -, (q,q) +
        ij = np.arange(3)
        for a, b, s in ((self.lp, self.lp, 1), (self.lp, self.lq, -1), (self.lq, self.lp, -1), (self.lq, self.lq, 1)):
            r = (3 * a[:, None, None] + ij[None, :, None]) + 0 * ij[None, None, :]
            c = (3 * b[:, None, None] + ij[None, None, :]) + 0 * ij[None, :, None]
            rows.append(r.ravel())
            cols.append(c.ravel())
            kv.append((s * kp).ravel())
            cv.append((s * cp).ravel())
        if len(self.tri):
            t = self.tri
            x9, v9 = x[t].reshape(-1, 9), v[t].reshape(-1, 9)
            h = 1e-30 * self.size
            k9 = np.empty((len(t), 9, 9))
            for c in range(9):                                   # complex step, column c
                xc = x9.astype(complex)
                xc[:, c] += 1j * h
                k9[:, :, c] = self._bend_force(xc, v9.astype(complex)).imag / h
            _, jac = self._kb_and_jac(x9)
            c9 = -self.eta_b * np.einsum("mki,mkj->mij", jac, jac)
            idx = (3 * t[:, :, None] + ij[None, None, :]).reshape(-1, 9)   # [m, 9] global dofs
            rows.append(np.repeat(idx[:, :, None], 9, axis=2).ravel())
            cols.append(np.repeat(idx[:, None, :], 9, axis=1).ravel())
            kv.append(k9.ravel())
            cv.append(c9.ravel())
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        shape = (3 * self.n, 3 * self.n)
        K = sp.csr_matrix((np.concatenate(kv), (rows, cols)), shape=shape)
        C = sp.csr_matrix((np.concatenate(cv), (rows, cols)), shape=shape)
        return K, C

    def jac(self, t, y):
        """d rhs / dy: [[0, I], [M^-1 K, M^-1 C]], zero rows on constrained nodes."""
        self.njev += 1
        x, v = y[:3 * self.n].reshape(-1, 3), y[3 * self.n:].reshape(-1, 3)
        K, C = self.force_jacobians(x, v)
        scale = np.where(self.free3, 1.0 / np.repeat(self.mass, 3), 0.0)
        D = sp.diags(scale)
        top = sp.diags(self.free3.astype(float))
        Z = sp.csr_matrix((3 * self.n, 3 * self.n))
        return sp.bmat([[Z, top], [D @ K, D @ C]], format="csc")

    # ----------------------------------------------------------- integration
    def y0(self):
        return np.concatenate([self.x0.ravel(), np.zeros(3 * self.n)])

    def atol(self, rtol, time_scale=1.0, atol_position=None, atol_velocity=None):
        """nuno's per-field tolerances (input/README.md, "Error tolerances")."""
        ax = rtol * self.size if atol_position is None else atol_position
        av = ax / time_scale if atol_velocity is None else atol_velocity
        return np.concatenate([np.full(3 * self.n, ax), np.full(3 * self.n, av)])

    def solve(self, t_end, method="BDF", rtol=1e-6, atol=None, first_step=None, lu="superlu"):
        """Integrate to t_end, restarting at keyframes. Returns (x [ny][nx][3], info).
        lu: 'superlu' (solve_ivp's own factorisation) or 'nopivot' (module docstring)."""
        if lu == "nopivot":
            saved = _ivp_bdf.splu, _ivp_radau.splu
            _ivp_bdf.splu = _ivp_radau.splu = _splu_nopivot
            try:
                return self.solve(t_end, method, rtol, atol, first_step)
            finally:
                _ivp_bdf.splu, _ivp_radau.splu = saved
        if lu != "superlu":
            raise ValueError(f"scipy_cloth: lu {lu!r} is neither 'superlu' nor 'nopivot'")
        if atol is None:
            atol = self.atol(rtol)
        y = self.y0()
        stops = self.events(t_end) + [t_end]
        ta = 0.0
        nsteps = 0
        cpu = time.process_time()
        for tb in stops:
            y = self.enter_window(y, ta, tb)
            sol = solve_ivp(self.rhs, (ta, tb), y, method=method, rtol=rtol, atol=atol,
                            jac=self.jac, first_step=first_step)
            if sol.status != 0:
                raise RuntimeError(f"solve_ivp {method} failed at t = {sol.t[-1]}: {sol.message}")
            y = sol.y[:, -1]
            nsteps += len(sol.t) - 1
            ta = tb
        cpu = time.process_time() - cpu
        x = y[:3 * self.n].reshape(self.ny, self.nx, 3)
        return x, {"cpu_time": cpu, "steps": nsteps, "nfev": self.nfev, "njev": self.njev}


def _splu_nopivot(A):
    """SuperLU with the diagonal pivots and a minimum-degree ordering of A^T + A."""
    return splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0)


def check_jacobian(cloth: Cloth, seed: int = 1, eps: float = 1e-6) -> float:
    """Largest relative difference between jac() and central differences of rhs()."""
    rng = np.random.default_rng(seed)
    y = cloth.y0()
    y[:3 * cloth.n] += 0.05 * cloth.size / max(cloth.nx, cloth.ny) * rng.standard_normal(3 * cloth.n)
    y[3 * cloth.n:] = rng.standard_normal(3 * cloth.n) * cloth.size
    J = cloth.jac(0.0, y).toarray()
    scale = np.abs(y) * eps + eps
    Jfd = np.empty_like(J)
    for k in range(len(y)):
        yp, ym = y.copy(), y.copy()
        yp[k] += scale[k]
        ym[k] -= scale[k]
        Jfd[:, k] = (cloth.rhs(0, yp) - cloth.rhs(0, ym)) / (2 * scale[k])
    return float(np.abs(J - Jfd).max() / np.abs(J).max())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("input", help="nuno input file (namelist)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a key (nx=65); repeatable")
    p.add_argument("--t-end", type=float, default=1.0)
    p.add_argument("--method", default="BDF", choices=["BDF", "Radau"])
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--lu", default="superlu", choices=["superlu", "nopivot"],
                   help="factorisation of I - h J: solve_ivp's SuperLU defaults, or diagonal pivots "
                        "with a minimum-degree ordering")
    p.add_argument("--check-jacobian", action="store_true", help="compare jac() with differences and exit")
    p.add_argument("-o", "--output", help="write the final positions here (.npy)")
    args = p.parse_args(argv)
    over = {}
    for kv in args.set:
        k, _, v = kv.partition("=")
        over[k.strip().lower()] = namelist.parse_value(v)
    cloth = Cloth(read_config(args.input, over))
    if args.check_jacobian:
        print(f"jacobian_error {check_jacobian(cloth):.3e}")
        return 0
    x, info = cloth.solve(args.t_end, args.method, args.rtol, lu=args.lu)
    print(" ".join(f"{k} {v}" for k, v in info.items()))
    if args.output:
        np.save(args.output, x)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
