#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The contact benchmark (issue 39): what contact costs a step.

The two contact scenes, input/drape_sphere.nml and input/drop_table.nml, at
N x N nodes, each run against the same lattice without obstacles
(n_obstacles = 0: a free sheet falling), the two alternated, in the modes of
bench/solver.py:
  bw      Baraff-Witkin: one linearised solve a step (-snes_type ksponly,
          -reduced_ksp_rtol 1e-3), dt = 1/600 s;
  newton  full Newton at the defaults, dt = 1 ms.
The obstacle is moved up so that the cloth touches it from the first step
(the table's top, or the sphere's, 0.9 mm below the flat cloth: inside the
barrier's reach of 1 mm), so every step measured is a step with contact
(the scenes as shipped fall 5 cm first: the first 100 steps have none).
Per run: node-steps/s (N^2 times the steps over the time of -log_view's
TSStep event), Newton and inner (Krylov) iterations a step (the run's
summary line), Jacobian assemblies a step (-log_view's SNESJacobianEval),
the active contacts at the end (the last `contact:` line), and the ratio of the contact run's TSStep time to the free one's (the
issue's target: at most 1.5 at 257 x 257 in bw mode). Each pair is
repeated --repeat times and the fastest of each kept.

    source tools/env.sh
    python3 bench/contact.py --sizes 129 257               # both scenes, bw and newton, 1 rank
    python3 bench/contact.py --sizes 129 --output table.md
    python3 bench/contact.py --sizes 1025 --ranks 2 --modes bw   # the large lattice
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from postprocess import namelist  # noqa: E402
from solver import MODES, event  # noqa: E402  (the modes and -log_view parsing of the main benchmark)

SCENES = ("drape_sphere", "drop_table")
# steps a run: contact spreads as the sheet settles or drapes, so issue
# 46's steps from rest (bench/solver.py's) and 60 at 33, few enough for
# minutes in all
STEPS = {33: 60, 65: 60, 129: 60, 257: 30, 513: 20, 1025: 10}
# [m] the obstacle's top below the flat cloth at the start: inside the
# barrier's reach (contact_dhat = 1 mm), near where the barrier
# (contact_stiffness 1 N/m) carries a node's weight at 129 x 129 (0.87 mm)
# and 257 x 257 (0.93 mm), so the sheet neither bounces off nor sinks in
GAP0 = 0.9e-3
# [s] the time step of each mode, as docs/performance.md's tables of this
# benchmark were measured; the options are bench/solver.py's MODES, whose
# newton runs at issue 46's 1/600 s
DT = {"bw": 1.0 / 600.0, "newton": 1.0e-3}


def scene_text(scene, n, mode, contact):
    """The scene's namelist at n x n nodes for `mode`, with its obstacle
    moved up to GAP0 below the cloth, or without obstacles."""
    dt = DT[mode]
    steps = STEPS.get(n, 10)
    nml = namelist.read((ROOT / "input" / f"{scene}.nml").read_text())
    nml["lattice"].update(nx=n, ny=n)
    nml["time"].update(t_end=steps * dt, dt=dt)
    nml["output"].update(output_interval=steps * dt, output_file="b.h5")
    c = nml["contact"]
    if contact:
        x, y, _ = c["obstacle_point"][0]             # obstacle_point(:, 1)
        if scene == "drape_sphere":
            z = -(float(c["obstacle_radius"][0]) + GAP0)   # the sphere's top GAP0 below z = 0
        else:
            z = -GAP0                                      # the table's top GAP0 below z = 0
        c["obstacle_point"] = [[x, y, z]]
    else:
        # no &contact at all: obstacle keys beyond n_obstacles = 0 are refused
        del nml["contact"]
    return str(nml) + "\n"


def run(exe, mpiexec, scene, n, nranks, mode, contact, timeout):
    """One run: a dict of its numbers, or ok=False with why."""
    _, opts = MODES[mode]
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "b.nml").write_text(scene_text(scene, n, mode, contact))
        cmd = [mpiexec, "-n", str(nranks), "--oversubscribe", exe, "b.nml", "-log_view", *opts]
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return dict(ok=False, why=f"no result in {timeout:g} s")
        wall = time.perf_counter() - t0
    out = p.stdout
    if p.returncode != 0:
        last = (p.stdout + p.stderr).strip().splitlines()
        why = next((ln for ln in reversed(last) if "nuno: error" in ln or "failed" in ln),
                   last[-1] if last else "?")
        return dict(ok=False, why=why.strip()[:160])
    _, t_step, _ = event(out, "TSStep")
    jac, _, _ = event(out, "SNESJacobianEval")
    summary = [ln for ln in out.splitlines() if ln.startswith("t =")][-1]
    steps, rejected, newton, linear = map(int, re.findall(
        r"steps\s+(\d+)\s+rejected\s+(\d+)\s+newton\s+(\d+)\s+linear\s+(\d+)", summary)[0])
    act = re.findall(r"contact: t = \S+, active = (\d+)", out)
    limited = re.findall(r"limited updates = (\d+)", out)
    return dict(ok=True, steps=steps, rejected=rejected, newton=newton / max(steps, 1),
                inner=linear / max(steps, 1), jac=jac / max(steps, 1), t_step=t_step, rate=n * n * steps / t_step,
                active=int(act[-1]) if act else 0, limited=int(limited[-1]) if limited else None,
                wall=wall)


def best(tries):
    good = [t for t in tries if t["ok"]]
    return min(good, key=lambda t: t["t_step"]) if good else tries[0]


HEAD = ("| scene | mode | N | ranks | steps | node-steps/s, contact | node-steps/s, free | time ratio "
        "| Newton / step, contact / free | Jacobians / step, contact / free | inner / step, contact / free "
        "| active contacts at the end |")


def row(scene, mode, n, p, c, f):
    def num(r, key, fmt):
        return fmt.format(r[key]) if r["ok"] else "failed"

    ratio = f"{c['t_step'] / f['t_step']:.2f}" if c["ok"] and f["ok"] else "-"
    fails = "; ".join(f"{w}: {r['why']}" for w, r in (("contact", c), ("free", f)) if not r["ok"])
    steps = c["steps"] if c["ok"] else (f["steps"] if f["ok"] else "-")
    return (f"| {scene} | {mode} | {n} | {p} | {steps} | {num(c, 'rate', '{:.3g}')} | {num(f, 'rate', '{:.3g}')} "
            f"| {ratio} | {num(c, 'newton', '{:.2f}')} / {num(f, 'newton', '{:.2f}')} "
            f"| {num(c, 'jac', '{:.2f}')} / {num(f, 'jac', '{:.2f}')} "
            f"| {num(c, 'inner', '{:.1f}')} / {num(f, 'inner', '{:.1f}')} "
            f"| {c['active'] if c['ok'] else '-'} of {n * n} |" + (f" {fails}" if fails else ""))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    ap.add_argument("--sizes", type=int, nargs="+", default=[129, 257],
                    help="N of the N x N lattice (1025: the large case, with --ranks 2)")
    ap.add_argument("--ranks", type=int, default=1, help="MPI ranks (default 1)")
    ap.add_argument("--modes", nargs="+", default=["bw", "newton"], choices=("bw", "newton"))
    ap.add_argument("--repeat", type=int, default=2, help="contact/free pairs of each case, the fastest kept")
    ap.add_argument("--timeout", type=float, default=900, help="seconds a run")
    ap.add_argument("--output", help="also write the markdown table to this file")
    a = ap.parse_args(argv)
    a.exe = str(Path(a.exe).resolve())  # the runs start in their own folders
    if not Path(a.exe).is_file():
        ap.error(f"--exe {a.exe}: no such file (bash tools/build.sh first)")
    lines = [HEAD, "|" + "---|" * 12]
    print(lines[0] + "\n" + lines[1], flush=True)
    for scene in a.scenes:
        for mode in a.modes:
            for n in a.sizes:
                pairs = [(run(a.exe, a.mpiexec, scene, n, a.ranks, mode, True, a.timeout),
                          run(a.exe, a.mpiexec, scene, n, a.ranks, mode, False, a.timeout))
                         for _ in range(a.repeat)]
                c, f = best([p[0] for p in pairs]), best([p[1] for p in pairs])
                lines.append(row(scene, mode, n, a.ranks, c, f))
                print(lines[-1], flush=True)
    if a.output:
        Path(a.output).write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
