# SPDX-License-Identifier: BSD-2-Clause
"""Parameter sweeps and refinement studies in one command: run, name the files, plot.

    nuno-sweep input/hang.nml --set e_s=1e3,2e3,4e3,8e3            # a parameter sweep
    nuno-sweep input/hang.nml --lattice 17,33,65 --fixed lattice_scaling="'continuum'"
    nuno-sweep input/hang.nml --dt 4e-3,2e-3,1e-3,5e-4 --options "-ts_type cn"
    nuno-sweep input/hang.nml --set e_s=1e3,2e3 --batch local -j 2    # 2 runs at once
    nuno-sweep input/hang.nml --set e_s=1e3,2e3 --batch slurm [--submit]   # Slurm jobs
    nuno-sweep input/hang.nml --set e_s=1e3,2e3 --plots-only           # plot finished jobs

One run per value, each the namelist with the value set by -nuno_set (so any
key works, whether or not the file names it): --set KEY=V1,V2,... sets KEY,
--lattice N1,N2,... sets nx = ny = N (a lattice refinement), --dt sets the
fixed time step dt. --fixed KEY=VALUE[,KEY=VALUE...] is set in every run,
--options passes program options (-ts_type cn, ...) to every run. The files
are <outdir>/<stem>_<key>-<value>.h5 (with .log beside each), outdir by
default runs/sweep_<stem>_<key>; sweep.json there lists the values, files and
commands. Runs go on this machine on --ranks ranks each (mpiexec, or
$NUNO_MPIEXEC), -j N of them at once (--batch local; default one after the
other). --batch slurm writes <outdir>/submit.sh instead: one Slurm job array
of tools/slurm/nuno.sbatch (task k runs line k of runs.txt; checkpointed and
requeued: see that script), with the executable's absolute path exported
(NUNO_EXE), and a plotting job (plots.sbatch: this command with
--plots-only) that runs after every task has ended well
(--dependency=afterok:<array>); --submit runs submit.sh.

Then (unless --no-plots) the comparison tools, labelled by the swept value,
write into outdir: compare.png (nuno-compare: snapshots at the last common
time and differences from the first run), timeseries.png (nuno-timeseries
over all runs); for a lattice or dt refinement of 3 runs or more also
convergence.png (nuno-convergence: the observed order, the asymptotic range
judged). The command line of each is printed, to redo it with other options.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

from . import cli

REPO = Path(__file__).resolve().parents[1]
SBATCH_SCRIPT = REPO / "tools" / "slurm" / "nuno.sbatch"


def split_values(text: str) -> list[str]:
    """Comma-separated Fortran values; commas inside quotes stay ('a,b')."""
    out, cur, quote = [], "", None
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == ",":
            out.append(cur.strip())
            cur = ""
            continue
        cur += ch
    out.append(cur.strip())
    if quote or any(not v for v in out):
        raise cli.UsageError(f"{text!r}: not a comma-separated list of values")
    return out


def parse_study(args) -> tuple[str, str, list[str]]:
    """(kind, key, values) from --set / --lattice / --dt (exactly one)."""
    given = [name for name in ("set", "lattice", "dt") if getattr(args, name)]
    if len(given) != 1:
        raise cli.UsageError("give one of --set KEY=V1,V2,..., --lattice N1,N2,... or --dt DT1,DT2,...")
    kind = given[0]
    if kind == "set":
        key, sep, rest = args.set.partition("=")
        key = key.strip()
        if not sep or not re.fullmatch(r"[A-Za-z_][\w%]*(\(\d+\))?", key):
            raise cli.UsageError(f"--set {args.set}: write KEY=V1,V2,...")
        if key.lower() in ("output_file",):
            raise cli.UsageError(f"--set {key}: the sweep names the output files itself")
        values = split_values(rest)
    elif kind == "lattice":
        key, values = "nx", split_values(args.lattice)
        for v in values:
            if not re.fullmatch(r"\d+", v) or int(v) < 2:
                raise cli.UsageError(f"--lattice {args.lattice}: {v!r} is not a node count >= 2")
    else:
        key, values = "dt", split_values(args.dt)
        for v in values:
            try:
                ok = float(v.replace("d", "e").replace("D", "e")) > 0
            except ValueError:
                ok = False
            if not ok:
                raise cli.UsageError(f"--dt {args.dt}: {v!r} is not a positive time step")
    if len(set(values)) != len(values):
        raise cli.UsageError(f"the values of {key} repeat: {', '.join(values)}")
    return kind, key, values


def file_stem(stem: str, key: str, value: str) -> str:
    """<stem>_<key>-<value>, with only file-name-safe characters."""
    safe = re.sub(r"[^A-Za-z0-9.+-]+", "_", value.strip("'\"")).strip("_") or "value"
    return f"{stem}_{re.sub(r'[^A-Za-z0-9_]+', '_', key)}-{safe}"


def settings(kind: str, key: str, value: str, fixed: list[str]) -> list[str]:
    """The -nuno_set entries of one run (the swept key last: it wins)."""
    own = [f"nx={value}", f"ny={value}"] if kind == "lattice" else [f"{key}={value}"]
    return fixed + own


def find_exe(given: str | None) -> str:
    for cand in (given, os.environ.get("NUNO_EXE"), shutil.which("nuno"), str(REPO / "build" / "nuno")):
        if cand and Path(cand).is_file() and os.access(cand, os.X_OK):
            return str(Path(cand).resolve())
    if given:
        raise FileNotFoundError(f"--exe {given}: no such executable")
    raise FileNotFoundError("no nuno executable: give --exe, set NUNO_EXE or put nuno on PATH "
                            "(bash tools/build.sh builds build/nuno)")


def plan(args) -> dict:
    kind, key, values = parse_study(args)
    nml = Path(args.namelist)
    if not nml.is_file():
        raise FileNotFoundError(f"{nml}: no such namelist file")
    fixed = split_values(args.fixed) if args.fixed else []
    for item in fixed:
        if "=" not in item:
            raise cli.UsageError(f"--fixed {args.fixed}: {item!r} is not KEY=VALUE")
    stem = nml.stem
    outdir = Path(args.outdir or Path("runs") / f"sweep_{stem}_{key}")
    runs = []
    for v in values:
        name = file_stem(stem, key, v)
        runs.append({"value": v, "name": name, "file": f"{name}.h5",
                     "set": settings(kind, key, v, fixed)})
    spec = {"set": args.set, "lattice": args.lattice, "dt": args.dt}[kind]
    return {"namelist": str(nml.resolve()), "kind": kind, "key": key, "values": values,
            "spec": spec, "fixed": fixed, "options": shlex.split(args.options or ""),
            "ranks": args.ranks, "outdir": str(outdir), "runs": runs}


def nuno_args(study: dict, run: dict) -> list[str]:
    sets = run["set"] + [f"output_file='{run['file']}'"]
    return [study["namelist"], "-nuno_set", ",".join(sets), *study["options"]]


def run_local(study: dict, exe: str, mpiexec: str, jobs: int = 1) -> list[str]:
    """Every run on this machine, `jobs` at once (cwd: outdir, log beside its
    file); returns the failures."""
    outdir = Path(study["outdir"])
    failed = []
    n = len(study["runs"])
    waiting = list(enumerate(study["runs"], start=1))
    running: dict = {}        # Popen -> (k, run, log, start)
    while waiting or running:
        while waiting and len(running) < jobs:
            k, run = waiting.pop(0)
            cmd = [*shlex.split(mpiexec), "-n", str(study["ranks"]), exe, *nuno_args(study, run)]
            run["command"] = shlex.join(cmd)
            log = open(outdir / f"{run['name']}.log", "w")
            proc = subprocess.Popen(cmd, cwd=outdir, stdout=log, stderr=subprocess.STDOUT)
            running[proc] = (k, run, log, time.perf_counter())
        done = [proc for proc in running if proc.poll() is not None]
        if not done:
            time.sleep(0.05)
            continue
        for proc in done:
            k, run, log, t0 = running.pop(proc)
            log.close()
            run["returncode"] = proc.returncode
            run["wall_s"] = round(time.perf_counter() - t0, 3)
            state = ("ok" if proc.returncode == 0
                     else f"failed (exit {proc.returncode}; see {run['name']}.log)")
            print(f"sweep: {k}/{n} {study['key']} = {run['value']}: {state}, "
                  f"{run['wall_s']:.1f} s", flush=True)
            if proc.returncode != 0:
                failed.append(run["name"])
    return [r["name"] for r in study["runs"] if r["name"] in failed]   # in the sweep's order


def plots_command(study: dict) -> list[str]:
    """This sweep's figures from its files: the command the plotting job runs."""
    pkg = __package__ or "postprocess"
    argv = [sys.executable, "-m", f"{pkg}.sweep", study["namelist"], f"--{study['kind']}",
            study["spec"], "--outdir", str(Path(study["outdir"]).resolve()), "--plots-only"]
    return argv


