# SPDX-License-Identifier: BSD-2-Clause
"""tools/slurm/nuno.sbatch, the example batch job (issue 38 item 4), run as
plain bash under stub sbatch/srun/scontrol commands on PATH: the first job
checkpoints by wall clock (-nuno_checkpoint_walltime), SIGTERM from Slurm is
passed on and the job requeued, a requeued job continues the file
(-nuno_restart), other endings are not requeued; a task of a job array
(--runs, nuno-sweep's) takes its line of the runs file. The last test runs the
real program through the script: interrupted, requeued, continued, complete."""
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec, read_run

SCRIPT = ROOT / "tools" / "slurm" / "nuno.sbatch"

# srun: records its arguments one a line; STUB_SRUN=sleep waits for a signal
# (SIGTERM: exit 1, as an interrupted run does), STUB_SRUN=fail exits 3,
# STUB_SRUN=mpi runs the real program under mpiexec on 2 ranks, passing
# SIGTERM to the ranks as srun does.
SRUN = """#!/usr/bin/env bash
printf '%s\\n' "$@" > "$STUB_LOG/srun.args"
case "${STUB_SRUN:-ok}" in
  ok) exit 0 ;;
  fail) exit 3 ;;
  sleep) trap 'echo TERM >> "$STUB_LOG/srun.signals"; exit 1' TERM
         echo started > "$STUB_LOG/srun.started"
         for i in $(seq 600); do sleep 0.1; done; exit 0 ;;
  mpi) # srun passes a signal to the tasks at once (mpiexec would wait
       # odls_base_sigkill_timeout first): so does this stub, to the ranks.
       $STUB_MPIEXEC -n 2 --oversubscribe "$@" &
       m=$!
       trap 'pkill -TERM -P "$m"' TERM
       wait "$m"; rc=$?
       while kill -0 "$m" 2>/dev/null; do wait "$m"; rc=$?; done
       exit $rc ;;
esac
"""
# scontrol: records its arguments. sbatch: runs the job script at once in the
# submit directory as Slurm would, with the job's variables.
SCONTROL = """#!/usr/bin/env bash
echo "$@" >> "$STUB_LOG/scontrol.calls"
"""
SBATCH = """#!/usr/bin/env bash
while [[ $# -gt 0 && $1 == -* ]]; do shift; done
export SLURM_JOB_ID=${STUB_JOB_ID:-4242} SLURM_SUBMIT_DIR=$PWD SLURM_NTASKS=2
export SLURM_RESTART_COUNT=${STUB_RESTART_COUNT:-0}
exec bash "$@"
"""


@pytest.fixture
def stubs(tmp_path):
    bin_dir = tmp_path / "stubs"
    bin_dir.mkdir()
    for name, text in (("srun", SRUN), ("scontrol", SCONTROL), ("sbatch", SBATCH),
                       ("nuno", "#!/bin/sh\nexit 0\n")):
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    logs = tmp_path / "logs"
    logs.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    (work / "case.nml").write_text("&scene scene='hang' /\n")
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", STUB_LOG=str(logs),
               NUNO_EXE=str(bin_dir / "nuno"), STUB_MPIEXEC=mpiexec())
    env.pop("SLURM_JOB_ID", None)
    return env, work, logs


def submit(env, work, *args, restart=0, mode="ok", **kw):
    env = dict(env, STUB_RESTART_COUNT=str(restart), STUB_SRUN=mode)
    return subprocess.Popen(["sbatch", "--ntasks=2", str(SCRIPT), "case.nml", "out.h5", *args],
                            cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **kw)


def srun_args(logs):
    return (logs / "srun.args").read_text().splitlines()


def test_first_job_checkpoints_by_wall_clock_and_is_not_requeued_when_done(stubs):
    env, work, logs = stubs
    proc = submit(env, work, "-ts_type", "cn", "-nuno_set", "e_s=2.0,t_end=0.5")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    args = srun_args(logs)
    assert args[0] == env["NUNO_EXE"] and args[1] == "case.nml"
    assert args[args.index("-nuno_checkpoint_walltime") + 1] == "1h"
    # one -nuno_set (PETSc keeps the last of two): the output file and the user's keys
    assert args.count("-nuno_set") == 1
    assert args[args.index("-nuno_set") + 1] == "output_file='out.h5',e_s=2.0,t_end=0.5"
    assert "-nuno_restart" not in args and args[-2:] == ["-ts_type", "cn"]
    assert not (logs / "scontrol.calls").exists()
    assert "run complete" in out


