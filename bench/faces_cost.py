#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""What the cloth's faces (`&contact contact_faces = .true.`) cost on the
contact scenes of input/: each scene with obstacles run as shipped with
and without the faces, on each rank count, and a markdown table of the
counts and the ratios on/off (docs/contact.md, "Why it is still off by
default").

    python3 bench/faces_cost.py --out /tmp/fcost --table fcost.md
    python3 bench/faces_cost.py --scenes drape_sphere gripper --ranks 2 \
        --t-end gripper=1.0

Per run: whether it completed, its steps and rejected steps (retried
after a failed Newton solve) from its last log line; Newton and inner
(linear) iterations from the output file's /diagnostics at its last
output step (where a run failed, the ratio on/off takes the other run's
counts at the same output time); Jacobian assemblies, the count of
PETSc's SNESJacobianEval event (-log_view into a file); the smallest
node gap over every accepted state (/contact min_gap_run) and, with the
faces, the smallest triangle or edge gap over the output steps
(/contact_faces min_gap) [the scene's length unit]; the wall time the
run prints [s] (meaningful only on an idle machine: the counts are the
measurement). The modified namelists (contact_faces, output_file and a
t_end given by --t-end) and each run's log are kept in --out; input/ is
not touched. Runs one after the other; exit 1 where a run failed (its
row says where).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def contact_scenes():
    """The scenes of input/ with obstacles (a key n_obstacles)."""
    return sorted(p.stem for p in (ROOT / "input").glob("*.nml")
                  if re.search(r"^\s*n_obstacles\s*=", p.read_text(), re.M))


def namelist(scene, faces, t_end, h5):
    """The scene's namelist with contact_faces, its output_file and t_end."""
    text = (ROOT / "input" / f"{scene}.nml").read_text()
    text = re.sub(r"^\s*contact_faces\s*=.*\n", "", text, flags=re.M | re.I)
    flag = ".true." if faces else ".false."
    text, n = re.subn(r"^(\s*n_obstacles\s*=.*)$", rf"\1\n  contact_faces = {flag}", text,
                      count=1, flags=re.M)
    text = re.sub(r"^(\s*output_file\s*=\s*)'[^']*'", rf"\1'{h5}'", text, flags=re.M)
    if t_end is not None:
        text, m = re.subn(r"^(\s*t_end\s*=\s*)[^!\n]*", rf"\g<1>{t_end} ", text, count=1, flags=re.M)
        if m != 1:
            sys.exit(f"faces_cost: {scene}: no t_end to change")
    if n != 1:
        sys.exit(f"faces_cost: {scene}: no n_obstacles")
    return text


def run(nuno, scene, ranks, faces, t_end, out):
    tag = f"{scene}-n{ranks}-{'on' if faces else 'off'}"
    (out / f"{tag}.nml").write_text(namelist(scene, faces, t_end, f"{tag}.h5"))
    for f in (out / f"{tag}.h5", out / f"{tag}.logview"):
        f.unlink(missing_ok=True)
    cmd = ["mpirun", "-n", str(ranks), str(nuno), f"{tag}.nml", "-log_view", f":{tag}.logview"]
    with open(out / f"{tag}.log", "w") as log:
        rc = subprocess.call(cmd, cwd=out, stdout=log, stderr=subprocess.STDOUT)
    text = (out / f"{tag}.log").read_text()
    # The run's last line: how far it got and its step counts, also where it failed.
    end = re.search(r"(complete|failed) at t =\s*(\S+): (\d+) steps, (\d+) rejected \((\d+) retried", text)
    wall = re.search(r"wall time\s+(\S+) s", text)
    row = {"scene": scene, "ranks": ranks, "faces": faces, "rc": rc,
           "end": end.group(1) if end else "no end line", "t_run": float(end.group(2)) if end else float("nan"),
           "steps": int(end.group(3)) if end else -1, "rejected": int(end.group(4)) if end else -1,
           "retried": int(end.group(5)) if end else -1,
           "wall": float(wall.group(1)) if wall else float("nan")}
    lv = out / f"{tag}.logview"
    jac = re.search(r"^SNESJacobianEval\s+(\d+)", lv.read_text(), re.M) if lv.exists() else None
    row["jac"] = int(jac.group(1)) if jac else -1
    with h5py.File(out / f"{tag}.h5", "r") as f:
        d = f["diagnostics"]
        # Iterations at every output step, so that a failed run is compared
        # with the other at its last output time.
        row["times"] = f["time"][()]
        row["newtons"] = d["newton_iterations"][()].astype(int)
        row["inners"] = d["linear_iterations"][()].astype(int)
        row["t"] = float(row["times"][-1])
        row["newton"], row["inner"] = int(row["newtons"][-1]), int(row["inners"][-1])
        row["gap"] = float(f["contact/min_gap_run"][-1])
        row["fgap"] = float(np.min(f["contact_faces/min_gap"][()])) if faces and "contact_faces" in f else None
    return row


def ratio(a, b):
    return f"{a / b:.2f}" if b else ("1" if a == b else "-")


def at_time(row, t):
    """(Newton, inner) of a run at its output time nearest t."""
    k = int(np.argmin(np.abs(row["times"] - t)))
    return int(row["newtons"][k]), int(row["inners"][k]), float(row["times"][k])


def table(rows, load):
    lines = ["| scene | ranks | faces | end | steps | rejected (retried) | t [s] | Newton | inner | Jacobians "
             "| min node gap | min face gap | wall [s] | Newton on/off | inner on/off |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    off = {(r["scene"], r["ranks"]): r for r in rows if not r["faces"]}
    for r in rows:
        o = off.get((r["scene"], r["ranks"])) if r["faces"] else None
        rn = ri = ""
        if o:
            # The ratios at the on run's last output time (where it failed: the
            # off run's counts up to the same time).
            on_, oi, ot = at_time(o, r["t"])
            rn, ri = ratio(r["newton"], on_), ratio(r["inner"], oi)
            if abs(ot - o["t"]) > 1e-12:
                rn, ri = f"{rn} (to t = {ot:g})", f"{ri} (to t = {ot:g})"
        fg = f"{r['fgap']:.3g}" if r["fgap"] is not None else "-"
        end = "complete" if r["end"] == "complete" and r["rc"] == 0 else f"{r['end']} at {r['t_run']:.4g} s (exit {r['rc']})"
        lines.append(
            f"| {r['scene']} | {r['ranks']} | {'on' if r['faces'] else 'off'} | {end} | {r['steps']} "
            f"| {r['rejected']} ({r['retried']}) | {r['t']:g} | {r['newton']} | {r['inner']} | {r['jac']} "
            f"| {r['gap']:.3g} | {fg} | {r['wall']:.1f} | {rn} | {ri} |")
    lines.append("")
    lines.append("steps, rejected (retried): the whole run's, from its last log line; Newton, inner: to the "
                 "last output time t, from /diagnostics; gaps [length unit of the scene]: nodes over every "
                 "accepted state, faces over the output steps (contact_dhat where none nearer).")
    lines.append("")
    lines.append(f"Load (`uptime`) at the start: {load}.")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nuno", default=str(ROOT / "build" / "nuno"), help="the build to run (default build/nuno)")
    ap.add_argument("--scenes", nargs="+", default=None,
                    help="scenes of input/ (default: every one with n_obstacles)")
    ap.add_argument("--ranks", nargs="+", type=int, default=[1, 2], help="rank counts (default 1 2)")
    ap.add_argument("--t-end", nargs="*", default=[], metavar="SCENE=T",
                    help="a shorter t_end [s] for a scene (default: its own)")
    ap.add_argument("--out", default="faces_cost_runs", help="folder for namelists, logs, output files")
    ap.add_argument("--table", default=None, help="write the markdown table here too (default: print only)")
    a = ap.parse_args()
    t_end = dict(s.split("=", 1) for s in a.t_end)
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    load = load[load.find("load"):] if "load" in load else load
    rows = []
    for scene in a.scenes or contact_scenes():
        for ranks in a.ranks:
            for faces in (False, True):
                r = run(a.nuno, scene, ranks, faces, t_end.get(scene), out)
                print(f"{scene} n={ranks} faces={'on' if faces else 'off'}: {r['end']} at t = {r['t_run']:g}, steps {r['steps']}, rejected "
                      f"{r['rejected']}, Newton {r['newton']}, inner {r['inner']}, Jacobians {r['jac']}, "
                      f"wall {r['wall']:.1f} s, exit {r['rc']}", flush=True)
                rows.append(r)
    md = table(rows, load)
    print(md)
    if a.table:
        Path(a.table).write_text(md)
    return 1 if any(r["rc"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