def write_batch(study: dict, exe: str, script: Path) -> Path:
    """<outdir>/submit.sh: one Slurm job array (task k: line k of runs.txt,
    run by tools/slurm/nuno.sbatch --runs) and a plotting job after it
    (afterok); the jobs find the executable by its exported absolute path."""
    if not script.is_file():
        raise FileNotFoundError(f"{script}: no batch script (give --sbatch-script)")
    outdir = Path(study["outdir"])
    name = f"{Path(study['namelist']).stem}_{study['key']}"
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
    lines = []
    for run in study["runs"]:
        words = [study["namelist"], run["file"], "-nuno_set", ",".join(run["set"]), *study["options"]]
        run["command"] = shlex.join(words)
        lines.append(run["command"])
    (outdir / "runs.txt").write_text("\n".join(lines) + "\n")
    pythonpath = str(Path(__file__).resolve().parents[1])
    (outdir / "plots.sbatch").write_text("\n".join([
        "#!/usr/bin/env bash",
        f"# nuno-sweep: the figures of the sweep in {outdir.resolve()}, once every run of",
        "# its job array has ended well (submit.sh: --dependency=afterok:<array>).",
        "#SBATCH --ntasks=1",
        "#SBATCH --time=01:00:00",
        "set -euo pipefail",
        "export MPLBACKEND=Agg",
        f"export PYTHONPATH={shlex.quote(pythonpath)}${{PYTHONPATH:+:$PYTHONPATH}}",
        shlex.join(plots_command(study)),
    ]) + "\n")
    n = len(study["runs"])
    array = ["sbatch", "--parsable", f"--array=0-{n - 1}", f"--job-name={name}",
             f"--ntasks={study['ranks']}", "--output=%x-%A_%a.log", str(script.resolve()),
             "--runs", "runs.txt"]
    plot = ["sbatch", "--parsable", "--dependency=afterok:$array", "--kill-on-invalid-dep=yes",
            f"--job-name={name}-plots", "--output=%x-%j.log", "plots.sbatch"]
    text = [
        "#!/usr/bin/env bash",
        f"# nuno-sweep: {study['key']} = {', '.join(study['values'])} of {study['namelist']}:",
        f"# one Slurm job array of {n} runs ({script.name} --runs runs.txt: task k runs line k,",
        "# checkpointed, requeued, continued), then the plotting job (plots.sbatch) once",
        "# every task has ended well (afterok). The jobs find nuno by NUNO_EXE, exported here.",
        "set -euo pipefail",
        'cd "$(dirname "$0")"',
        f"export NUNO_EXE={shlex.quote(exe)}",
        f"array=$({shlex.join(array)})",
        "array=${array%%;*}    # --parsable prints ID or ID;CLUSTER",
        f'echo "nuno-sweep: job array $array: {n} runs ({study["key"]})"',
        # $array must expand: the dependency is not quoted by shlex
        "plots=$(" + " ".join(shlex.quote(w) if "$array" not in w else f'"{w}"' for w in plot) + ")",
        'echo "nuno-sweep: plotting job ${plots%%;*} after job array $array (afterok)"',
    ]
    path = outdir / "submit.sh"
    path.write_text("\n".join(text) + "\n")
    path.chmod(0o755)
    return path


