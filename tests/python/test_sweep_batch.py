# SPDX-License-Identifier: BSD-2-Clause
"""nuno-sweep's batch modes (issue 48 item 3), run end to end.

--batch slurm under stub Slurm commands on PATH: the stub sbatch records its
arguments, prints a job id and runs the job script at once in the submit
directory with the job's variables (each task of an --array, with
SLURM_ARRAY_TASK_ID), and runs a job with --dependency=afterok:ID only when
every task of job ID exited 0 (Slurm would leave it pending; with
--kill-on-invalid-dep it is cancelled); the stub srun runs the program under
mpiexec. The submitting environment has no NUNO_EXE and no nuno on PATH,
as the issue's user had: the jobs must find the executable from what
submit.sh exports. --batch local -j N: a stub launcher records when each
run starts and ends, so how many ran at once is measured, not assumed."""
from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from nunorun import ROOT, exe, mpiexec, read_run
from test_postprocess import assert_png

SBATCH = r"""#!/usr/bin/env bash
echo "$*" >> "$STUB_LOG/sbatch.calls"
array= dep= ntasks=1 parsable=0
while [[ $# -gt 0 && $1 == -* ]]; do
  case $1 in
    --array=*) array=${1#--array=} ;;
    --dependency=*) dep=${1#--dependency=} ;;
    --ntasks=*) ntasks=${1#--ntasks=} ;;
    --parsable) parsable=1 ;;
  esac
  shift
done
id=$(( $(cat "$STUB_LOG/last_id" 2>/dev/null || echo 4100) + 1 ))
echo "$id" > "$STUB_LOG/last_id"
if [[ $parsable -eq 1 ]]; then echo "$id"; else echo "Submitted batch job $id"; fi
if [[ -n $dep ]]; then
  if [[ $dep != afterok:* || ! -f $STUB_LOG/ok.${dep#afterok:} ]]; then
    echo "$id $dep" >> "$STUB_LOG/never_run"
    exit 0
  fi
fi
export SLURM_JOB_ID=$id SLURM_SUBMIT_DIR=$PWD SLURM_NTASKS=$ntasks SLURM_RESTART_COUNT=0
ok=1
if [[ -n $array ]]; then
  for ((k = ${array%-*}; k <= ${array#*-}; k++)); do
    SLURM_ARRAY_JOB_ID=$id SLURM_ARRAY_TASK_ID=$k bash "$@" > "$STUB_LOG/job-$id-$k.log" 2>&1 || ok=0
  done
else
  bash "$@" > "$STUB_LOG/job-$id.log" 2>&1 || ok=0
fi
if [[ $ok -eq 1 ]]; then touch "$STUB_LOG/ok.$id"; fi
exit 0
"""
SRUN = r"""#!/usr/bin/env bash
printf '%s\n' "$@" > "$STUB_LOG/srun.${SLURM_ARRAY_TASK_ID:-0}.args"
if [[ ${STUB_SRUN:-mpi} == record ]]; then exit 0; fi
exec $STUB_MPIEXEC -n "$SLURM_NTASKS" --oversubscribe "$@"
"""
SCONTROL = """#!/usr/bin/env bash
echo "$@" >> "$STUB_LOG/scontrol.calls"
"""

CASE = """&scene scene='hang' /
&lattice nx=9 ny=9 /
&time t_end=0.1 dt=2e-3 /
&output output_interval=0.05 /
"""


@pytest.fixture
def slurm(tmp_path):
    """(env, work dir, log dir): stub sbatch/srun/scontrol first on PATH, no
    NUNO_EXE, no nuno on PATH."""
    bin_dir = tmp_path / "stubs"
    bin_dir.mkdir()
    for name, text in (("sbatch", SBATCH), ("srun", SRUN), ("scontrol", SCONTROL)):
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    logs = tmp_path / "logs"
    logs.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    (work / "case.nml").write_text(CASE)
    path = [d for d in os.environ["PATH"].split(":")
            if d and not (Path(d) / "nuno").exists()]          # no nuno on PATH
    env = {k: v for k, v in os.environ.items() if k not in ("NUNO_EXE", "NUNO_MPIEXEC")}
    env.update(PATH=":".join([str(bin_dir), *path]), STUB_LOG=str(logs), STUB_MPIEXEC=mpiexec(),
               PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    for key in ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
                "OMPI_MCA_rmaps_base_oversubscribe"):
        env.setdefault(key, "1")
    return env, work, logs


def sweep(env, work, *args, timeout=600):
    return subprocess.run([sys.executable, "-m", "postprocess.sweep", "case.nml",
                           "--outdir", "out", *args], cwd=work, env=env,
                          capture_output=True, text=True, timeout=timeout)


def sbatch_calls(logs):
    return [shlex.split(line) for line in (logs / "sbatch.calls").read_text().splitlines()]


