#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The self-contact benchmark (issue 49 item 5): a self-contact step against
the free step.

The scene of tests/python/test_self_contact.py at N x N nodes: a 0.5 m cloth
dropped flat onto a thin capsule (radius 2 cm) near its middle; its halves
swing under the capsule and meet below it at about t = 0.29 s. Run to
t = 0.34 s with `&contact`'s self_contact on and off (off: the halves pass
through each other; the same scene and obstacle otherwise), the two
alternated, in the modes of bench/solver.py:
  bw      Baraff-Witkin: one linearised solve a step (-snes_type ksponly,
          -reduced_ksp_rtol 1e-3), dt = 1/600 s;
  newton  full Newton at the defaults, dt = 1 ms.
contact_dhat = 1 mm (--dhat; self-contact needs it below 0.7 of the
spacing: up to 257 x 257; at 1025 x 1025, 0.49 mm, 0.2 mm is given) and
contact_stiffness = 1 N/m (--stiffness; at most 100 m/dt^2 of the lightest
node: 0.4 N/m at 1025 x 1025 in bw).
Per run: the wall time a step over the steps from t = 0.28 s to the end
(the halves meeting: self-contact pairs active), from the progress lines
(`wall_s` at each output step, every 0.02 s), as node-steps/s and as
microseconds per node and step (one core a rank: per vertex per core),
the whole run's TSStep time (-log_view), Newton and inner iterations a
step over the whole run, and the most pairs in the barrier at an output step
(/self_contact/active), the most candidate pairs in the Verlet list at an
output step (/self_contact/candidates) and the broad-phase searches a step
(/self_contact/searches over the whole run). The ratio is the self-contact run's time a step in the window
to the free run's (issue 49's target: at most 3 in bw mode). Each pair is
repeated --repeat times, the fastest of each kept. The table goes to
stdout and, with --output, to a file; --log writes every run's numbers.

    source tools/env.sh
    python3 bench/self_contact.py --sizes 129 257 --output table.md
    python3 bench/self_contact.py --sizes 1025 --ranks 2 --modes bw --dhat 2e-4 --stiffness 0.4
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from solver import MODES, event  # noqa: E402  (the modes and -log_view parsing of the main benchmark)

T_END = 0.34          # [s] the halves meet at about 0.29 s
T_WINDOW = 0.28       # [s] the steps timed start here
OGC_US = 0.21 / 246000 * 1e6   # OGC's published step: 246 000 vertices in 0.21 s [us a vertex]
# [s] the time step of each mode, as docs/performance.md's tables of this
# benchmark were measured; the options are bench/solver.py's MODES, whose
# newton runs at issue 46's 1/600 s
DT = {"bw": 1.0 / 600.0, "newton": 1.0e-3}


def scene_text(n, mode, on, dhat=1.0e-3, kappa=1.0, t_end=T_END, step="accd"):
    """The scene's namelist at n x n nodes for `mode`, self-contact on or off (step: its
    self_step, the step guarantee)."""
    dt = DT[mode]
    return f"""&scene scene='flat' units='SI' gravity=0.0,0.0,-9.81 /
&lattice nx={n} ny={n} lx=0.5 ly=0.5 total_mass=0.05 mass_distribution='area' /
&material e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='energy' k_b=1.0e-3 eta_b=1.0e-5 /
&contact n_obstacles=1 obstacle_shape(1)='capsule' obstacle_point(:,1)=0.26,-0.1,-0.0255
  obstacle_end(:,1)=0.26,0.6,-0.0255 obstacle_radius(1)=0.02 contact_dhat={dhat!r} contact_stiffness={kappa!r}
  self_contact={'.true.' if on else '.false.'}{f" self_step='{step}'" if on and step != "accd" else ""} /
&time t_end={t_end!r} dt={dt!r} /
&output output_interval={min(0.02, t_end / 2)!r} write_velocity=.false. output_file='b.h5' /
"""


def run(exe, mpiexec, n, nranks, mode, on, timeout, dhat, kappa, t_end=T_END, step="accd"):
    """One run: a dict of its numbers, or ok=False with why."""
    _, opts = MODES[mode]
    guard = {}
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "b.nml").write_text(scene_text(n, mode, on, dhat, kappa, t_end, step))
        cmd = [mpiexec, "-n", str(nranks), "--oversubscribe", exe, "b.nml", "-log_view", *opts]
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return dict(ok=False, why=f"no result in {timeout:g} s")
        wall = time.perf_counter() - t0
        active = candidates = searches = None
        if p.returncode == 0 and on:
            with h5py.File(Path(d) / "b.h5", "r") as f:
                active = int(f["self_contact/active"][:].max())
                candidates = int(f["self_contact/candidates"][:].max())
                searches = int(f["self_contact/searches"][-1])
                # the step guarantee's counts (bench/self_step.py)
                guard = dict(limited=int(f["self_contact/limited"][-1]), min_gap=float(f["self_contact/min_gap"][:].min()),
                             clamped=int(f["self_contact/clamped"][-1]) if "self_contact/clamped" in f else 0,
                             rejected=int(f["diagnostics/rejected_steps"][-1]))
    out = p.stdout
    if p.returncode != 0:
        last = (p.stdout + p.stderr).strip().splitlines()
        why = next((ln for ln in reversed(last) if "nuno: error" in ln or "failed" in ln),
                   last[-1] if last else "?")
        return dict(ok=False, why=why.strip()[:160])
    prog = [(float(t), int(s), float(w)) for t, s, w in re.findall(
        r"^t = (\S+)\s+steps\s+(\d+).*?wall_s\s+(\S+)", out, re.M)]
    t1 = min(prog, key=lambda r: abs(r[0] - (T_WINDOW if t_end > T_WINDOW else t_end / 2)))
    t2 = prog[-1]
    per_step = (t2[2] - t1[2]) / max(t2[1] - t1[1], 1)
    _, t_step, _ = event(out, "TSStep")
    steps, newton, linear = map(int, re.findall(r"steps\s+(\d+)\s+rejected\s+\d+\s+newton\s+(\d+)\s+linear\s+(\d+)",
                                                out)[-1])
    return dict(ok=True, steps=steps, window=t2[1] - t1[1], per_step=per_step, rate=n * n / per_step,
                us=per_step * nranks / (n * n) * 1e6, t_step=t_step, newton=newton / max(steps, 1),
                inner=linear / max(steps, 1), active=active, candidates=candidates,
                searches=None if searches is None else searches / max(steps, 1), wall=wall,
                newton_window=newton_in_window(out, t1[1]), **guard)