def test_sigterm_is_passed_on_and_the_job_requeued(stubs):
    env, work, logs = stubs
    proc = submit(dict(env, NUNO_CHECKPOINT_WALLTIME="23h"), work, mode="sleep")
    deadline = time.time() + 30
    while not (logs / "srun.started").exists() and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)          # what --signal=B:TERM@300 sends
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert (logs / "srun.signals").read_text().split() == ["TERM"]
    assert (logs / "scontrol.calls").read_text().split() == ["requeue", "4242"]
    assert "23h" in srun_args(logs)


def test_requeued_job_continues_the_file(stubs):
    env, work, logs = stubs
    (work / "out.h5").write_bytes(b"")        # the first job's file
    proc = submit(env, work, restart=1)
    proc.communicate(timeout=60)
    args = srun_args(logs)
    assert proc.returncode == 0
    assert args[args.index("-nuno_restart") + 1] == "out.h5"


def test_failed_run_is_not_requeued(stubs):
    env, work, logs = stubs
    proc = submit(env, work, mode="fail")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 3 and "not requeued" in err
    assert not (logs / "scontrol.calls").exists()
    proc = subprocess.run(["bash", str(SCRIPT), "case.nml"], cwd=work, env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stderr.startswith("usage: sbatch")


def test_array_task_takes_its_line_of_the_runs_file(stubs):
    """--runs RUNS.txt (nuno-sweep's job array): task k runs with the shell
    words of line k (from 0), quotes kept; without a task id, or past the
    last line, the job stops with one line and no run."""
    env, work, logs = stubs
    (work / "runs.txt").write_text(
        "case.nml a.h5 -nuno_set e_s=1\n"
        "case.nml 'b c.h5' -nuno_set \"scene='hang',e_s=2\" -ts_type cn\n")
    proc = subprocess.run(["bash", str(SCRIPT), "--runs", "runs.txt"], cwd=work,
                          env=dict(env, SLURM_ARRAY_TASK_ID="1", SLURM_JOB_ID="9"),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    args = srun_args(logs)
    assert args[1] == "case.nml"
    assert args[args.index("-nuno_set") + 1] == "output_file='b c.h5',scene='hang',e_s=2"
    assert args[-2:] == ["-ts_type", "cn"]
    (logs / "srun.args").unlink()
    for task, code, message in ((None, 2, "needs a job array"), ("2", 1, "no line 2 in runs.txt")):
        run_env = dict(env, SLURM_JOB_ID="9")
        if task is not None:
            run_env["SLURM_ARRAY_TASK_ID"] = task
        proc = subprocess.run(["bash", str(SCRIPT), "--runs", "runs.txt"], cwd=work, env=run_env,
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == code and message in proc.stderr, proc.stderr
        assert not (logs / "srun.args").exists()


NAMELIST = """&scene scene='hang' /
&lattice nx=9 ny=9 /
&time t_end=0.6 dt=2e-3 /
&output output_interval=0.02 /
"""


def test_real_run_interrupted_requeued_and_continued(stubs):
    """hang 9 x 9 on 2 ranks (300 steps, seconds) through the script: SIGTERM to the job script
    mid-run gives an interrupted file with a checkpoint and a requeue; the
    requeued job continues it to t_end: one series, complete, one restart."""
    env, work, logs = stubs
    env = dict(env, NUNO_EXE=exe())
    (work / "case.nml").write_text(NAMELIST)
    proc = submit(env, work, mode="mpi")
    seen = 0
    while seen < 3:                            # the time loop is running
        line = proc.stdout.readline()
        assert line, proc.stderr.read()
        seen += line.startswith("t =")
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "requeueing job 4242" in out
    assert (logs / "scontrol.calls").read_text().split() == ["requeue", "4242"]
    first = read_run(str(work / "out.h5"))
    assert first.status.startswith("interrupted: SIGTERM") and first.time[-1] < 0.6
    first.close()
    proc = submit(env, work, restart=1, mode="mpi")
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, out + err
    assert (logs / "scontrol.calls").read_text().split() == ["requeue", "4242"]  # not again
    run = read_run(str(work / "out.h5"))
    assert run.complete and int(run.run_info["restarts"]) == 1
    # one series: every output time of the grid once (plus the state the
    # interrupted job stopped at), increasing, to t_end
    t = np.asarray(run.time)
    assert np.all(np.diff(t) > 0) and t[-1] == pytest.approx(0.6)
    grid = 0.02 * np.arange(31)
    assert np.min(np.abs(t[:, None] - grid[None, :]), axis=0).max() < 1e-9
    assert len(t) <= len(grid) + 1