def plots(study: dict, dpi: int) -> list[str]:
    """The comparison figures of the finished runs; returns their paths."""
    from . import compare, convergence, timeseries  # noqa: only when plotting

    outdir = Path(study["outdir"])
    files = [str(outdir / r["file"]) for r in study["runs"] if (outdir / r["file"]).is_file()]
    if len(files) < len(study["runs"]):
        print(f"sweep: {len(study['runs']) - len(files)} of {len(study['runs'])} files missing: "
              "plotting the others", file=sys.stderr)
    label = study["key"]
    jobs = []
    if len(files) >= 2:
        jobs.append(("compare", compare.main, [*files, "--label", label, "-o", str(outdir / "compare.png")]))
    if files:
        jobs.append(("timeseries", timeseries.main,
                     [*files, "--label", label, "-o", str(outdir / "timeseries.png")]))
    if study["kind"] in ("lattice", "dt") and len(files) >= 3:
        jobs.append(("convergence", convergence.main,     # the title names the namelist file
                     [*files, "--name", Path(study["namelist"]).name,
                      "-o", str(outdir / "convergence.png")]))
    made = []
    for name, fn, argv in jobs:
        argv = argv + ["--dpi", str(dpi)]
        print(f"sweep: {cli.script_name(name)} {shlex.join(argv)}", flush=True)
        try:
            ok = fn(argv) == 0
        except SystemExit:           # argparse's usage error: reported, go on
            ok = False
        if ok:
            made.append(argv[argv.index("-o") + 1])
    return made


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "sweep")
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = "examples:\n" + "\n".join(
        line for line in __doc__.splitlines()[2:9]) + "\n\nsee postprocess/README.md"
    p.add_argument("namelist", help="the case's namelist file")
    g = p.add_argument_group("what varies (one of)")
    g.add_argument("--set", default=None, metavar="KEY=V1,V2,...",
                   help="a parameter sweep: one run for each value of a namelist key")
    g.add_argument("--lattice", default=None, metavar="N1,N2,...",
                   help="a lattice refinement: nx = ny = N")
    g.add_argument("--dt", default=None, metavar="DT1,DT2,...",
                   help="a time-step refinement: the fixed step dt")
    p.add_argument("--fixed", default=None, metavar="KEY=VALUE,...",
                   help="namelist keys set in every run (e.g. t_end=0.5,lattice_scaling='continuum')")
    p.add_argument("--options", default="", metavar="'-OPT VALUE ...'",
                   help="program options for every run (e.g. '-ts_type cn'; one word: "
                        "--options=-snes_monitor)")
    p.add_argument("-n", "--ranks", type=int, default=1, help="MPI ranks a run (default 1)")
    p.add_argument("--exe", default=None,
                   help="the nuno executable (default: $NUNO_EXE, nuno on PATH, build/nuno)")
    p.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC") or "mpiexec",
                   help="MPI launcher, may hold options (default $NUNO_MPIEXEC or mpiexec)")
    p.add_argument("--outdir", default=None,
                   help="where the runs and figures go (default runs/sweep_<stem>_<key>)")
    p.add_argument("--batch", choices=("local", "slurm"), default=None,
                   help="local: run here, -j at once; slurm: write <outdir>/submit.sh (a job "
                        "array of the runs and a plotting job after it) instead of running")
    p.add_argument("-j", "--jobs", type=int, default=1,
                   help="runs at once on this machine (default 1: one after the other)")
    p.add_argument("--submit", action="store_true", help="with --batch slurm: run submit.sh (sbatch)")
    p.add_argument("--sbatch-script", default=str(SBATCH_SCRIPT),
                   help="the job script (default tools/slurm/nuno.sbatch)")
    p.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    p.add_argument("--no-plots", action="store_true", help="only the runs")
    p.add_argument("--plots-only", action="store_true",
                   help="only the figures, from the files already in outdir")
    p.add_argument("--dpi", type=int, default=120, help="resolution of the figures (default 120)")
    return p


