# SPDX-License-Identifier: BSD-2-Clause
"""Work-precision benchmark of nuno against a SciPy baseline (issue 10 item 4).

    source tools/env.sh && python3 bench/workprecision.py            # everything (about 25 min here)
    python3 bench/workprecision.py --quick                              # a smoke run (small, seconds)

For each scene (hang 21 x 21 and 65 x 65, bend_release_energy,
wave_point_energy) it runs nuno on one rank with many integrators, fixed
steps and adaptive, and the SciPy implementation of the same model
(bench/scipy_cloth.py, solve_ivp BDF and Radau with the exact sparse
Jacobian), and measures the final-time position error: the largest node
distance from a reference, over the cloth size max(lx, ly). The reference
is nuno's highest-order BDF at a tight -ts_rtol, checked by Richardson
against a second run at 10 times that tolerance. Also: the agreement of
SciPy (Radau, tight) with nuno's reference, and the check of the
documented accurate setting (docs/workprecision.md: -ts_rtol R gives an
error of at most 10 R).

Output: nuno writes an output step every --output-interval (0.02 s by
default, as the scenes' users do; hang 65 x 65: every 0.02 s of its 0.2 s),
so that the errors are those a user who writes output gets (output steps
no longer change the solution, issue 48; before, every output step
restarted bdf and the benchmark wrote only the last one).

Time: nuno's is the /run wall_time attribute of the run (its time loop on
one rank, output included, start-up excluded); its CPU time (getrusage of
the process, start-up included) is in the CSV too. SciPy's is
time.process_time() around solve_ivp (model set-up excluded).

Writes bench/results/workprecision.csv and .json, docs/figures/
workprecision.png, and the results part of docs/workprecision.md (between
its markers; the text around them is kept).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from postprocess.reader import read_run  # noqa: E402
import scipy_cloth  # noqa: E402

# The documented accurate setting (docs/workprecision.md, "Tolerances").
DOCUMENTED = ("-ts_type arkimex -ts_arkimex_type 5 -ts_arkimex_fully_implicit "
              "-ts_adapt_type basic -ts_adapt_wnormtype infinity")
INF = "-ts_adapt_wnormtype infinity"
BW = "-ts_type beuler -snes_type ksponly -reduced_ksp_rtol 1e-3"


def adaptive(ts, rtols):
    return [(f"-ts_type {ts} -ts_adapt_type basic {INF} -ts_rtol {r:g}", r) for r in rtols]


def bdf(order, rtols):
    return [(f"-ts_type bdf -ts_bdf_order {order} -ts_adapt_type basic {INF} -ts_rtol {r:g}", r)
            for r in rtols]


def fixed(ts, dts):
    return [(f"{ts} -ts_dt {dt:g}", dt) for dt in dts]


def plan(quick: bool) -> list[dict]:
    """Scenes, their runs and their references (sized for ~25 min on 2 shared cores)."""
    if quick:
        return [dict(
            key="bend_release_energy", input="bend_release_energy.nml", sets={}, t_end=0.2,
            ref=("-ts_type bdf -ts_bdf_order 6 -ts_adapt_type basic " + INF, 1e-11),
            nuno={"beuler fixed": fixed("-ts_type beuler", [1e-3]),
                  "bdf5 adaptive": bdf(5, [1e-4]),
                  "arkimex 5 adaptive (documented)": [(f"{DOCUMENTED} -ts_rtol 1e-4", 1e-4)]},
            scipy={"BDF": [1e-4]}, crosscheck=("Radau", 1e-8), documented=[1e-4])]
    small = dict(
        nuno={
            "beuler fixed": fixed("-ts_type beuler", [1e-2, 1e-3, 1e-4]),
            "Baraff-Witkin (beuler, one linear solve a step)": fixed(BW, [1e-2, 1e-3, 1e-4]),
            "cn fixed": fixed("-ts_type cn", [1e-2, 1e-3]),
            "bdf2 fixed": fixed("-ts_type bdf -ts_bdf_order 2", [1e-2, 1e-3]),
            "bdf2 adaptive": bdf(2, [1e-3, 1e-5, 1e-7]),
            "bdf3 adaptive": bdf(3, [1e-3, 1e-5, 1e-7]),
            "bdf4 adaptive": bdf(4, [1e-3, 1e-5, 1e-7]),
            "bdf5 adaptive": bdf(5, [1e-3, 1e-5, 1e-7, 1e-8]),
            "cn adaptive": adaptive("cn", [1e-3, 1e-5]),
            "arkimex 3 adaptive": [(f"-ts_type arkimex -ts_arkimex_type 3 -ts_arkimex_fully_implicit "
                                    f"-ts_adapt_type basic {INF} -ts_rtol {r:g}", r) for r in (1e-3, 1e-5, 1e-7)],
            "arkimex 5 adaptive (documented)": [(f"{DOCUMENTED} -ts_rtol {r:g}", r)
                                                for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)],
            "rosw ra34pw2 adaptive": [(f"-ts_type rosw -ts_rosw_type ra34pw2 -ts_adapt_type basic {INF} "
                                       f"-ts_rtol {r:g}", r) for r in (1e-3, 1e-5, 1e-7)],
        },
        scipy={"BDF": [1e-3, 1e-5, 1e-7], "Radau": [1e-3, 1e-5, 1e-7]},
        crosscheck=("Radau", 1e-10), documented=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
    ref_small = ("-ts_type bdf -ts_bdf_order 6 -ts_adapt_type basic " + INF, 1e-12)
    return [
        dict(key="bend_release_energy", input="bend_release_energy.nml", sets={}, t_end=1.0,
             ref=ref_small, **small),
        dict(key="wave_point_energy", input="wave_point_energy.nml", sets={}, t_end=1.0,
             ref=ref_small, **small),
        dict(key="hang 21 x 21", input="hang.nml", sets={}, t_end=1.0,
             ref=("-ts_type bdf -ts_bdf_order 5 -ts_adapt_type basic " + INF, 1e-11),
             nuno={
                 "beuler fixed": fixed("-ts_type beuler", [1e-2, 1e-3]),
                 "Baraff-Witkin (beuler, one linear solve a step)": fixed(BW, [1e-2, 1e-3]),
                 "cn fixed": fixed("-ts_type cn", [1e-2, 1e-3]),
                 "bdf2 adaptive": bdf(2, [1e-3, 1e-5]),
                 "bdf3 adaptive": bdf(3, [1e-3, 1e-5, 1e-7]),
                 "bdf4 adaptive": bdf(4, [1e-3, 1e-6]),
                 "bdf5 adaptive": bdf(5, [1e-3, 1e-6, 1e-8]),
                 "arkimex 5 adaptive (documented)": [(f"{DOCUMENTED} -ts_rtol {r:g}", r)
                                                     for r in (1e-3, 1e-5, 1e-8)],
                 "rosw ra34pw2 adaptive": [(f"-ts_type rosw -ts_rosw_type ra34pw2 -ts_adapt_type basic {INF} "
                                            f"-ts_rtol {r:g}", r) for r in (1e-3, 1e-5)],
             },
             scipy={"BDF": [1e-3, 1e-5], "Radau": [1e-4]},
             crosscheck=None, documented=[1e-3, 1e-5, 1e-8]),
        # hang 65 x 65 to t = 0.2 s only, and few runs: one nuno step costs
        # ~0.3 s and one SciPy step ~2 s here (docs/workprecision.md, "What was cut").
        dict(key="hang 65 x 65", input="hang.nml", sets={"nx": 65, "ny": 65}, t_end=0.2,
             ref=("-ts_type bdf -ts_bdf_order 5 -ts_adapt_type basic " + INF, 1e-9),
             nuno={
                 "Baraff-Witkin (beuler, one linear solve a step)": fixed(BW, [1e-3]),
                 "bdf3 adaptive": bdf(3, [1e-3]),
                 "bdf5 adaptive": bdf(5, [1e-3, 1e-6]),
             },
             scipy={"BDF": [1e-3]},
             crosscheck=None, documented=[]),
    ]


class Nuno:
    def __init__(self, exe: Path, work: Path, log, output_interval: float):
        self.exe, self.work, self.log = exe, work, log
        self.output_interval = output_interval
        self.n = 0

    def run(self, scene: dict, opts: str, keep: bool = False) -> dict:
        """One run on one rank (no mpiexec: the process's CPU time is nuno's alone).
        keep: leave the output file in the work folder, its path in res["h5"]."""
        self.n += 1
        name = f"run{self.n}"
        t_end = scene["t_end"]
        every = min(self.output_interval, t_end) if self.output_interval > 0 else t_end
        sets = [f"output_file='{name}.h5'", f"output_interval={every!r}"]
        sets += [f"{k}={v}" for k, v in scene["sets"].items()]
        cmd = [str(self.exe), str(ROOT / "input" / scene["input"]), "-ts_max_time", repr(t_end),
               "-nuno_set", ",".join(sets), "-options_left", "no", *opts.split()]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        proc = subprocess.run(cmd, cwd=self.work, capture_output=True, text=True)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        print(f"  nuno {opts}: rc {proc.returncode}, {wall:.1f} s", file=self.log, flush=True)
        h5 = self.work / f"{name}.h5"
        res = {"opts": opts, "rc": proc.returncode, "cpu_s": cpu, "process_wall_s": wall}
        if proc.returncode != 0 or not h5.exists():
            res["error_message"] = (proc.stderr.strip().splitlines() or ["?"])[-1][:300]
            return res
        r = read_run(str(h5))
        res["x"] = np.asarray(r.position[-1])
        res["time_s"] = float(r.run_info["wall_time"])
        res["steps"] = int(np.asarray(r.diagnostics["steps"])[-1])
        r.close()
        if keep:
            res["h5"] = h5
        else:
            h5.unlink()
        return res


def pareto(points):
    """Lower-left envelope [(error, time)], sorted by error, of (error, time) points."""
    pts = sorted((e, t) for e, t in points if np.isfinite(e) and e > 0 and t > 0)
    front, best = [], np.inf
    for e, t in pts:                 # increasing error: keep a point if faster than all more accurate ones
        if t < best:
            front.append((e, t))
            best = t
    return front


def time_at(front, err):
    """Time to reach error err on a front (log-log interpolation), None outside its range."""
    if len(front) == 0:
        return None
    es = np.log([e for e, _ in front])
    ts = np.log([t for _, t in front])
    le = np.log(err)
    if le < es.min() - 1e-12:
        return None
    if le >= es.max():
        return float(np.exp(ts[np.argmax(es)]))   # the fastest point is already accurate enough
    # front time decreases with error: the time needed for err is the least over points with e <= err,
    # interpolated between the neighbours
    k = np.searchsorted(es, le)
    w = (le - es[k - 1]) / (es[k] - es[k - 1])
    return float(np.exp(ts[k - 1] + w * (ts[k] - ts[k - 1])))


def speedups(rows, key):
    """Speed-up at equal error: at the error of each SciPy run on SciPy's
    lower envelope (BDF or Radau, whichever is faster there), the time nuno's
    lower envelope needs for that error (log-log interpolation between its
    runs; above nuno's loosest run, its fastest run's time, an upper bound;
    below its most accurate run, none)."""
    nf = pareto([(r["error"], r["time_s"]) for r in rows if r["scene"] == key and r["program"] == "nuno"])
    sf = pareto([(r["error"], r["time_s"]) for r in rows if r["scene"] == key and r["program"] == "scipy"])
    out = []
    for e, ts in sf:
        tn = time_at(nf, e)
        if tn:
            method = next(r["method"] for r in rows if r["scene"] == key and r["program"] == "scipy"
                          and r["error"] == e and r["time_s"] == ts)
            out.append({"error": e, "scipy": method, "nuno_s": tn, "scipy_s": ts, "speedup": ts / tn})
    return out


def load_results(res: Path):
    summary = json.loads((res / "workprecision.json").read_text())
    rows = []
    with open(res / "workprecision.csv", newline="") as f:
        for r in csv.DictReader(f):
            for k in ("parameter", "error", "time_s", "cpu_s"):
                r[k] = float(r[k]) if r[k] not in ("", "nan") else float("nan")
            rows.append(r)
    return rows, summary


def replot(args) -> int:
    """Figure and doc again from bench/results (no runs)."""
    res = Path(args.results)
    rows, summary = load_results(res)
    for key, info in summary["scenes"].items():
        info["speedup"] = speedups(rows, key)
    (res / "workprecision.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
    figure(rows, summary, Path(args.figure))
    write_doc(rows, summary, Path(args.doc))
    return 0


def machine() -> str:
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()
    return (f"{platform.node()}: {cpu}, {os.cpu_count()} cores, Linux {platform.release()}, "
            f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy_cloth.sp.__name__ and __import__('scipy').__version__}; "
            f"load average at the start {load[0]:.1f} (the cores are shared)")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a smoke run: one scene, a few runs, nothing written to docs/")
    p.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    p.add_argument("--results", default=str(ROOT / "bench" / "results"))
    p.add_argument("--figure", default=str(ROOT / "docs" / "figures" / "workprecision.png"))
    p.add_argument("--doc", default=str(ROOT / "docs" / "workprecision.md"))
    p.add_argument("--scenes", default=None, help="comma-separated scene keys to run (default all)")
    p.add_argument("--replot", action="store_true", help="only the figure and the doc, from bench/results")
    p.add_argument("--output-interval", type=float, default=0.02,
                   help="nuno's output_interval [s] (default 0.02, as users write; 0: one output step, at t_end)")
    args = p.parse_args(argv)
    if args.replot:
        return replot(args)
    start = time.perf_counter()
    log = sys.stdout
    scenes = plan(args.quick)
    if args.scenes:
        keep = [s.strip() for s in args.scenes.split(",")]
        scenes = [s for s in scenes if s["key"] in keep]
    command = "python3 bench/workprecision.py" + (" --quick" if args.quick else "")
    if args.output_interval != 0.02:
        command += f" --output-interval {args.output_interval:g}"
    rows, summary = [], {"machine": machine(), "command": command, "output_interval": args.output_interval,
                         "git": subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                                               capture_output=True, text=True).stdout.strip(),
                         "scenes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        nuno = Nuno(Path(args.exe), Path(tmp), log, args.output_interval)
        for sc in scenes:
            key = sc["key"]
            print(f"{key}:", file=log, flush=True)
            cfg = scipy_cloth.read_config(ROOT / "input" / sc["input"], sc["sets"])
            size = max(float(cfg["lx"]), float(cfg["ly"]))
            info = {"t_end": sc["t_end"], "size": size}
            ref_opts, ref_r = sc["ref"]
            ref = nuno.run(sc, f"{ref_opts} -ts_rtol {ref_r:g}")
            ref2 = nuno.run(sc, f"{ref_opts} -ts_rtol {10 * ref_r:g}")
            if "x" not in ref or "x" not in ref2:
                raise SystemExit(f"{key}: a reference run failed: {ref.get('error_message')} {ref2.get('error_message')}")
            xref = ref["x"]
            d = float(np.abs(ref2["x"] - xref).max() / size)
            info["reference"] = {"opts": f"{ref_opts} -ts_rtol {ref_r:g}", "time_s": ref["time_s"],
                                 "second": f"-ts_rtol {10 * ref_r:g}", "difference": d,
                                 # err(tol) ~ tol^(p/(p+1)), p = 5 or 6: the tighter run is about 7 times
                                 # more accurate, so its error is about d / 6
                                 "estimated_error": d / 6.0}

            def err(x):
                return float(np.abs(np.asarray(x) - xref).max() / size)

            for method, runs in sc["nuno"].items():
                for opts, param in runs:
                    r = nuno.run(sc, opts)
                    row = {"scene": key, "program": "nuno", "method": method, "parameter": param,
                           "error": err(r["x"]) if "x" in r else float("nan"),
                           "time_s": r.get("time_s", float("nan")), "cpu_s": r["cpu_s"],
                           "steps": r.get("steps", ""), "options": opts,
                           "note": r.get("error_message", "")}
                    rows.append(row)
            for method, rtols in sc["scipy"].items():
                for rt in rtols:
                    cloth = scipy_cloth.Cloth(cfg)
                    try:
                        x, si = cloth.solve(sc["t_end"], method, rt)
                        e, note = err(x), ""
                    except RuntimeError as exc:
                        x, si, e, note = None, {"cpu_time": float("nan"), "steps": ""}, float("nan"), str(exc)[:300]
                    print(f"  scipy {method} rtol {rt:g}: {si['cpu_time']:.1f} s", file=log, flush=True)
                    rows.append({"scene": key, "program": "scipy", "method": f"SciPy {method}", "parameter": rt,
                                 "error": e, "time_s": si["cpu_time"], "cpu_s": si["cpu_time"],
                                 "steps": si["steps"], "options": f"solve_ivp(method='{method}', rtol={rt:g})",
                                 "note": note})
            if sc["crosscheck"]:
                m, rt = sc["crosscheck"]
                cloth = scipy_cloth.Cloth(cfg)
                x, si = cloth.solve(sc["t_end"], m, rt)
                info["crosscheck"] = {"scipy": f"{m} rtol {rt:g}", "difference": err(x), "cpu_s": si["cpu_time"]}
                print(f"  cross-check SciPy {m} {rt:g}: {err(x):.2e}", file=log, flush=True)
            # the documented setting: error <= 10 R
            doc = [r for r in rows if r["scene"] == key and r["method"].endswith("(documented)")]
            info["documented"] = [{"rtol": r["parameter"], "error": r["error"],
                                   "ratio": r["error"] / r["parameter"], "time_s": r["time_s"],
                                   "meets": bool(r["error"] <= 10 * r["parameter"])} for r in doc]
            # speed-up at equal error: SciPy's best (BDF or Radau) against nuno's best, each the
            # lower envelope of its runs, interpolated in log-log, never extrapolated
            nf = pareto([(r["error"], r["time_s"]) for r in rows if r["scene"] == key and r["program"] == "nuno"])
            sf = pareto([(r["error"], r["time_s"]) for r in rows if r["scene"] == key and r["program"] == "scipy"])
            info["speedup"] = speedups(rows, key)
            summary["scenes"][key] = info
    summary["elapsed_s"] = time.perf_counter() - start
    if args.quick:
        print(json.dumps(summary["scenes"], indent=1, default=float))
        return 0
    res = Path(args.results)
    res.mkdir(parents=True, exist_ok=True)
    if args.scenes and (res / "workprecision.json").exists():
        # Some scenes again: replace theirs in the results, keep the others.
        old_rows, old = load_results(res)
        again = set(summary["scenes"])
        rows = [r for r in old_rows if r["scene"] not in again] + rows
        order = [s["key"] for s in plan(False)]
        rows.sort(key=lambda r: order.index(r["scene"]) if r["scene"] in order else len(order))
        old["scenes"].update(summary["scenes"])
        old["scenes"] = {k: old["scenes"][k] for k in sorted(old["scenes"], key=lambda k: order.index(k) if k in order else 99)}
        old.setdefault("reruns", []).append({"scenes": sorted(again), "git": summary["git"],
                                             "elapsed_s": summary["elapsed_s"], "machine": summary["machine"]})
        summary = old
    fields = ["scene", "program", "method", "parameter", "error", "time_s", "cpu_s", "steps", "options", "note"]
    with open(res / "workprecision.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in fields})
    (res / "workprecision.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
    figure(rows, summary, Path(args.figure))
    write_doc(rows, summary, Path(args.doc))
    print(f"done in {time.perf_counter() - start:.0f} s", file=log)
    return 0


def figure(rows, summary, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keys = list(summary["scenes"])
    ncol = 2
    nrow = (len(keys) + 1) // 2
    fig, axes = plt.subplots(nrow, ncol, figsize=(13, 5.2 * nrow), squeeze=False)
    methods = sorted({r["method"] for r in rows if r["program"] == "nuno"})
    cmap = plt.get_cmap("tab20")
    colours = {m: cmap((2 * k) % 20 + (k // 10)) for k, m in enumerate(methods)}
    marks = {m: "osD^v<>ph*XP8"[k % 13] for k, m in enumerate(methods)}
    for ax, key in zip(axes.ravel(), keys):
        info = summary["scenes"][key]
        for m in methods + ["SciPy BDF", "SciPy Radau"]:
            pts = sorted((r["time_s"], r["error"]) for r in rows
                         if r["scene"] == key and r["method"] == m and np.isfinite(r["error"]) and r["error"] > 0)
            if not pts:
                continue
            t, e = zip(*pts)
            if m.startswith("SciPy"):
                ax.loglog(t, e, "k-" if "BDF" in m else "k--", marker="s" if "BDF" in m else "o",
                          mfc="white", lw=2, label=m)
            else:
                ax.loglog(t, e, "-", color=colours[m], marker=marks[m], lw=1.2, ms=5, label=m)
        ax.set_title(f"{key}, t = {info['t_end']:g} s")
        ax.set_xlabel("time [s] (nuno: /run wall_time, 1 rank; SciPy: process_time)")
        ax.set_ylabel("final position error / cloth size")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.ravel()[len(keys):]:
        ax.axis("off")
    h, lab = axes.ravel()[0].get_legend_handles_labels()
    fig.legend(h, lab, loc="lower center", ncol=3, fontsize="small", frameon=False)
    fig.tight_layout(rect=(0, 0.09 if nrow > 1 else 0.18, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


BEGIN, END = "<!-- results begin (bench/workprecision.py) -->", "<!-- results end -->"


def write_doc(rows, summary, path: Path):
    every = summary.get("output_interval", 0.0)
    out = [BEGIN, "", f"Command: `{summary['command']}` (commit {summary['git']}), "
           f"{summary['elapsed_s'] / 60:.1f} min; nuno writes "
           + (f"an output step every {every:g} s." if every > 0 else "one output step, at t_end.")]
    for rr in summary.get("reruns", []):
        out.append(f"Run again with `--scenes '{','.join(rr['scenes'])}'` (commit {rr['git']}), "
                   f"{rr['elapsed_s'] / 60:.1f} min: those scenes' results are from that run.")
    out += ["", f"Machine: {summary['machine']}.", "",
           "![work-precision](figures/workprecision.png)", ""]
    out += ["### Speed-up at equal error", "",
            "At the error of each SciPy run on SciPy's lower envelope (the faster of BDF and Radau "
            "there), SciPy's time over the time nuno's lower envelope (its fastest method at that "
            "error) needs for the same error, interpolated in log-log between nuno's runs:", "",
            "| scene | error | SciPy run | SciPy [s] | nuno [s] | speed-up |", "|---|---|---|---|---|---|"]
    for key, info in summary["scenes"].items():
        for s in info["speedup"]:
            out.append(f"| {key} | {s['error']:.2e} | {s['scipy']} | {s['scipy_s']:.3g} | {s['nuno_s']:.3g} | "
                       f"{s['speedup']:.1f} |")
    out += ["", "### References and cross-check", "", "| scene | reference | its time [s] | "
            "difference to the run at 10x its tolerance | estimated error | SciPy at tight tolerance - reference |",
            "|---|---|---|---|---|---|"]
    for key, info in summary["scenes"].items():
        rf = info["reference"]
        cc = info.get("crosscheck")
        ccs = f"{cc['difference']:.1e} ({cc['scipy']})" if cc else "not run"
        out.append(f"| {key} | `{rf['opts']}` | {rf['time_s']:.1f} | {rf['difference']:.1e} | "
                   f"{rf['estimated_error']:.0e} | {ccs} |")
    out += ["", "### The documented setting: `-ts_rtol R` gives an error of at most 10 R", "",
            "| scene | R | error / cloth size | error / R | time [s] | meets |", "|---|---|---|---|---|---|"]
    for key, info in summary["scenes"].items():
        for d in info["documented"]:
            out.append(f"| {key} | {d['rtol']:.0e} | {d['error']:.2e} | {d['ratio']:.2g} | {d['time_s']:.2f} | "
                       f"{'yes' if d['meets'] else 'NO'} |")
    out += ["", "### All runs", "",
            "| scene | method | dt or rtol | error | time [s] | CPU [s] | steps |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        e = f"{r['error']:.2e}" if np.isfinite(r["error"]) else f"failed: {r['note']}"
        out.append(f"| {r['scene']} | {r['method']} | {r['parameter']:g} | {e} | {r['time_s']:.3g} | "
                   f"{r['cpu_s']:.3g} | {r['steps']} |")
    replace_results(path, out[1:], BEGIN, END, "# Work-precision")


def replace_results(path: Path, lines, begin: str, end: str, title: str):
    """Write lines between the markers begin and end of the document at path
    (the text around them is kept; appended, markers and all, when they are
    missing; a new document with the title when there is none)."""
    block = "\n".join([begin, *lines, "", end])
    text = path.read_text() if path.exists() else f"{title}\n\n{begin}\n{end}\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.write_text(text)


if __name__ == "__main__":
    raise SystemExit(main())
