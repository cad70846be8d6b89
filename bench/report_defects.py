#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Measure the four defects that the seed report names in its section 5, with
the report's `paper` bending model and with the corrected `energy` model.

    python3 bench/report_defects.py                 # runs nuno, writes PNGs, prints the table
    python3 bench/report_defects.py --help

Runs (report scenes, mm g s, E = eta = 1, paper k_b = 1, energy k_b = 1 * ax):
  1. lift_release (Fig. 3): centre-line length /diagnostics/length against lx.
  2. divergence: lift_release over a long run (kinetic + stretch energy), and a
     free 11 x 11 sheet (100 mm, 1 g) bent by 1e-5 degree, whose flatness grows
     at the paper model's leading eigenvalue; that eigenvalue is computed here
     independently (numpy: paper bending force + axial Voigt springs, central
     finite differences about the flat state, eigenvalues of the first-order
     system [[0, I], [M^-1 K, M^-1 C]]).
  3. bend_release (Fig. 4): flatness at the end / flatness at t = 0.
  4. wave_point (Fig. 5): the same drive on corner (0,0) (wave along the
     diagonal) and on edge i = 0 (wave_nodes = 'edge', wave along x); elastic
     energy stored per unit drive work, with `none` and `energy`.

Writes PNGs into --figures (default docs/figures/defects/) and prints a
markdown table (metric, paper, energy, command) on stdout.
"""
from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402
matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402

from postprocess.reader import read_run  # noqa: E402

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1",
           "OMPI_MCA_btl_vader_single_copy_mechanism": "none"}


# ----------------------------------------------------------------------------
# Running nuno

class Runner:
    def __init__(self, exe, workdir, nranks, mpiexec, reuse=False):
        self.reuse = reuse
        self.exe, self.workdir, self.nranks = exe, Path(workdir), nranks
        self.mpiexec = shlex.split(mpiexec)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.commands = {}

    def __call__(self, name, options=(), **groups):
        """Write name.nml from {group: 'key=value ...'}, run it, return the Run."""
        groups.setdefault("output", "")
        groups["output"] += f" output_file='{name}.h5' write_velocity=.true."
        text = "".join(f"&{g} {body} /\n" for g, body in groups.items())
        nml = self.workdir / f"{name}.nml"
        h5 = self.workdir / f"{name}.h5"
        key = f"{text}{self.nranks} {' '.join(options)}"
        stamp = self.workdir / f"{name}.key"
        if self.reuse and h5.is_file() and stamp.is_file() and stamp.read_text() == key:
            self.commands[name] = "`" + " ".join(
                f"&{g} {b.strip()} /" for g, b in groups.items() if g != "output") + "`"
            return read_run(h5)
        nml.write_text(text)
        cmd = self.mpiexec + ["-n", str(self.nranks), self.exe, nml.name, *options]
        self.commands[name] = "`" + " ".join(
            f"&{g} {b.strip()} /" for g, b in groups.items() if g != "output") + "`"

        t0 = time.time()
        proc = subprocess.run(cmd, cwd=self.workdir, capture_output=True, text=True,
                              env={**os.environ, **MPI_ENV})
        if proc.returncode != 0:
            sys.exit(f"error: {' '.join(cmd)} failed ({proc.returncode}):\n"
                     f"{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        print(f"ran {name} in {time.time() - t0:.1f} s", file=sys.stderr)
        stamp.write_text(key)
        return read_run(self.workdir / f"{name}.h5")


# ----------------------------------------------------------------------------
# Independent linearisation of the paper model about the flat state

def lattice_links(nx, ny):
    out = []
    for j in range(ny):
        for i in range(nx):
            for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
                if 0 <= i + di < nx and 0 <= j + dj < ny:
                    out.append((j * nx + i, (j + dj) * nx + i + di))
    return np.array(out)


def lattice_triples(nx, ny):
    out = []
    for j in range(ny):
        for i in range(nx):
            for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
                if 0 <= i - di < nx and 0 <= i + di < nx and 0 <= j - dj < ny and 0 <= j + dj < ny:
                    out.append(((j - dj) * nx + i - di, j * nx + i, (j + dj) * nx + i + di))
    return np.array(out)


def paper_forces(x, v, rest, links, triples, e, eta, k_b):
    """Axial Voigt springs + report eqs. (2)-(3) bending, docs/model.md sections 2-3."""
    f = np.zeros_like(x)
    p, q = links[:, 0], links[:, 1]
    d = x[p] - x[q]
    l = np.linalg.norm(d, axis=1)
    n = d / l[:, None]
    L = np.linalg.norm(rest[p] - rest[q], axis=1)
    ldot = (n * (v[p] - v[q])).sum(axis=1)
    fp = -(e * (l - L) + eta * ldot)[:, None] * n
    np.add.at(f, p, fp)
    np.add.at(f, q, -fp)
    P, Q, R = triples.T
    u, w = x[P] - x[Q], x[R] - x[Q]
    e1, e2 = -u, w
    theta = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), (e1 * e2).sum(axis=1))
    small = theta < 1e-4
    ratio = np.where(small, 1 + theta**2 / 6, theta / np.where(small, 1.0, np.sin(theta)))

    def q_hat(a, b):  # (I - a_hat a_hat^T) b_hat
        ah = a / np.linalg.norm(a, axis=1)[:, None]
        bh = b / np.linalg.norm(b, axis=1)[:, None]
        return bh - (ah * bh).sum(axis=1)[:, None] * ah

    np.add.at(f, P, -k_b * ratio[:, None] * q_hat(u, w))
    np.add.at(f, R, -k_b * ratio[:, None] * q_hat(w, u))
    return f


def paper_flat_eigenvalues(nx=11, ny=11, lx=100.0, ly=100.0, total_mass=1.0,
                           e=1.0, eta=1.0, k_b=1.0, h=1e-6):
    xs, ys = np.meshgrid(np.linspace(0, lx, nx), np.linspace(0, ly, ny))
    rest = np.stack([xs.ravel(), ys.ravel(), np.zeros(nx * ny)], axis=1)
    links, triples = lattice_links(nx, ny), lattice_triples(nx, ny)
    n = nx * ny
    m = total_mass / n
    zero = np.zeros_like(rest)
    K = np.zeros((3 * n, 3 * n))
    C = np.zeros((3 * n, 3 * n))
    for k in range(3 * n):
        dx = np.zeros(3 * n)
        dx[k] = h
        dx = dx.reshape(n, 3)
        K[:, k] = ((paper_forces(rest + dx, zero, rest, links, triples, e, eta, k_b)
                    - paper_forces(rest - dx, zero, rest, links, triples, e, eta, k_b)) / (2 * h)).ravel()
        C[:, k] = ((paper_forces(rest, dx, rest, links, triples, e, eta, k_b)
                    - paper_forces(rest, -dx, rest, links, triples, e, eta, k_b)) / (2 * h)).ravel()
    A = np.block([[np.zeros((3 * n, 3 * n)), np.eye(3 * n)], [K / m, C / m]])
    return np.linalg.eigvals(A)


# ----------------------------------------------------------------------------
# Measures

def rate(t, y, t0, t1):
    """Exponential growth rate: slope of log(y) over t0 <= t <= t1."""
    sel = (t >= t0 - 1e-9) & (t <= t1 + 1e-9) & (y > 0)
    return float(np.polyfit(t[sel], np.log(y[sel]), 1)[0])


# ----------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=os.environ.get("NUNO_EXE", str(ROOT / "build" / "nuno")),
                    help="nuno executable (default $NUNO_EXE or build/nuno)")
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec") + " --oversubscribe",
                    help="MPI launcher command (default 'mpiexec --oversubscribe')")
    ap.add_argument("-n", "--nranks", type=int, default=1, help="MPI ranks per run (default 1)")
    ap.add_argument("--workdir", default=str(ROOT / "build" / "report_defects"),
                    help="where namelists and HDF5 files go (default build/report_defects)")
    ap.add_argument("--figures", default=str(ROOT / "docs" / "figures" / "defects"),
                    help="PNG output folder (default docs/figures/defects)")
    ap.add_argument("--dt", type=float, default=2e-3, help="time step of every run (default 2e-3)")
    ap.add_argument("--eta-b", type=float, default=5.0,
                    help="bending damping of the damped energy runs (default 5)")
    ap.add_argument("--long", type=float, default=10.0, help="t_end of the divergence run (default 10)")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse HDF5 files in --workdir made by the same namelist and options")
    args = ap.parse_args(argv)
    if not Path(args.exe).is_file():
        ap.exit(1, f"error: {args.exe}: no such executable\n")

    run = Runner(args.exe, args.workdir, args.nranks, args.mpiexec, args.reuse)
    figs = Path(args.figures)
    figs.mkdir(parents=True, exist_ok=True)
    dt, eb = args.dt, args.eta_b
    rows = []

    def cmd(*names):
        return "<br>".join(run.commands[n] for n in names)

    # 1 + 2a. lift_release, long run
    lift = {}
    for key, mat in (("paper", "bending_model='paper'"),
                     ("energy", "bending_model='energy' eta_b=0"),
                     ("energy_damped", f"bending_model='energy' eta_b={eb}")):
        lift[key] = run(f"lift_{key}", scene="scene='lift_release'", material=mat,
                        time=f"t_end={args.long} dt={dt}", output="output_interval=0.05")
    lx = 100.0
    fig1 = {}
    for key, r in lift.items():
        w = r.time <= 5.0 + 1e-9
        L = r.diagnostics["length"]
        fig1[key] = (L[w].max() / lx, L[np.flatnonzero(w)[-1]] / lx, L.max() / lx)
    rows.append(("1. Fig. 3 lift_release: max centre-line length / lx over 0..5 s",
                 f"{fig1['paper'][0]:.3f}", f"{fig1['energy'][0]:.4f}",
                 cmd("lift_paper", "lift_energy")))
    rows.append((f"1. same, max over 0..{args.long:g} s",
                 f"{fig1['paper'][2]:.3f}", f"{fig1['energy'][2]:.4f}", "same runs"))

    f = Figure(figsize=(7, 4))
    ax = f.add_subplot()
    for key, r in lift.items():
        ax.plot(r.time, r.diagnostics["length"] / lx, label=key + ("" if key == "paper" else
                                                                   f" (eta_b={0 if key == 'energy' else eb:g})"))
    ax.set_xlabel("t [s]")
    ax.set_ylabel("centre-line length / lx")
    ax.set_title("Defect 1: lift_release (Fig. 3), length of row j = 5")
    ax.legend()
    f.tight_layout()
    f.savefig(figs / "defect1_length.png", dpi=110)

    # 2. divergence
    def eks(r):
        return r.energy["kinetic"] + r.energy["stretch"]
    late0 = args.long / 2
    stats = {}
    for key, r in lift.items():
        late = r.time >= late0
        stats[key] = (eks(r).max(), eks(r)[late].mean(), eks(r)[-1],
                      np.abs(r.velocity).max(axis=(1, 2, 3))[late].max())
    rows.append((f"2. lift_release: kinetic+stretch energy, max over 0..{args.long:g} s [g mm^2/s^2]",
                 f"{stats['paper'][0]:.4g}", f"{stats['energy_damped'][0]:.4g} (eta_b={eb:g})",
                 cmd("lift_paper", "lift_energy_damped")))
    rows.append((f"2. same, mean over {late0:g}..{args.long:g} s / value at {args.long:g} s",
                 f"{stats['paper'][1]:.4g} / {stats['paper'][2]:.4g}",
                 f"{stats['energy_damped'][1]:.3g} / {stats['energy_damped'][2]:.3g}", "same runs"))

    small = {}
    for key, mat in (("paper", "bending_model='paper'"), ("energy", f"bending_model='energy' eta_b={eb}")):
        small[key] = run(f"flat_{key}", scene="scene='bend_release' bend_angle=1e-5",
                         lattice="nx=11 ny=11 lx=100 ly=100 total_mass=1", material=mat,
                         time=f"t_end=3.2 dt={dt}", output="output_interval=0.05")
    ev = paper_flat_eigenvalues()
    lam = float(ev.real.max())
    # the solver's growth: kinetic energy of the 1e-5 degree bend, window where the
    # leading mode dominates and the amplitude is still small (< 1 mm)
    rs = small["paper"]
    fl = rs.diagnostics["flatness"]
    grow = rate(rs.time, rs.energy["kinetic"], 2.0, 3.0) / 2   # |v| ~ sqrt(E_kin)
    grow_flat = rate(rs.time, fl, 2.0, 3.0)
    # backward Euler turns e^{lam t} into (1 - lam dt)^{-t/dt}
    lam_be = -np.log(1 - lam * dt) / dt
    decay = rate(small["energy"].time, small["energy"].energy["kinetic"], 2.0, 3.0) / 2
    rows.append(("2. flat 11 x 11 sheet (100 mm, 1 g): largest Re(eigenvalue) of the linearisation, numpy [1/s]",
                 f"{lam:.3f}", "(stable: decays)", "`python3 bench/report_defects.py` (numpy)"))
    rows.append(("2. same sheet bent 1e-5 degree: growth rate of sqrt(E_kin) (of flatness), 2..3 s [1/s]",
                 f"{grow:.3f} ({grow_flat:.3f}); beuler-expected {lam_be:.3f}", f"{decay:.3f} (eta_b={eb:g})",
                 cmd("flat_paper", "flat_energy")))

    f = Figure(figsize=(11, 4))
    ax = f.add_subplot(1, 2, 1)
    for key, r in lift.items():
        ax.semilogy(r.time, np.maximum(eks(r), 1e-30), label=key)
    ax.set_ylim(1e-3, None)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("E_kin + E_stretch [g mm^2/s^2]")
    ax.set_title("lift_release, long run")
    ax.legend()
    ax = f.add_subplot(1, 2, 2)
    for key, r in small.items():
        ax.semilogy(r.time, r.diagnostics["flatness"], label=key)
    t = rs.time
    ax.semilogy(t, fl[rs.step_index(2.5)] * np.exp(lam_be * (t - 2.5)), "k--", lw=0.8,
                label=f"exp({lam_be:.2f} t), numpy eigenvalue")
    ax.set_ylim(1e-7, 1e2)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("flatness [mm]")
    ax.set_title("Flat sheet bent 1e-5 degree")
    ax.legend(fontsize=8)
    f.suptitle("Defect 2: divergence")
    f.tight_layout()
    f.savefig(figs / "defect2_divergence.png", dpi=110)

    # 3. bend_release
    bend = {}
    for key, mat in (("paper", "bending_model='paper'"),
                     ("energy", "bending_model='energy' eta_b=0"),
                     ("energy_damped", f"bending_model='energy' eta_b={eb}")):
        bend[key] = run(f"bend_{key}", scene="scene='bend_release'", material=mat,
                        time=f"t_end=5 dt={dt}", output="output_interval=0.05")
    fr = {k: r.diagnostics["flatness"][-1] / r.diagnostics["flatness"][0] for k, r in bend.items()}
    rows.append(("3. Fig. 4 bend_release: flatness(5 s) / flatness(0)",
                 f"{fr['paper']:.3f}", f"{fr['energy']:.3f} (eta_b=0); {fr['energy_damped']:.4f} (eta_b={eb:g})",
                 cmd("bend_paper", "bend_energy", "bend_energy_damped")))
    rows.append(("3. same, centre-line length at 5 s / lx",
                 f"{bend['paper'].diagnostics['length'][-1] / 50:.3f}",
                 f"{bend['energy_damped'].diagnostics['length'][-1] / 50:.4f} (eta_b={eb:g})", "same runs"))
    f = Figure(figsize=(11, 4))
    ax = f.add_subplot(1, 2, 1)
    for key, r in bend.items():
        ax.semilogy(r.time, r.diagnostics["flatness"] / r.diagnostics["flatness"][0], label=key)
    ax.axhline(0.05, color="k", lw=0.6, ls=":")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("flatness / flatness(0)")
    ax.legend()
    ax = f.add_subplot(1, 2, 2)
    for key, r in bend.items():
        for k, ls in ((0, ":"), (r.nt - 1, "-")):
            mid = r.position[k, (r.ny - 1) // 2]
            ax.plot(mid[:, 0], mid[:, 2], ls, label=f"{key} t={r.time[k]:g}" if k else None)
    ax.plot([], [], "k:", label="t = 0")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_title("centre row, side view")
    ax.legend(fontsize=7)
    f.suptitle("Defect 3: bend_release (Fig. 4)")
    f.tight_layout()
    f.savefig(figs / "defect3_flatness.png", dpi=110)

    # 4. wave_point: the same keyframe drive on corner (0,0) (wave along the
    # diagonal, the report's) and on the whole edge i = 0 (wave along +x).
    # Metric: elastic energy stored per unit work of the driven nodes,
    # max_t (E_stretch + E_bend) / max_t |W_external|.
    wave = {}
    for key, mat in (("none", "bending_model='none'"), ("energy", "bending_model='energy' eta_b=0")):
        for nodes in ("corner", "edge"):
            wave[key, nodes] = run(f"wave_{key}_{nodes}",
                                   scene=f"scene='wave_point' wave_nodes='{nodes}'", material=mat,
                                   time=f"t_end=3 dt={dt}", output="output_interval=0.05")

    def stored_per_work(r):
        e = r.energy["stretch"] + r.energy["bend"]
        return float(e.max() / np.abs(r.energy["external_work"]).max())

    def at1(r):
        k = r.step_index(1.0)
        w = abs(float(r.energy["external_work"][k]))
        return float(r.energy["stretch"][k]) / w, float(r.energy["bend"][k]) / w

    spw = {k: stored_per_work(r) for k, r in wave.items()}
    a1 = {k: at1(r) for k, r in wave.items()}
    rat = {m: spw[m, "corner"] / spw[m, "edge"] for m in ("none", "energy")}
    rows.append(("4. Fig. 5 wave_point: max_t (E_stretch + E_bend) / max_t abs(W_external), "
                 "wave along x (edge i = 0 driven); along the diagonal (corner (0,0), the report's)",
                 f"{spw['none', 'edge']:.3g}; {spw['none', 'corner']:.3g} (none)",
                 f"{spw['energy', 'edge']:.3g}; {spw['energy', 'corner']:.3g}",
                 cmd("wave_none_edge", "wave_none_corner", "wave_energy_edge", "wave_energy_corner")))
    rows.append(("4. same: ratio diagonal / along x",
                 f"{rat['none']:.3g} (none)", f"{rat['energy']:.3g}", "same runs"))
    rows.append(("4. same: E_stretch / abs(W_external) at t = 1 s, along x; diagonal",
                 f"{a1['none', 'edge'][0]:.3g}; {a1['none', 'corner'][0]:.3g} (none)",
                 f"{a1['energy', 'edge'][0]:.3g}; {a1['energy', 'corner'][0]:.3g}", "same runs"))
    rows.append(("4. same: E_bend / abs(W_external) at t = 1 s, along x; diagonal",
                 "0; 0 (none)",
                 f"{a1['energy', 'edge'][1]:.3g}; {a1['energy', 'corner'][1]:.3g}", "same runs"))
    f = Figure(figsize=(11, 4))
    for n, m in enumerate(("none", "energy")):
        ax = f.add_subplot(1, 2, n + 1)
        for nodes, ls in (("edge (along x)", "-"), ("corner (diagonal)", "--")):
            r = wave[m, nodes.split()[0]]
            w = np.abs(r.energy["external_work"]).max()
            ax.plot(r.time, r.energy["stretch"] / w, ls, label=f"{nodes}: E_stretch / max|W|")
            if m != "none":
                ax.plot(r.time, r.energy["bend"] / w, ls, label=f"{nodes}: E_bend / max|W|")
        ax.set_yscale("symlog", linthresh=1e-6)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("energy / max |external work|")
        ax.set_title(f"bending '{m}'")
        ax.legend(fontsize=7)
    f.suptitle("Defect 4: wave_point (Fig. 5), elastic energy stored per unit drive work")
    f.tight_layout()
    f.savefig(figs / "defect4_wave.png", dpi=110)

    print("| metric | paper (4: none) | energy | command |")
    print("|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print(f"\nnumpy: largest Re(eigenvalues) of the paper model, flat 11 x 11: "
          f"{np.sort(ev.real)[::-1][:4].round(3).tolist()}")
    print(f"figures in {figs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