def test_slurm_sweep_is_one_array_and_a_plot_job_after_it(slurm):
    """dt = 4e-3, 2e-3, 1e-3 of hang 9 x 9 on 2 ranks, submitted: one sbatch
    --array=0-2 of tools/slurm/nuno.sbatch, then one sbatch with
    --dependency=afterok:<the array's id>; every task ran the absolute
    executable on its own file, and the plotting job drew the sweep's
    figures from the three complete files."""
    env, work, logs = slurm
    nuno = str(Path(exe()).resolve())
    proc = sweep(env, work, "--dt", "4e-3,2e-3,1e-3", "-n", "2", "--exe", exe(),
                 "--batch", "slurm", "--submit")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    calls = sbatch_calls(logs)
    assert len(calls) == 2, calls
    first, second = calls
    assert "--array=0-2" in first and "--ntasks=2" in first
    assert Path(first[first.index("--runs") - 1]) == ROOT / "tools" / "slurm" / "nuno.sbatch"
    array_id = (logs / "last_id").read_text().split()[0]
    array_id = str(int(array_id) - 1)                  # the array was the first job
    assert f"--dependency=afterok:{array_id}" in second, second
    assert second[-1] == "plots.sbatch"
    assert not (logs / "never_run").exists()
    outdir = work / "out"
    for k, dt in enumerate(("4e-3", "2e-3", "1e-3")):
        args = (logs / f"srun.{k}.args").read_text().splitlines()
        assert args[0] == nuno, args                   # the exported absolute path
        assert args[1] == str((work / "case.nml").resolve())
        run = read_run(outdir / f"case_dt-{dt}.h5")
        assert run.complete and run.run_info["dt"] == pytest.approx(float(dt))
    plot_log = (logs / f"job-{int(array_id) + 1}.log").read_text()
    assert "sweep: nuno-convergence " in plot_log, plot_log
    for name in ("compare.png", "timeseries.png", "convergence.png"):
        assert_png(outdir / name)
    study = json.loads((outdir / "sweep.json").read_text())
    assert [r["file"] for r in study["runs"]] == [f"case_dt-{v}.h5" for v in ("4e-3", "2e-3", "1e-3")]


def test_slurm_jobs_find_the_executable_without_nuno_on_path(slurm, tmp_path):
    """No --exe, no NUNO_EXE, no nuno on PATH (the issue's user): the sweep
    finds the checkout's build/nuno and submit.sh exports its absolute path,
    which every task hands to srun; without any executable it says so
    before writing jobs."""
    env, work, logs = slurm
    built = ROOT / "build" / "nuno"
    proc = sweep(dict(env, STUB_SRUN="record"), work, "--set", "e_s=1,2", "--batch", "slurm",
                 "--submit")
    if not built.is_file():
        assert proc.returncode == 1 and "no nuno executable" in proc.stderr
        return
    assert proc.returncode == 0, proc.stdout + proc.stderr
    submit = (work / "out" / "submit.sh").read_text()
    assert f"export NUNO_EXE={shlex.quote(str(built.resolve()))}" in submit.splitlines()
    for k in (0, 1):
        assert (logs / f"srun.{k}.args").read_text().splitlines()[0] == str(built.resolve())
        log = next(logs.glob(f"job-*-{k}.log")).read_text()
        assert "no nuno executable" not in log and "run complete" in log, log


def test_plot_job_waits_for_every_run(slurm):
    """A run that fails (e_s = -1 is refused at input) keeps the plotting job
    from running: its dependency is afterok, not afterany."""
    env, work, logs = slurm
    proc = sweep(env, work, "--set", "e_s=1.0,-1.0", "--exe", exe(), "--batch", "slurm", "--submit")
    assert proc.returncode == 0, proc.stderr
    (never,) = (logs / "never_run").read_text().splitlines()
    assert never.split()[1].startswith("afterok:")
    assert not (work / "out" / "compare.png").exists()
    assert "--kill-on-invalid-dep=yes" in sbatch_calls(logs)[1]


LAUNCHER = r"""#!/usr/bin/env bash
# a stub mpiexec: records when this run starts and ends; the run with e_s=3 fails
set -u
tag=$(printf '%s\n' "$@" | grep -o "output_file='[^']*'" || echo "?")
echo "start $(date +%s.%N) $tag" >> "$STUB_LOG/launch"
sleep 1
echo "end $(date +%s.%N) $tag" >> "$STUB_LOG/launch"
case "$*" in *e_s=3,*) exit 3 ;; esac
exit 0
"""


def most_at_once(path):
    """The largest number of runs between their start and end at one time."""
    events = []
    for line in path.read_text().splitlines():
        kind, t, _ = line.split(maxsplit=2)
        events.append((float(t), 1 if kind == "start" else -1))
    level = peak = 0
    for _, step in sorted(events, key=lambda e: (e[0], e[1])):   # an end before a start at a tie
        level += step
        peak = max(peak, level)
    return peak


@pytest.mark.parametrize("jobs", [1, 2, 3])
def test_local_batch_runs_n_at_once(slurm, tmp_path, jobs):
    """Five runs of about 1 s each: -j N has at most N, and at some time N,
    running at once; every run is reported, the failed one named."""
    env, work, logs = slurm
    launcher = tmp_path / "launch.sh"
    launcher.write_text(LAUNCHER)
    launcher.chmod(0o755)
    proc = sweep(env, work, "--set", "e_s=1,2,3,4,5", "--batch", "local", "-j", str(jobs),
                 "--exe", "/bin/true", "--mpiexec", str(launcher), "--no-plots")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert proc.stderr == "error: 1 of 5 runs failed: case_e_s-3\n"
    assert sorted(ln.split(":")[1].split()[0] for ln in proc.stdout.splitlines()
                  if ln.startswith("sweep: ")) == ["1/5", "2/5", "3/5", "4/5", "5/5"]
    assert most_at_once(logs / "launch") == jobs
    assert len((logs / "launch").read_text().splitlines()) == 10


def test_batch_options_are_checked(slurm):
    env, work, _ = slurm
    for args, message in ((("-j", "0"), "-j 0: must be >= 1"),
                          (("--batch", "slurm", "-j", "2", "--exe", "/bin/true"), "-j is for runs on this machine"),
                          (("--batch", "local", "--submit"), "--submit goes with --batch slurm")):
        proc = sweep(env, work, "--set", "e_s=1,2", *args)
        assert proc.returncode == 1 and proc.stderr.startswith("error: ") and message in proc.stderr, \
            proc.stderr
        assert proc.stderr.count("\n") == 1
