# SPDX-License-Identifier: BSD-2-Clause
"""The default integrator of adaptive runs (issue 10 item 6): which method
wins the work-precision diagram at moderate tolerance when the user asks
only for adaptive steps.

    source tools/env.sh && python3 bench/adaptive_default.py     # about 7 min here
    python3 bench/adaptive_default.py --replot                     # figure and doc from bench/results

Each candidate runs as a user who passes only `-ts_adapt_type basic
[-ts_rtol R]` would get it: `-ts_type X -ts_adapt_type basic -ts_rtol R`
with everything else at its default (the 2-norm of the error control, the
per-field tolerances of input/README.md), at R = 1e-3, 1e-4 (PETSc's
default) and 1e-5, on the scenes of bench/workprecision.py against its
references. The final position error over the cloth size against the run
time (/run wall_time, one rank; the least of three runs on the 11 x 11
scenes, whose runs take a fraction of a second). At each error from 1e-3
to 1e-5 the fastest method is the one whose lower envelope reaches that
error in the least time (log-log interpolation, never extrapolated).

Writes bench/results/adaptive_default.json, docs/figures/adaptive_default.png
and its part of docs/workprecision.md (between its markers).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

import workprecision as wp  # noqa: E402

ARK5 = "-ts_type arkimex -ts_arkimex_type 5 -ts_arkimex_fully_implicit"
CANDIDATES = {
    "rosw (ra34pw2)": "-ts_type rosw",
    "bdf (order 2, PETSc's default)": "-ts_type bdf",
    "bdf3": "-ts_type bdf -ts_bdf_order 3",
    "bdf4": "-ts_type bdf -ts_bdf_order 4",
    "bdf5": "-ts_type bdf -ts_bdf_order 5",
    "arkimex 5": ARK5,
}
RTOLS = (1e-3, 1e-4, 1e-5)
LEVELS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5)   # the moderate errors at which the winner is read


def winners(rows, key):
    """At each error level: (fastest method, its time, runner-up, its time)."""
    out = []
    fronts = {m: wp.pareto([(r["error"], r["time_s"]) for r in rows if r["scene"] == key and r["method"] == m])
              for m in CANDIDATES}
    for e in LEVELS:
        times = sorted((t, m) for m in CANDIDATES if (t := wp.time_at(fronts[m], e)) is not None)
        if not times:
            continue
        best = {"error": e, "method": times[0][1], "time_s": times[0][0]}
        if len(times) > 1:
            best.update(second=times[1][1], second_s=times[1][0])
        out.append(best)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    p.add_argument("--results", default=str(ROOT / "bench" / "results"))
    p.add_argument("--figure", default=str(ROOT / "docs" / "figures" / "adaptive_default.png"))
    p.add_argument("--doc", default=str(ROOT / "docs" / "workprecision.md"))
    p.add_argument("--replot", action="store_true", help="only the figure and the doc, from bench/results")
    args = p.parse_args(argv)
    res_path = Path(args.results) / "adaptive_default.json"
    if args.replot:
        summary = json.loads(res_path.read_text())
    else:
        summary = measure(args)
        res_path.parent.mkdir(parents=True, exist_ok=True)
        res_path.write_text(json.dumps(summary, indent=1, default=float) + "\n")
    wp.figure(summary["rows"], summary, Path(args.figure))
    write_doc(summary, Path(args.doc))
    return 0


def measure(args) -> dict:
    start = time.perf_counter()
    log = sys.stdout
    rows, scenes = [], {}
    summary = {"machine": wp.machine(), "command": "python3 bench/adaptive_default.py",
               "git": subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                                     capture_output=True, text=True).stdout.strip()}
    with tempfile.TemporaryDirectory() as tmp:
        nuno = wp.Nuno(Path(args.exe), Path(tmp), log)
        for sc in wp.plan(False):
            key = sc["key"]
            print(f"{key}:", file=log, flush=True)
            ref_opts, ref_r = sc["ref"]
            ref = nuno.run(sc, f"{ref_opts} -ts_rtol {ref_r:g}")
            if "x" not in ref:
                raise SystemExit(f"{key}: the reference failed: {ref.get('error_message')}")
            cfg = wp.scipy_cloth.read_config(ROOT / "input" / sc["input"], sc["sets"])
            size = max(float(cfg["lx"]), float(cfg["ly"]))
            repeats = 3 if sc["input"] != "hang.nml" else 1
            for method, opts in CANDIDATES.items():
                for rt in RTOLS:
                    best = None
                    for _ in range(repeats):
                        r = nuno.run(sc, f"{opts} -ts_adapt_type basic -ts_rtol {rt:g}")
                        if best is None or ("time_s" in r and r["time_s"] < best.get("time_s", np.inf)):
                            best = r
                    e = float(np.abs(best["x"] - ref["x"]).max() / size) if "x" in best else float("nan")
                    rows.append({"scene": key, "program": "nuno", "method": method, "parameter": rt,
                                 "error": e, "time_s": best.get("time_s", float("nan")), "cpu_s": best["cpu_s"],
                                 "steps": best.get("steps", ""), "options": f"{opts} -ts_adapt_type basic -ts_rtol {rt:g}",
                                 "note": best.get("error_message", "")})
            scenes[key] = {"t_end": sc["t_end"], "size": size, "reference": f"{ref_opts} -ts_rtol {ref_r:g}"}
            scenes[key]["winners"] = winners(rows, key)
    summary.update(rows=rows, scenes=scenes, elapsed_s=time.perf_counter() - start)
    return summary


BEGIN, END = "<!-- default results begin (bench/adaptive_default.py) -->", "<!-- default results end -->"


def write_doc(summary, path: Path):
    rows = summary["rows"]
    out = ["", f"Command: `{summary['command']}` (commit {summary['git']}), {summary['elapsed_s'] / 60:.1f} min.",
           "", f"Machine: {summary['machine']}.", "", "![adaptive default](figures/adaptive_default.png)", "",
           "The fastest method at each error (its lower envelope reaches that error first), and the next one:", "",
           "| scene | error | fastest | time [s] | next | time [s] |", "|---|---|---|---|---|---|"]
    for key, info in summary["scenes"].items():
        for w in info["winners"]:
            nxt = (f"{w['second']} | {w['second_s']:.3g}") if "second" in w else "- | -"
            out.append(f"| {key} | {w['error']:.0e} | {w['method']} | {w['time_s']:.3g} | {nxt} |")
    out += ["", "Every run (`-ts_type X -ts_adapt_type basic -ts_rtol R`, nothing else):", "",
            "| scene | method | R | error / cloth size | error / R | time [s] | CPU [s] | steps |",
            "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        e = f"{r['error']:.2e} | {r['error'] / r['parameter']:.2g}" if np.isfinite(r["error"]) else f"failed: {r['note']} | -"
        out.append(f"| {r['scene']} | {r['method']} | {r['parameter']:g} | {e} | {r['time_s']:.3g} | "
                   f"{r['cpu_s']:.3g} | {r['steps']} |")
    wp.replace_results(path, out, BEGIN, END, "# Work-precision")


if __name__ == "__main__":
    raise SystemExit(main())