def newton_in_window(out, step0):
    """Newton iterations from step step0 to the end, from the progress lines."""
    rows = [(int(s), int(k)) for s, k in re.findall(r"^t = \S+\s+steps\s+(\d+)\s+rejected\s+\d+\s+newton\s+(\d+)",
                                                     out, re.M)]
    at = [k for s, k in rows if s == step0]
    return rows[-1][1] - at[0] if at else None


def best(tries):
    good = [t for t in tries if t["ok"]]
    return min(good, key=lambda t: t["per_step"]) if good else tries[0]


HEAD = ("| mode | N | ranks | dhat [mm] | steps timed | node-steps/s, self / free | time ratio | us a vertex a core, self "
        f"(OGC {OGC_US:.2f} on their CPU) | whole run TSStep ratio | Newton / step, self / free "
        "| inner / step, self / free | most pairs active | most candidates | searches / step |")


def row(mode, n, p, dhat, c, f):
    if not (c["ok"] and f["ok"]):
        fails = "; ".join(f"{w}: {r['why']}" for w, r in (("self", c), ("free", f)) if not r["ok"])
        return f"| {mode} | {n} | {p} | {dhat * 1e3:g} | - | - | - | - | - | - | - | - | - | {fails}"
    return (f"| {mode} | {n} | {p} | {dhat * 1e3:g} | {c['window']} | {c['rate']:.3g} / {f['rate']:.3g} "
            f"| {c['per_step'] / f['per_step']:.2f} | {c['us']:.2f} | {c['t_step'] / f['t_step']:.2f} "
            f"| {c['newton']:.2f} / {f['newton']:.2f} | {c['inner']:.1f} / {f['inner']:.1f} | {c['active']} "
            f"| {c['candidates']} | {c['searches']:.2f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[129, 257],
                    help="N of the N x N lattice (1025: the large case, with --ranks 2)")
    ap.add_argument("--ranks", type=int, default=1, help="MPI ranks (default 1)")
    ap.add_argument("--modes", nargs="+", default=["bw", "newton"], choices=("bw", "newton"))
    ap.add_argument("--repeat", type=int, default=1, help="self/free pairs of each case, the fastest kept")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds a run")
    ap.add_argument("--dhat", type=float, default=1.0e-3,
                    help="contact_dhat [m] (default 1 mm; below 0.7 of the spacing: 2e-4 at 1025)")
    ap.add_argument("--stiffness", type=float, default=1.0,
                    help="contact_stiffness [N/m] (default 1; at most 100 m/dt^2: 0.4 at 1025 in bw)")
    ap.add_argument("--t-end", type=float, default=T_END,
                    help="end of the runs [s] (default 0.34; shorter: the steps timed are the second half, "
                         "before the halves meet)")
    ap.add_argument("--output", help="also write the markdown table to this file")
    ap.add_argument("--log", help="also write every run's numbers (JSON lines) to this file")
    a = ap.parse_args(argv)
    a.exe = str(Path(a.exe).resolve())  # the runs start in their own folders
    if not Path(a.exe).is_file():
        ap.error(f"--exe {a.exe}: no such file (bash tools/build.sh first)")
    lines = [HEAD, "|" + "---|" * 14]
    print(lines[0] + "\n" + lines[1], flush=True)
    log = open(a.log, "a") if a.log else None
    for mode in a.modes:
        for n in a.sizes:
            pairs = []
            for _ in range(a.repeat):
                pairs.append((run(a.exe, a.mpiexec, n, a.ranks, mode, True, a.timeout, a.dhat, a.stiffness, a.t_end),
                              run(a.exe, a.mpiexec, n, a.ranks, mode, False, a.timeout, a.dhat, a.stiffness, a.t_end)))
                if log:
                    for on, r in zip((True, False), pairs[-1]):
                        log.write(json.dumps(dict(mode=mode, n=n, ranks=a.ranks, dhat=a.dhat, kappa=a.stiffness, t_end=a.t_end, self_contact=on, **r))
                                  + "\n")
                        log.flush()
            c, f = best([p[0] for p in pairs]), best([p[1] for p in pairs])
            lines.append(row(mode, n, a.ranks, a.dhat, c, f))
            print(lines[-1], flush=True)
    if a.output:
        Path(a.output).write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
