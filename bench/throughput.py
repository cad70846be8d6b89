#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Throughput of nuno's default solver: node-steps per second of TSStep
(from -log_view) on the hang scene and a report scene, for a few lattice
sizes and rank counts. Writes a markdown table (stdout, or --output).

    source tools/env.sh
    python3 bench/throughput.py --output docs/bench-throughput.md
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

CASES = [  # (label, namelist groups, node count)
    ("lift_release 11x11 (paper)", "&scene scene='lift_release' /\n&time t_end=0.5 dt=1e-3 /", 121),
    ("bend_release 11x11 (energy)", "&scene scene='bend_release' /\n&material bending_model='energy' /\n"
                                    "&time t_end=0.5 dt=1e-3 /", 121),
    ("hang 21x21", "&scene scene='hang' /\n&time t_end=0.1 dt=1e-3 /", 441),
    ("hang 41x41", "&scene scene='hang' /\n&lattice nx=41 ny=41 /\n&time t_end=0.05 dt=1e-3 /", 1681),
    ("hang 65x65", "&scene scene='hang' /\n&lattice nx=65 ny=65 /\n&time t_end=0.02 dt=1e-3 /", 4225),
]


def event(text, name):
    m = re.search(rf"^{name}\s+(\d+)\s+\S+\s+([0-9.e+-]+)", text, re.M)
    return (int(m.group(1)), float(m.group(2))) if m else (0, float("nan"))


def measure(exe, mpiexec, nml_text, nranks, extra):
    with tempfile.TemporaryDirectory() as d:
        nml = Path(d) / "b.nml"
        nml.write_text(nml_text + "\n&output output_interval=1000 output_file='b.h5' /\n")
        t0 = time.perf_counter()
        p = subprocess.run([mpiexec, "-n", str(nranks), "--oversubscribe", exe, str(nml), "-log_view", *extra],
                           cwd=d, capture_output=True, text=True, timeout=1800)
        wall = time.perf_counter() - t0
    if p.returncode != 0:
        return None
    steps, t_step = event(p.stdout, "TSStep")
    _, t_jac = event(p.stdout, "SNESJacobianEval")
    _, t_fun = event(p.stdout, "SNESFunctionEval")
    _, t_pc = event(p.stdout, "PCSetUp")
    _, t_ksp = event(p.stdout, "KSPSolve")
    return dict(steps=steps, t_step=t_step, wall=wall, jac=t_jac, fun=t_fun, pc=t_pc, ksp=t_ksp)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--output", help="write the markdown table here")
    ap.add_argument("extra", nargs="*", help="PETSc options passed to every run (after --)")
    a = ap.parse_args(argv)
    if not Path(a.exe).exists():
        print(f"error: {a.exe} not found (bash tools/build.sh)", file=sys.stderr)
        return 1
    rows = ["| case | ranks | steps | TSStep [s] | node-steps/s | Jacobian | residual | PC set-up | KSP |",
            "|---|---|---|---|---|---|---|---|---|"]
    for label, text, nodes in CASES:
        for n in a.ranks:
            r = measure(a.exe, a.mpiexec, text, n, a.extra)
            if r is None:
                rows.append(f"| {label} | {n} | failed | | | | | | |")
                continue
            pct = lambda x: f"{100 * x / r['t_step']:.0f} %"  # noqa: E731
            rows.append(f"| {label} | {n} | {r['steps']} | {r['t_step']:.2f} | "
                        f"{nodes * r['steps'] / r['t_step']:.3g} | {pct(r['jac'])} | {pct(r['fun'])} | "
                        f"{pct(r['pc'])} | {pct(r['ksp'])} |")
            print(rows[-1], file=sys.stderr)
    table = "\n".join(rows) + "\n"
    if a.output:
        Path(a.output).write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