def _body(args):
    if args.ranks < 1:
        raise cli.UsageError(f"--ranks {args.ranks}: must be >= 1")
    if args.submit and args.batch != "slurm":
        raise cli.UsageError("--submit goes with --batch slurm")
    if args.jobs < 1:
        raise cli.UsageError(f"-j {args.jobs}: must be >= 1")
    if args.jobs > 1 and args.batch == "slurm":
        raise cli.UsageError("-j is for runs on this machine (--batch local); Slurm runs the "
                             "job array's tasks as it finds room")
    study = plan(args)
    outdir = Path(study["outdir"])
    if args.plots_only:
        if not plots(study, args.dpi):
            raise ValueError(f"{outdir}: no figures made (are the runs there?)")
        return
    if args.dry_run:
        exe = args.exe or os.environ.get("NUNO_EXE") or "nuno"
        for run in study["runs"]:
            print(shlex.join([*shlex.split(args.mpiexec), "-n", str(args.ranks), exe,
                              *nuno_args(study, run)]))
        return
    outdir.mkdir(parents=True, exist_ok=True)
    manifest = outdir / "sweep.json"
    if args.batch == "slurm":
        path = write_batch(study, find_exe(args.exe), Path(args.sbatch_script))
        manifest.write_text(json.dumps(study, indent=1) + "\n")
        print(f"sweep: a job array of {len(study['runs'])} runs and a plotting job in {path}")
        if args.submit:
            proc = subprocess.run(["bash", str(path)])
            if proc.returncode != 0:
                raise ValueError(f"{path}: exit {proc.returncode}")
        return
    exe = find_exe(args.exe)
    failed = run_local(study, exe, args.mpiexec, args.jobs)
    manifest.write_text(json.dumps(study, indent=1) + "\n")
    if not args.no_plots:
        plots(study, args.dpi)
    if failed:
        raise ValueError(f"{len(failed)} of {len(study['runs'])} runs failed: {', '.join(failed)}")


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
