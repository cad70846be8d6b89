#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The fast-solver benchmark (issues 7 and 46): hang at N x N on 1 and 2
ranks, on issue 46's protocol (hang with energy bending, dt = 1/600 s, its
table's steps from rest: 60 at 65 x 65 and 129 x 129, 30 at 257, 20 at
513, 10 at 1025), for
  bw      the Baraff-Witkin mode: one linearised solve a step
          (-snes_type ksponly), inner relative tolerance 1e-3;
  newton  full Newton at the default tolerances (nuno's structured
          multigrid, Newton forcing, lagged S), at issue 46's dt = 1/600 s
          too, so that both of its targets are measured as it states them;
  pcmg    the same with PETSc's PCMG as the inner preconditioner
          (-nuno_mg petsc, the default before nuno's multigrid);
  full6   the old 6-dof assembled path (-nuno_jacobian full, GMRES + ILU),
          dt = 1 ms (hang's own), where it runs (65 x 65);
and, with --bending no|both, the same cloth without bending (3 x 3 stencil).
With --peer N:THREADS, the implicit peer (bench/peer_taichi.py) at that N
on that many threads, the same steps, right after nuno's bw rows with
bending at that N, so that nuno/peer comes from runs minutes apart on the
same machine; its line ("peer N=...") goes into the output with nuno's.
Per run: node-steps/s of TSStep (from -log_view), Newton and Krylov
iterations per step, set-up time (wall time before the first step), peak
memory per node (-memory_view, summed over ranks), and the rates of the two
passes a Krylov iteration makes, as bytes/s against a STREAM-like triad
(bench/triad.c, compiled here): the product with S (MatMult) and one cycle
of nuno's multigrid (nunoMGCycle, its bytes from the start-up line). Each
run is repeated --repeat times and the fastest kept (this machine's speed
wanders by 20-30 %).
Writes a JSON file of the raw numbers, a markdown table, and a plot.

    source tools/env.sh
    bash bench/performance.sh          # the benchmark behind docs/performance.md (~15 min)
    bash bench/performance.sh --quick  # the same script at 65 and 129 only (~2 min)
    python3 bench/solver.py --sizes 65 129 --modes bw      # a quick look
    python3 bench/solver.py --replot LOG... --donewhen LOG \
        --output docs/performance-data.json --plot docs/figures/performance.png --doc docs/performance.md

--replot reads the tables and the peer's lines printed by earlier runs
(later logs win for the same case), --donewhen the log of the done-when
run (hang 257 x 257, 1 s, 2 ranks, no options, under /usr/bin/time -v;
smaller with performance.sh --quick), and writes the JSON, the figure and
the table between docs/performance.md's markers from them (with the peer:
its node-steps/s and nuno/peer on the bw rows with bending at its N).
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from postprocess import namelist  # noqa: E402

# steps from rest per run: those of issue 46's table (its protocol)
STEPS = {65: 60, 129: 60, 257: 30, 513: 20, 1025: 10}
# dt [s] and options of each mode: issue 46's targets are at dt = 1/600 s
MODES = {
    "bw": (1.0 / 600.0, ["-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3"]),
    "newton": (1.0 / 600.0, []),
    "pcmg": (1.0 / 600.0, ["-nuno_mg", "petsc"]),
    "full6": (1.0e-3, ["-nuno_jacobian", "full"]),
}


def event(text, name):
    """(count, time [s], MFlop/s) of a -log_view event, or (0, nan, nan)."""
    m = re.search(rf"^{re.escape(name)}\s+(\d+)\s+\S+\s+([0-9.e+-]+)\s+\S+\s+([0-9.e+-]+)\s+\S+"
                  r"(?:\s+\S+){13}\s+([0-9.e+-]+)\s*$", text, re.M)
    if not m:
        return 0, float("nan"), float("nan")
    return int(m.group(1)), float(m.group(2)), float(m.group(4))


def triad(nranks):
    """Triad bandwidth [GB/s] of nranks concurrent copies (summed)."""
    exe = Path(tempfile.gettempdir()) / "nuno_triad"
    subprocess.run(["cc", "-O3", "-march=native", "-o", str(exe), str(ROOT / "bench" / "triad.c")], check=True)
    procs = [subprocess.Popen([str(exe)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
             for _ in range(nranks)]
    return sum(float(p.communicate()[0]) for p in procs)


def run(exe, mpiexec, n, nranks, mode, bending, timeout):
    dt, opts = MODES[mode]
    steps = STEPS.get(n, 3)
    groups = {"scene": {"scene": "hang"}, "lattice": {"nx": n, "ny": n}}
    if not bending:
        groups["material"] = {"bending_model": "none"}
    groups["time"] = {"t_end": steps * dt, "dt": dt}
    groups["output"] = {"output_interval": steps * dt, "output_file": "b.h5"}
    nml = namelist.write(groups)
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "b.nml").write_text(nml)
        cmd = [mpiexec, "-n", str(nranks), "--oversubscribe", exe, "b.nml", "-log_view", "-memory_view", *opts]
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return dict(ok=False, why=f"no result in {timeout} s")
        wall = time.perf_counter() - t0
    out = p.stdout
    if p.returncode != 0:
        last = (p.stdout + p.stderr).strip().splitlines()
        why = next((l for l in reversed(last) if "nuno: error" in l), last[-1] if last else "?")
        return dict(ok=False, why=why[:160])
    ns, t_step, _ = event(out, "TSStep")
    lines = [l for l in out.splitlines() if l.startswith("t =")]
    nums = re.findall(r"steps\s+(\d+)\s+rejected\s+(\d+)\s+newton\s+(\d+)\s+linear\s+(\d+)", lines[-1])[0]
    steps_done, rejected, newton, linear = map(int, nums)
    mem = re.search(r"Maximum \(over computational time\) process memory:\s+total\s+([0-9.e+]+)", out)
    n_mm, t_mm, mf_mm = event(out, "MatMult")
    _, t_sor, mf_sor = event(out, "MatSOR")
    n_cyc, t_cyc, _ = event(out, "nunoMGCycle")
    _, t_asm, _ = event(out, "nunoAssembleS")
    reads = re.search(r"reads about ([0-9.]+) MB", out)
    # S by stencil offset, node by node: the blocks the elements couple
    # (17 with bending, 9 without) and the two vectors; with the mixed
    # product (-nuno_mg_product mixed) the
    # multigrid's single-precision blocks (16 or 8, and the row sums D)
    if "product with S mixed" in out or "product with S fused" in out:
        s_bytes = n * n * (((16 if bending else 8) + 1) * 36 + 48)
    else:
        s_bytes = n * n * ((17 if bending else 9) * 72 + 48)
    mm_gbs = (n_mm * s_bytes / t_mm / 1e9) if (n_cyc and t_mm > 0) else 6e-3 * mf_mm
    if "product with S fused" in out:
        # the products of the cycles' outputs are formed in the cycles
        # (-nuno_mg_product fused, the default): MatMult
        # times copies, its bandwidth is not that of a product
        mm_gbs = float("nan")
    cyc_gbs = (n_cyc * float(reads.group(1)) * 1e6 / t_cyc / 1e9) if (n_cyc and reads and t_cyc > 0) else float("nan")
    _, t_jac, _ = event(out, "SNESJacobianEval")
    _, t_ksp, _ = event(out, "KSPSolve")
    _, t_pcs, _ = event(out, "PCSetUp")
    total = re.search(r"^Time \(sec\):\s+([0-9.e+-]+)", out, re.M)
    return dict(ok=True, n=n, nranks=nranks, mode=mode, bending=bending, steps=steps_done,
                rejected=rejected, newton_per_step=newton / max(steps_done, 1),
                krylov_per_step=linear / max(steps_done, 1), t_step=t_step,
                node_steps_per_s=n * n * steps_done / t_step,
                setup_s=(float(total.group(1)) - t_step) if total else float("nan"), wall=wall,
                bytes_per_node=float(mem.group(1)) / (n * n) if mem else float("nan"),
                jac_share=t_jac / t_step, ksp_share=t_ksp / t_step, pcsetup_share=t_pcs / t_step,
                # AIJ and BAIJ products move about 6 bytes a flop (8-byte value and
                # 4-byte index per multiply-add), vectors aside; nuno's S is a
                # MATSHELL (no flops logged): its bytes counted above
                matmult_gbs=mm_gbs, sor_gbs=6e-3 * mf_sor, cycle_gbs=cyc_gbs,
                cycle_ms=1e3 * t_cyc / n_cyc if n_cyc else float("nan"),
                assemble_share=t_asm / t_step if n_cyc else float("nan"))


# the line bench/peer_taichi.py prints (and this script copies into its output)
PEER_LINE = re.compile(r"^peer N=(\d+) threads=(\d+) steps=(\d+) cg_iterations_per_step=([0-9.eE+-]+) "
                       r"node_steps_per_s=([0-9.eE+-]+)\s*$", re.M)


def peer_from_match(m):
    return dict(ok=True, n=int(m.group(1)), threads=int(m.group(2)), steps=int(m.group(3)),
                cg_iterations_per_step=float(m.group(4)), node_steps_per_s=float(m.group(5)))


def peer_run(n, threads, steps, timeout):
    """The peer (bench/peer_taichi.py, in its venv under runs/) at N x N on
    threads threads, steps steps at bw's dt: its numbers, or ok=False."""
    cmd = [sys.executable, str(ROOT / "bench" / "peer_taichi.py"), "--n", str(n), "--steps", str(steps),
           "--threads", str(threads), "--dt", repr(MODES["bw"][0])]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return dict(ok=False, n=n, threads=threads, why=f"no result in {timeout} s")
    m = PEER_LINE.search(p.stdout)
    if p.returncode != 0 or not m:
        last = (p.stdout + p.stderr).strip().splitlines()
        return dict(ok=False, n=n, threads=threads, why=(last[-1] if last else "?")[:160])
    return peer_from_match(m)


def peer_line(r):
    """The peer's line as bench/peer_taichi.py prints it (what --replot reads)."""
    if not r["ok"]:
        return f"peer N={r['n']} threads={r['threads']} failed: {r['why']}"
    return (f"peer N={r['n']} threads={r['threads']} steps={r['steps']} "
            f"cg_iterations_per_step={r['cg_iterations_per_step']:.2f} node_steps_per_s={r['node_steps_per_s']:.4g}")


def peer_spec(text):
    """--peer's N:THREADS as (N, THREADS)."""
    try:
        n, threads = (int(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--peer takes N:THREADS, got {text!r}") from None
    if n < 3 or threads < 1:
        raise argparse.ArgumentTypeError(f"--peer needs N >= 3 and THREADS >= 1, got {text!r}")
    return n, threads


def table(rows, bw1, bw2):
    head = ("| mode | bending | N | ranks | steps | node-steps/s | Newton/step | Krylov/step | set-up [s] "
            "| memory [KB/node] | Jacobian | KSP | MatMult GB/s (of triad) | MG cycle GB/s (of triad) |\n|" + "---|" * 14)
    out = [head]
    for r in rows:
        if not r["ok"]:
            out.append(f"| {r['mode']} | {'yes' if r['bending'] else 'no'} | {r['n']} | {r['nranks']} "
                       f"| failed: {r['why']} |||||||||")
            continue
        bw = bw1 if r["nranks"] == 1 else bw2
        out.append(f"| {r['mode']} | {'yes' if r['bending'] else 'no'} | {r['n']} | {r['nranks']} | {r['steps']} "
                   f"| {r['node_steps_per_s']:.3g} | {r['newton_per_step']:.2f} | {r['krylov_per_step']:.1f} "
                   f"| {r['setup_s']:.2f} | {r['bytes_per_node'] / 1024:.2f} | {100 * r['jac_share']:.0f} % "
                   f"| {100 * r['ksp_share']:.0f} % | {r['matmult_gbs']:.1f} ({100 * r['matmult_gbs'] / bw:.0f} %) "
                   + (f"| {r['cycle_gbs']:.1f} ({100 * r['cycle_gbs'] / bw:.0f} %) |"
                      if r.get("cycle_gbs", float("nan")) == r.get("cycle_gbs", float("nan")) else "| - |"))
    return "\n".join(out)


def plot(rows, path, peers=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 4.5))
    keys = sorted({(r["mode"], r["bending"], r["nranks"]) for r in rows if r["ok"]})
    palette = plt.get_cmap("viridis")
    combos = sorted({(m, b) for m, b, _ in keys})
    colors = {c: palette(k / max(1, len(combos) - 1) * 0.9) for k, c in enumerate(combos)}
    for mode, bending, nranks in keys:
        pts = sorted((r["n"], r["node_steps_per_s"]) for r in rows
                     if r["ok"] and (r["mode"], r["bending"], r["nranks"]) == (mode, bending, nranks))
        ax.loglog(*zip(*pts), ("o-" if nranks == 1 else "s--"), color=colors[(mode, bending)],
                  label=f"{mode}, {'bending' if bending else 'no bending'}, {nranks} rank(s)")
    peers = sorted((r["n"], r["node_steps_per_s"] / r["threads"]) for r in peers or [])
    if peers:
        # the peer measured in the same run (--peer): node-steps/s per thread
        ax.loglog(*zip(*peers), "k:", marker="x", lw=1.2,
                  label="peer (peer_taichi.py), per thread")
    else:
        # logs without the peer: its rate from bench/peer.sh (docs/performance.md "The peer")
        ax.axhline(1.0e5, color="k", lw=0.8, ls=":")
        ax.text(70, 1.1e5, "peer (bench/peer_taichi.py): 0.1 M per core (257 x 257, 2-hop springs)", fontsize=8)
    ax.set_xlabel("N (lattice N x N)")
    ax.set_ylabel("node-steps / s (TSStep)")
    ax.axhline(1.2e6, color="k", lw=0.8, ls="--")
    ax.text(70, 1.32e6, "issue 46's target, bw with bending, 257 x 257 on 1 core: 1.2 M", fontsize=8)
    builds = sorted({m.group(1) for r in rows for m in [re.search(r"-([0-9a-f]{7,})", r.get("log", ""))] if m})
    ax.set_title("nuno reduced solve, hang scene, this 2-core machine"
                 + (f" (builds {', '.join(builds)})" if builds else ""), fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def rows_from_table(path):
    """Rows back from the markdown lines this script prints (to replot), each
    with the name of its log. Lines starting with '#' are the log's notes."""
    rows = []
    for line in Path(path).read_text().splitlines():
        f = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(f) < 14 or f[0] not in MODES or "failed" in line:
            continue
        rows.append(dict(ok=True, mode=f[0], bending=f[1] == "yes", n=int(f[2]), nranks=int(f[3]),
                         steps=int(f[4]), node_steps_per_s=float(f[5]), newton_per_step=float(f[6]),
                         krylov_per_step=float(f[7]), setup_s=float(f[8]), bytes_per_node=1024 * float(f[9]),
                         log=Path(path).name))
    return rows


def peers_from_log(path):
    """The peer's lines of a log (--peer), each with the name of its log."""
    return [dict(peer_from_match(m), log=Path(path).name) for m in PEER_LINE.finditer(Path(path).read_text())]


def log_source(path):
    """A log's notes ('#' lines) and triad line: where its numbers come from."""
    lines = Path(path).read_text().splitlines()
    notes = [l.lstrip("# ").strip() for l in lines if l.startswith("#")]
    triad_line = next((l for l in lines if l.startswith("triad:")), "")
    return dict(log=Path(path).name, notes=notes, triad=triad_line)


def donewhen_from_log(path):
    """The done-when run (hang 257 x 257, 1 s, 2 ranks, no options) from its
    log: nuno's summary lines, -log_view's TSStep and /usr/bin/time -v."""
    text = Path(path).read_text()
    last = [l for l in text.splitlines() if l.startswith("t =")][-1]
    steps, rejected, newton, linear = map(int, re.findall(
        r"steps\s+(\d+)\s+rejected\s+(\d+)\s+newton\s+(\d+)\s+linear\s+(\d+)", last)[0])
    wall = re.search(r"wall time\s+([0-9.E+-]+) s", text)
    elapsed = re.search(r"^real\s+(\d+)m([0-9.]+)s", text, re.M)
    rss = re.search(r"Maximum resident set size \(kbytes\):\s+(\d+)", text)
    _, t_step, _ = event(text, "TSStep")
    # its lattice and t_end [s] from the log's first line (--quick runs a smaller one)
    case = re.search(r"nx = ny = (\d+), t_end = ([0-9.]+)", text)
    return dict(log=Path(path).name, n=int(case.group(1)) if case else 257,
                t_end_s=float(case.group(2)) if case else 1.0, steps=steps, rejected=rejected, newton=newton, linear=linear,
                wall_time_s=float(wall.group(1)) if wall else None,
                elapsed_s=(60 * int(elapsed.group(1)) + float(elapsed.group(2))) if elapsed else None,
                tsstep_s=t_step, max_rss_mb=int(rss.group(1)) / 1024 if rss else None)


def doc_table(data):
    """The markdown of docs/performance.md's table (between its markers):
    one row a (bending, mode, N), the two rank counts side by side; with the
    peer's runs (data["peer"]), two columns more on the bw rows with bending
    at the peer's N: its node-steps/s and nuno's over it at as many ranks as
    the peer had threads."""
    runs = {(r["mode"], r["bending"], r["n"], r["nranks"]): r for r in data["runs"]}
    peers = data.get("peer") or []

    def cell(r, key, fmt):
        return fmt.format(r[key]) if r else "-"

    def peer_cells(bending, mode, n):
        here = sorted((q for q in peers if q["n"] == n), key=lambda q: q["threads"]) \
            if bending and mode == "bw" else []
        if not here:
            return "| - | - "
        rates, ratios = [], []
        for q in here:
            s = "" if q["threads"] == 1 else "s"
            rates.append(f"{q['node_steps_per_s']:.3g} ({q['threads']} thread{s})")
            nuno = runs.get((mode, bending, n, q["threads"]))
            ratios.append(f"{nuno['node_steps_per_s'] / q['node_steps_per_s']:.2f} ({q['threads']} rank{s})"
                          if nuno else "-")
        return f"| {'; '.join(rates)} | {'; '.join(ratios)} "

    head = "| bending | mode | N | node-steps/s, 1 rank | node-steps/s, 2 ranks "
    rule = "|---|---|---|---|---"
    if peers:
        head += "| peer node-steps/s | nuno / peer "
        rule += "|---|---"
    out = [head + "| Newton / step (2 ranks) | Krylov / step (2 ranks) | KB / node, 1 rank | KB / node, 2 ranks | log |",
           rule + "|---|---|---|---|---|"]
    keys = sorted({(b, m, n) for m, b, n, _ in runs}, key=lambda k: (not k[0], k[1], k[2]))
    for bending, mode, n in keys:
        one, two = runs.get((mode, bending, n, 1)), runs.get((mode, bending, n, 2))
        ref = two or one
        kb1 = dict(kb=one["bytes_per_node"] / 1024) if one else None
        kb2 = dict(kb=two["bytes_per_node"] / 1024) if two else None
        out.append(f"| {'yes' if bending else 'no'} | {mode} | {n} "
                   f"| {cell(one, 'node_steps_per_s', '{:.3g}')} | {cell(two, 'node_steps_per_s', '{:.3g}')} "
                   + (peer_cells(bending, mode, n) if peers else "")
                   + f"| {ref['newton_per_step']:.2f} | {ref['krylov_per_step']:.1f} "
                   f"| {cell(kb1, 'kb', '{:.2f}')} | {cell(kb2, 'kb', '{:.2f}')} | {ref.get('log', '')} |")
    d = data.get("donewhen")
    if d:
        n, t_end = d.get("n", 257), d.get("t_end_s", 1.0)
        out += ["", f"Done-when run (hang {n} x {n}, {t_end:g} s, 2 ranks, no options; {d['log']}): "
                f"{d['elapsed_s']:.1f} s elapsed, TSStep {d['tsstep_s']:.1f} s, {d['steps']} steps, "
                f"{d['rejected']} rejected, {d['newton']} Newton and {d['linear']} Krylov iterations, "
                + (f"{d['max_rss_mb']:.0f} MB resident at most (the largest process)."
                   if d["max_rss_mb"] is not None else "resident memory not recorded.")]
    return out


def replace_between(path, lines, begin="<!-- table begin (bench/solver.py) -->",
                    end="<!-- table end -->"):
    """Put lines between the markers of a markdown file (the rest untouched)."""
    text = Path(path).read_text()
    a, b = text.index(begin) + len(begin), text.index(end)
    Path(path).write_text(text[:a] + "\n" + "\n".join(lines) + "\n" + text[b:])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[65, 129, 257, 513, 1025])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--modes", nargs="+", default=["bw", "newton", "full6"], choices=sorted(MODES))
    ap.add_argument("--bending", choices=["yes", "no", "both"], default="yes",
                    help="hang's energy bending (yes), the same cloth without bending (no), or both")
    ap.add_argument("--peer", type=peer_spec, nargs="+", default=[], metavar="N:THREADS",
                    help="run the peer (bench/peer_taichi.py) at N on THREADS threads, the steps of N, "
                         "after nuno's bw rows with bending at N (issue 46: 257:1 1025:2)")
    ap.add_argument("--timeout", type=float, default=900, help="seconds per run")
    ap.add_argument("--repeat", type=int, default=2, help="runs of each case (and of the peer), the fastest kept")
    ap.add_argument("--output", help="JSON file of the raw numbers")
    ap.add_argument("--plot", help="PNG of node-steps/s against N")
    ap.add_argument("--replot", nargs="+", metavar="LOG",
                    help="no runs: read the tables printed by earlier runs (a later log wins for the "
                         "same case) and write --output, --plot and --doc")
    ap.add_argument("--donewhen", metavar="LOG", help="with --replot: the done-when run's log")
    ap.add_argument("--doc", help="with --replot: markdown file whose table markers get the table")
    a = ap.parse_args(argv)
    a.exe = str(Path(a.exe).resolve())  # the runs start in their own folders
    lost = [f"{n}:{t}" for n, t in a.peer if n not in a.sizes or "bw" not in a.modes or a.bending == "no"]
    if lost and not a.replot:
        ap.error(f"--peer {' '.join(lost)} runs after nuno's bw rows with bending at its N, "
                 "which these --sizes, --modes and --bending do not run")
    if a.replot:
        rows = [r for log in a.replot for r in rows_from_table(log)]
        rows = list({(r["mode"], r["bending"], r["n"], r["nranks"]): r for r in rows}.values())
        peers = [q for log in a.replot for q in peers_from_log(log)]
        peers = list({(q["n"], q["threads"]): q for q in peers}.values())
        data = dict(sources=[log_source(log) for log in a.replot], runs=rows)
        if peers:
            data["peer"] = peers
        if a.donewhen:
            data["donewhen"] = donewhen_from_log(a.donewhen)
        if a.output:
            Path(a.output).write_text(json.dumps(data, indent=1) + "\n")
        if a.plot:
            plot(rows, a.plot, peers)
        if a.doc:
            replace_between(a.doc, doc_table(data))
        else:
            print("\n".join(doc_table(data)))
        return 0
    bw1, bw2 = triad(1), triad(2)
    print(f"triad: {bw1:.1f} GB/s on 1 core, {bw2:.1f} GB/s on 2", flush=True)
    rows, peers = [], []
    for bending in {"yes": [True], "no": [False], "both": [True, False]}[a.bending]:
        for mode in a.modes:
            for n in a.sizes:
                if mode == "full6" and n > 65:
                    continue          # accepts no step at 129 x 129 (docs/design.md)
                for p in a.ranks:
                    if n >= 1025 and p == 1 and mode != "bw":
                        continue
                    tries = [run(a.exe, a.mpiexec, n, p, mode, bending, a.timeout) for _ in range(a.repeat)]
                    good = [t for t in tries if t["ok"]]
                    r = max(good, key=lambda t: t["node_steps_per_s"]) if good else tries[0]
                    r.update(n=n, nranks=p, mode=mode, bending=bending)
                    rows.append(r)
                    print(table([r], bw1, bw2).splitlines()[-1], flush=True)
                for pn, threads in a.peer:
                    if (pn, mode, bending) == (n, "bw", True):
                        tries = [peer_run(n, threads, STEPS.get(n, 3), a.timeout) for _ in range(a.repeat)]
                        good = [t for t in tries if t["ok"]]
                        peers.append(max(good, key=lambda t: t["node_steps_per_s"]) if good else tries[0])
                        print(peer_line(peers[-1]), flush=True)
    print()
    print(table(rows, bw1, bw2))
    for q in peers:
        print(peer_line(q))
    if a.output:
        Path(a.output).write_text(json.dumps(dict(triad_gbs=[bw1, bw2], runs=rows, peer=peers), indent=1))
    if a.plot:
        plot(rows, a.plot, [q for q in peers if q["ok"]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
