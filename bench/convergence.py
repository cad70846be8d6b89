# SPDX-License-Identifier: BSD-2-Clause
"""Convergence studies of nuno (issue 10 item 5): the observed temporal order
of its integrators and the observed spatial order under lattice refinement.

    source tools/env.sh && python3 bench/convergence.py      # everything (about 15 min here)
    python3 bench/convergence.py --quick                      # a smoke run (seconds), writes nothing
    python3 bench/convergence.py --replot                     # figures and doc from bench/results

Temporal: each method with fixed steps, dt halved from 2e-2 to 6.25e-4,
on bend_release_energy (11 x 11,
to t = 1 s) and hang (21 x 21, to t = 0.2 s); the error of a run is its
final-time position error against a tight adaptive reference (the one of
bench/workprecision.py, checked by a second one at 10 times its
tolerance), the observed order log2 of the ratio of successive errors.
Spatial: hang (to t = 0.05 s) and bend_release_energy (to t = 0.02 s)
with lattice_scaling = 'continuum' on N x N lattices, N = 17, 33, 65, 129
(and 257 for hang), each with a tight adaptive integrator; errors at the
coarsest lattice's nodes against the finest lattice, largest and root mean
square, and the differences of successive lattices, whose order needs no
reference. Every error and order is computed by postprocess.convergence,
the tool users have for their own runs; the runs are made by the runner
of bench/workprecision.py (one rank, its /run wall time).

Writes bench/results/convergence.json, docs/figures/convergence_time.png,
docs/figures/convergence_lattice.png and the results part of
docs/convergence.md (between its markers; the text around them is kept).
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
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from postprocess import convergence  # noqa: E402
from postprocess.reader import read_run  # noqa: E402
import workprecision as wp  # noqa: E402

ARK = "-ts_type arkimex -ts_arkimex_fully_implicit -ts_arkimex_type"
# name: (options, order in theory)
METHODS = {
    "beuler": ("-ts_type beuler", 1),
    "Baraff-Witkin": (wp.BW, 1),
    "cn": ("-ts_type cn", 2),
    "bdf2": ("-ts_type bdf -ts_bdf_order 2", 2),
    "bdf3": ("-ts_type bdf -ts_bdf_order 3", 3),
    "bdf4": ("-ts_type bdf -ts_bdf_order 4", 4),
    "bdf5": ("-ts_type bdf -ts_bdf_order 5", 5),
    "arkimex l2": (f"{ARK} l2", 2),
    "arkimex 3": (f"{ARK} 3", 3),
    "arkimex 4": (f"{ARK} 4", 4),
    "arkimex 5": (f"{ARK} 5", 5),
    "rosw 2p": ("-ts_type rosw -ts_rosw_type 2p", 2),
    "rosw ra34pw2": ("-ts_type rosw -ts_rosw_type ra34pw2", 3),
    "rosw rodas3": ("-ts_type rosw -ts_rosw_type rodas3", 3),
}
DTS = [2e-2 / 2**k for k in range(6)]          # 2e-2 .. 6.25e-4
# A run whose error is below this many times the reference's estimated
# error measures the reference: left out of the orders.
FLOOR = 10.0
ADAPT = "-ts_adapt_type basic " + wp.INF


def plan(quick: bool) -> dict:
    """The studies (sized for about 15 min on 2 shared cores)."""
    if quick:
        return {"temporal": [dict(key="bend_release_energy", input="bend_release_energy.nml", sets={},
                                  t_end=0.1, ref=(f"-ts_type bdf -ts_bdf_order 6 {ADAPT}", 1e-11),
                                  methods=["beuler", "cn", "rosw ra34pw2"], dts=DTS[1:4])],
                "lattice": [dict(key="hang", input="hang.nml", sets={"lattice_scaling": "'continuum'"},
                                 t_end=0.01, ns=[9, 17, 33], opts=f"-ts_type bdf -ts_bdf_order 5 {ADAPT}",
                                 rtol=1e-6)]}
    return {
        "temporal": [
            dict(key="bend_release_energy", input="bend_release_energy.nml", sets={}, t_end=1.0,
                 ref=(f"-ts_type bdf -ts_bdf_order 6 {ADAPT}", 1e-12), methods=list(METHODS), dts=DTS),
            dict(key="hang 21 x 21", input="hang.nml", sets={}, t_end=0.2,
                 ref=(f"-ts_type bdf -ts_bdf_order 5 {ADAPT}", 1e-11), methods=list(METHODS), dts=DTS),
        ],
        "lattice": [
            # bdf5 at these tolerances: its time error is checked below (tighter run
            # on the second-finest lattice) and is far under the lattice's error.
            dict(key="hang", input="hang.nml", sets={"lattice_scaling": "'continuum'"},
                 t_end=0.05, ns=[17, 33, 65, 129, 257], opts=f"-ts_type bdf -ts_bdf_order 5 {ADAPT}",
                 rtol=1e-6),
            # Undamped bending (eta_b = 0): the steps grow 3-4 times per refinement
            # (docs/convergence.md), so 257 and later times are out of reach here.
            dict(key="bend_release_energy", input="bend_release_energy.nml",
                 sets={"lattice_scaling": "'continuum'", "mass_distribution": "'area'"},
                 t_end=0.02, ns=[17, 33, 65, 129], opts=f"-ts_type bdf -ts_bdf_order 5 {ADAPT}",
                 rtol=1e-5),
        ],
    }


def cloth_size(run) -> float:
    """max(lx, ly) of a run, from its /config (the errors are relative to it)."""
    return max(float(run.config["lattice"]["lx"]), float(run.config["lattice"]["ly"]))


def temporal(nuno, sc: dict, log) -> dict:
    """Fixed-step runs of each method against a tight adaptive reference."""
    ref_opts, ref_r = sc["ref"]
    ref = nuno.run(sc, f"{ref_opts} -ts_rtol {ref_r:g}", keep=True)
    ref2 = nuno.run(sc, f"{ref_opts} -ts_rtol {10 * ref_r:g}")
    if "x" not in ref or "x" not in ref2:
        raise SystemExit(f"{sc['key']}: a reference run failed: {ref.get('error_message')} "
                         f"{ref2.get('error_message')}")
    ref_run = read_run(str(ref["h5"]))
    size = cloth_size(ref_run)
    ref_err = float(np.abs(ref2["x"] - ref["x"]).max() / size) / 6.0   # as in bench/workprecision.py
    out = {"t_end": sc["t_end"], "size": size, "reference": f"{ref_opts} -ts_rtol {ref_r:g}",
           "reference_error": ref_err, "methods": {}}
    for name in sc["methods"]:
        opts, theory = METHODS[name]
        runs, failed, cost = [], [], 0.0
        for dt in sc["dts"]:
            r = nuno.run(sc, f"{opts} -ts_dt {dt:g}", keep=True)
            cost += r.get("time_s", 0.0)
            if "h5" in r:
                runs.append(read_run(str(r["h5"])))
            else:
                failed.append({"dt": dt, "message": r.get("error_message", "")})
        m = {"options": opts, "theory": theory, "dt": [], "error": [], "failed": failed, "time_s": cost}
        if len(runs) >= 2:
            res = convergence.study(runs, reference_run=ref_run)
            m["dt"] = [float(h) for h in res["h"]]
            m["error"] = [float(e) / size for e in res["errors"]]
        for r in runs:
            r.close()
        m.update(orders(m["dt"], m["error"], FLOOR * ref_err))
        out["methods"][name] = m
        print(f"  {name}: errors {' '.join(f'{e:.2e}' for e in m['error'])}, orders "
              f"{' '.join(f'{p:.2f}' for p in m['orders'])} ({cost:.1f} s)", file=log, flush=True)
    ref_run.close()
    return out


def orders(dt, err, floor) -> dict:
    """Successive orders (None across a point at the reference's accuracy)
    and the observed order: that of the two smallest steps above the floor."""
    dt, err = np.asarray(dt), np.asarray(err)
    ok = err > floor
    ps = convergence.successive_orders(dt, err) if len(dt) >= 2 else np.array([])
    out = [float(p) if ok[k] and ok[k + 1] else None for k, p in enumerate(ps)]
    valid = [p for p in out if p is not None]
    return {"orders": [p if p is not None else float("nan") for p in out],
            "observed": valid[-1] if valid else None, "at_floor": [bool(not o) for o in ok]}


def lattice(nuno, sc: dict, log) -> dict:
    """Refinement with continuum scaling; errors against the finest lattice."""
    runs, info = [], []
    for n in sc["ns"]:
        scn = dict(sc, sets=dict(sc["sets"], nx=n, ny=n))
        r = nuno.run(scn, f"{sc['opts']} -ts_rtol {sc['rtol']:g}", keep=True)
        if "h5" not in r:
            raise SystemExit(f"{sc['key']} {n} x {n}: failed: {r.get('error_message')}")
        runs.append(read_run(str(r["h5"])))
        info.append({"n": n, "time_s": r["time_s"], "steps": r["steps"]})
        print(f"  {sc['key']} {n} x {n}: {r['steps']} steps, {r['time_s']:.1f} s", file=log, flush=True)
    out = {"t_end": sc["t_end"], "size": cloth_size(runs[0]), "units": runs[0].units(),
           "options": f"{sc['opts']} -ts_rtol {sc['rtol']:g}", "sets": sc["sets"], "runs": info}
    for norm in convergence.NORMS:
        res = convergence.study(runs, reference="finest", norm=norm)
        out[norm] = {"h": [float(h) for h in res["h"]], "error": [float(e) for e in res["errors"]],
                     "orders": [float(p) for p in res["orders"]], "order": res["order"],
                     "h_all": [convergence.spacing(r) for r in runs],
                     "differences": [float(d) for d in res["differences"]],
                     "difference_orders": [float(p) for p in convergence.successive_orders(
                         [convergence.spacing(r) for r in runs[:-1]], res["differences"])],
                     "observed_differences": res["observed"]}
    # The time integrator's share: the second-finest lattice again at a
    # tolerance 10 times tighter.
    n2 = sc["ns"][-2]
    tight = nuno.run(dict(sc, sets=dict(sc["sets"], nx=n2, ny=n2)),
                     f"{sc['opts']} -ts_rtol {sc['rtol'] / 10:g}")
    x2 = np.asarray(runs[-2].position[-1])
    out["time_error"] = {"n": n2, "difference": convergence.distance(tight["x"], x2),
                         "time_s": tight["time_s"]}
    for r in runs:
        r.close()
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a smoke run: small studies, nothing written")
    p.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    p.add_argument("--results", default=str(ROOT / "bench" / "results"))
    p.add_argument("--figures", default=str(ROOT / "docs" / "figures"))
    p.add_argument("--doc", default=str(ROOT / "docs" / "convergence.md"))
    p.add_argument("--only", choices=("temporal", "lattice"), default=None,
                   help="run one of the two studies (merged into the saved results)")
    p.add_argument("--replot", action="store_true", help="only the figures and the doc, from bench/results")
    args = p.parse_args(argv)
    res_path = Path(args.results) / "convergence.json"
    if args.replot:
        summary = json.loads(res_path.read_text())
        write_outputs(summary, args)
        return 0
    start = time.perf_counter()
    log = sys.stdout
    studies = plan(args.quick)
    summary = {"machine": wp.machine(), "git": subprocess.run(
        ["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True).stdout.strip(),
        "command": "python3 bench/convergence.py" + (" --quick" if args.quick else "")
        + (f" --only {args.only}" if args.only else ""),
        "temporal": {}, "lattice": {}}
    with tempfile.TemporaryDirectory() as tmp:
        nuno = wp.Nuno(Path(args.exe), Path(tmp), log)
        for kind, fn in (("temporal", temporal), ("lattice", lattice)):
            if args.only and args.only != kind:
                continue
            t0 = time.perf_counter()
            for sc in studies[kind]:
                print(f"{kind}: {sc['key']}", file=log, flush=True)
                summary[kind][sc["key"]] = fn(nuno, sc, log)
            summary[f"{kind}_elapsed_s"] = time.perf_counter() - t0
    summary["elapsed_s"] = time.perf_counter() - start
    if args.quick:
        print(json.dumps(summary, indent=1, default=float))
        return 0
    if args.only and res_path.exists():
        # One study again: keep the other one's results (and its provenance).
        old = json.loads(res_path.read_text())
        old[args.only] = summary[args.only]
        old.setdefault("reruns", []).append({k: summary[k] for k in ("command", "git", "machine", "elapsed_s")})
        summary = old
    res_path.parent.mkdir(parents=True, exist_ok=True)
    res_path.write_text(json.dumps(summary, indent=1, default=float) + "\n")
    write_outputs(summary, args)
    print(f"done in {time.perf_counter() - start:.0f} s", file=log)
    return 0


def write_outputs(summary, args):
    figures = Path(args.figures)
    figure_temporal(summary["temporal"], figures / "convergence_time.png")
    figure_lattice(summary["lattice"], figures / "convergence_lattice.png")
    write_doc(summary, Path(args.doc))


def _axes(n):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, n, figsize=(6.5 * n, 5.6), squeeze=False)
    return plt, fig, axes.ravel()


def figure_temporal(studies, path: Path):
    plt, fig, axes = _axes(len(studies))
    cmap = plt.get_cmap("tab20")
    names = list(METHODS)
    for ax, (key, st) in zip(axes, studies.items()):
        for k, (name, m) in enumerate(st["methods"].items()):
            if not m["dt"]:
                continue
            c = cmap((2 * names.index(name)) % 20 + (names.index(name) // 10))
            dt, e = np.array(m["dt"]), np.array(m["error"])
            obs = f"{m['observed']:.2f}" if m["observed"] is not None else "-"
            ax.loglog(dt, e, "-", color=c, marker="osD^v<>ph*XP8d"[k % 14], ms=5,
                      label=f"{name} (theory {m['theory']}, observed {obs})")
            low = np.array(m["at_floor"])
            if low.any():
                ax.loglog(dt[low], e[low], "o", ms=9, mfc="none", mec="k")
        ax.axhline(FLOOR * st["reference_error"], color="0.5", ls=":", lw=1)
        ax.set_title(f"{key}, fixed steps, error at t = {st['t_end']:g} s")
        ax.set_xlabel("time step dt [s]")
        ax.set_ylabel("final position error / cloth size")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="x-small", loc="lower right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def figure_lattice(studies, path: Path):
    plt, fig, axes = _axes(len(studies))
    for ax, (key, st) in zip(axes, studies.items()):
        u = st["units"]
        # The figure of nuno-convergence (one implementation): errors and
        # differences with their orders, slope guides from the coarsest error.
        for norm, c in (("max", "C0"), ("rms", "C1")):
            s = st[norm]
            convergence.draw_study(ax, s["h"], s["error"], s["h_all"][:-1], s["differences"],
                                   norm, "finest", color=c, order=s["order"])
        h = np.array(st["max"]["h_all"])
        convergence.slope_guides(ax, h, st["max"]["error"][0])
        ns = [r["n"] for r in st["runs"]]
        ax.set_title(f"{key}, continuum scaling, N = {ns[0]} .. {ns[-1]}, t = {st['t_end']:g} s")
        ax.xaxis.set_minor_formatter(plt.NullFormatter())
        ax.set_xlabel(f"lattice spacing h [{u}]")
        ax.set_ylabel(f"distance [{u}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="x-small")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


BEGIN, END = "<!-- results begin (bench/convergence.py) -->", "<!-- results end -->"


def _num(x, fmt=".2f"):
    return "-" if x is None or not np.isfinite(x) else format(x, fmt)


def write_doc(summary, path: Path):
    out = ["", f"Command: `{summary['command']}` (commit {summary['git']}), {summary['elapsed_s'] / 60:.1f} min."]
    for rr in summary.get("reruns", []):
        out.append(f"Run again: `{rr['command']}` (commit {rr['git']}), {rr['elapsed_s'] / 60:.1f} min: "
                   "that study's results are from that run.")
    out += ["", f"Machine: {summary['machine']}.", ""]
    out += ["### Temporal order (fixed steps, dt halved)", "",
            "![temporal convergence](figures/convergence_time.png)", ""]
    for key, st in summary["temporal"].items():
        dts = sorted({d for m in st["methods"].values() for d in m["dt"]}, reverse=True)
        out += [f"**{key}** to t = {st['t_end']:g} s; reference `{st['reference']}` (estimated error "
                f"{st['reference_error']:.0e} of the cloth size; errors below {FLOOR:g} times that, in "
                "brackets, are left out of the orders). Final position error / cloth size, and the "
                "observed order log2(e(dt) / e(dt/2)) between successive steps:", "",
                "| method | theory | " + " | ".join(f"dt {d:g}" for d in dts) + " | orders | observed |",
                "|---|---|" + "---|" * len(dts) + "---|---|"]
        for name, m in st["methods"].items():
            cells = []
            for d in dts:
                if d in m["dt"]:
                    k = m["dt"].index(d)
                    e = f"{m['error'][k]:.2e}"
                    cells.append(f"({e})" if m["at_floor"][k] else e)
                elif any(abs(f["dt"] - d) < 1e-15 for f in m["failed"]):
                    cells.append("failed")
                else:
                    cells.append("")
            out.append(f"| {name} | {m['theory']} | " + " | ".join(cells) + " | "
                       + " ".join(_num(p) for p in m["orders"]) + f" | {_num(m['observed'])} |")
        fails = [(name, f) for name, m in st["methods"].items() for f in m["failed"]]
        if fails:
            # the message up to its hints
            out += ["", "Failed runs: " + "; ".join(f"{n} at dt {f['dt']:g} ({f['message'].split('; try')[0]})"
                                                    for n, f in fails) + "."]
        out.append("")
    out += ["### Lattice refinement (continuum scaling)", "",
            "![lattice convergence](figures/convergence_lattice.png)", ""]
    for key, st in summary["lattice"].items():
        u = st["units"]
        te = st["time_error"]
        out += [f"**{key}** (`-nuno_set` {', '.join(f'{k}={v}' for k, v in st['sets'].items())}) to "
                f"t = {st['t_end']:g} s with `{st['options']}`. The time integrator's share: the "
                f"{te['n']} x {te['n']} run at a 10 times tighter tolerance differs by {te['difference']:.1e} {u} "
                f"(max), against a lattice error there of {st['max']['error'][-1]:.1e} {u}.", "",
                "| N | h [" + u + "] | steps | time [s] | max error [" + u + "] | rms error [" + u + "] | "
                "max difference to the next N | rms difference |", "|---|---|---|---|---|---|---|---|"]
        for k, r in enumerate(st["runs"]):
            h = st["max"]["h_all"][k]
            last = k == len(st["runs"]) - 1
            em = "finest" if last else f"{st['max']['error'][k]:.2e}"
            er = "finest" if last else f"{st['rms']['error'][k]:.2e}"
            dm = "" if last else f"{st['max']['differences'][k]:.2e}"
            dr = "" if last else f"{st['rms']['differences'][k]:.2e}"
            out.append(f"| {r['n']} | {h:.4g} | {r['steps']} | {r['time_s']:.1f} | {em} | {er} | {dm} | {dr} |")
        out += ["", "| norm | orders against the finest | fit | orders of the differences | fit |",
                "|---|---|---|---|---|"]
        for norm in convergence.NORMS:
            s = st[norm]
            out.append(f"| {norm} | {' '.join(_num(p) for p in s['orders'])} | {_num(s['order'])} | "
                       f"{' '.join(_num(p) for p in s['difference_orders'])} | {_num(s['observed_differences'])} |")
        out.append("")
    wp.replace_results(path, out[:-1], BEGIN, END, "# Convergence")


if __name__ == "__main__":
    raise SystemExit(main())
