#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Memory soak: run nuno for a fixed wall time with a checkpoint every few
seconds and sample every rank's resident set size (VmRSS, /proc) at every
checkpoint line it prints. A leak per checkpoint or output step shows as a
steady rise; a healthy run is flat after its first minute (the allocator's
and the libraries' start-up).

    python3 bench/soak.py --minutes 10 --nx 129 --ranks 2 --every 10s \
        --json bench/results/soak.json

The run is hang NX x NX (dt = 1 ms, an output step every 0.01 s), stopped
with SIGTERM at the end (which writes one more checkpoint). Prints one line
per sample and a summary: RSS of the first and last sample after the
warm-up, and the least-squares slope over the samples after it [MiB/min].
docs/stability.md, "Memory", holds the result."""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def rss_mib(pid):
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def rank_pids(exe, nml):
    """Processes running exe on nml (the ranks, whoever their parent is)."""
    pids = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            cmd = (d / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if len(cmd) >= 2 and cmd[0].decode(errors="replace").endswith(Path(exe).name) and \
                nml.encode() in cmd[1]:
            pids.append(int(d.name))
    return sorted(pids)


def slope(ts, ys):
    n = len(ts)
    if n < 2:
        return float("nan")
    mt, my = sum(ts) / n, sum(ys) / n
    den = sum((t - mt) ** 2 for t in ts)
    return sum((t - mt) * (y - my) for t, y in zip(ts, ys)) / den if den > 0 else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--exe", default=os.environ.get("NUNO_EXE", str(ROOT / "build" / "nuno")))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--nx", type=int, default=129)
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--every", default="10s", help="-nuno_checkpoint_walltime (default 10s)")
    ap.add_argument("--warmup", type=float, default=1.0, help="minutes left out of the slope (default 1)")
    ap.add_argument("--json", help="write the samples and the summary here")
    a = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="nuno-soak-"))
    nml = work / "soak.nml"
    nml.write_text(f"&scene scene='hang' /\n&lattice nx={a.nx} ny={a.nx} /\n"
                   f"&time t_end=1000 dt=1e-3 /\n"
                   f"&output output_interval=0.01 output_file='soak.h5' /\n")
    cmd = [a.mpiexec, "-n", str(a.ranks), "--oversubscribe", a.exe, str(nml), "-nuno_allow_long",
           "-nuno_checkpoint_walltime", a.every]
    t0 = time.time()
    proc = subprocess.Popen(cmd, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    samples = []
    pids = []
    stop = threading.Timer(a.minutes * 60.0, lambda: proc.send_signal(signal.SIGTERM))
    stop.start()
    try:
        for line in proc.stdout:
            if not line.startswith("nuno: checkpoint"):
                continue
            if not pids:
                pids = rank_pids(a.exe, str(nml))
            rss = [rss_mib(p) for p in pids]
            if any(r is None for r in rss):
                continue
            minute = (time.time() - t0) / 60.0
            t_sim = float(line.split("at t =")[1].split()[0]) if "at t =" in line else float("nan")
            samples.append({"minute": minute, "t": t_sim, "rss_mib": rss})
            print(f"{minute:7.2f} min  t = {t_sim:9.4f}  RSS/rank MiB: " + " ".join(f"{r:7.1f}" for r in rss),
                  flush=True)
    finally:
        stop.cancel()
        proc.wait()
    late = [s for s in samples if s["minute"] >= a.warmup]
    if len(late) < 2:
        print("soak: too few samples after the warm-up", file=sys.stderr)
        return 1
    mean = [sum(s["rss_mib"]) / len(s["rss_mib"]) for s in late]
    summary = {
        "nx": a.nx, "ranks": a.ranks, "every": a.every, "minutes": a.minutes, "samples": len(samples),
        "rss_first_after_warmup_mib": mean[0], "rss_last_mib": mean[-1],
        "rss_max_mib": max(max(s["rss_mib"]) for s in late),
        "slope_mib_per_min": slope([s["minute"] for s in late], mean),
        "exe": a.exe, "host": os.uname().nodename, "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    print("soak: RSS a rank (mean over ranks) %.1f -> %.1f MiB after the first %.0f min, slope %+.3f MiB/min, "
          "%d checkpoints" % (summary["rss_first_after_warmup_mib"], summary["rss_last_mib"], a.warmup,
                              summary["slope_mib_per_min"], len(samples)))
    if a.json:
        Path(a.json).write_text(json.dumps({"summary": summary, "samples": samples}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
