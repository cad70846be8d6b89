#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Self-contact's two step guarantees in whole steps (issue 49 item 3;
docs/self-contact.md, "The step guarantee: two flavours"): `&contact`'s
self_step = 'accd' (every update scaled by the global ACCD alpha) against
'ogc' (each node's update shortened to its own bound), alternated, on the
scene of bench/self_contact.py (the guarantee test's cloth dropped onto a
capsule, its halves meeting below it from about t = 0.28 s) in its modes
(bw: one linearised solve a step, dt = 1/600 s; newton: dt = 1 ms).
Per run: whether it completes, steps, rejected steps, Newton iterations
over the whole run and from t = 0.28 s (where the halves meet), updates and
predictors shortened (/self_contact/limited), node updates clamped to
their bounds (/self_contact/clamped, 'ogc' only), the smallest gap of an
accepted state at an output step, and the wall time a step from t = 0.28 s
(the fastest of --repeat alternated pairs; only indicative on a loaded
machine: state the load).

    source tools/env.sh
    python3 bench/self_step.py --sizes 65 129 --modes bw newton --dhat 1e-3
"""
import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from self_contact import best, run  # noqa: E402  (the benchmark's scene, run and choice of the fastest)

HEAD = ("| mode | N | dhat [mm] | self_step | steps (rejected) | Newton, whole run / from 0.28 s | limited "
        "| nodes clamped | smallest gap [mm] | s a step from 0.28 s |")


def row(mode, n, dhat, step, r):
    if not r["ok"]:
        return f"| {mode} | {n} | {dhat * 1e3:g} | {step} | fails: {r['why']} | | | | | |"
    newton = round(r["newton"] * r["steps"])
    return (f"| {mode} | {n} | {dhat * 1e3:g} | {step} | {r['steps']} ({r['rejected']}) | {newton} / "
            f"{r['newton_window']} | {r['limited']} | {r['clamped'] if step == 'ogc' else '-'} "
            f"| {r['min_gap'] * 1e3:.3g} | {r['per_step']:.3g} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[65, 129], help="N of the N x N lattice")
    ap.add_argument("--ranks", type=int, default=1, help="MPI ranks (default 1)")
    ap.add_argument("--modes", nargs="+", default=["bw", "newton"], choices=("bw", "newton"))
    ap.add_argument("--dhat", type=float, default=1.0e-3, help="contact_dhat [m] (default 1 mm)")
    ap.add_argument("--stiffness", type=float, default=1.0, help="contact_stiffness [N/m] (default 1)")
    ap.add_argument("--repeat", type=int, default=1, help="alternated accd/ogc pairs, the fastest of each kept")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds a run")
    a = ap.parse_args(argv)
    a.exe = str(Path(a.exe).resolve())
    if not Path(a.exe).is_file():
        ap.error(f"--exe {a.exe}: no such file (bash tools/build.sh first)")
    print(HEAD + "\n" + "|" + "---|" * 10, flush=True)
    for mode in a.modes:
        for n in a.sizes:
            tries = {"accd": [], "ogc": []}
            for _ in range(a.repeat):
                for step in tries:
                    tries[step].append(run(a.exe, a.mpiexec, n, a.ranks, mode, True, a.timeout, a.dhat, a.stiffness,
                                           step=step))
            for step, rs in tries.items():
                print(row(mode, n, a.dhat, step, best(rs)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
