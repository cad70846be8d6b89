# SPDX-License-Identifier: BSD-2-Clause
"""SIGTERM and SIGINT, what batch schedulers send before SIGKILL (issue 8
item 3): every rank finishes the step it is in, the last state is written,
the file says 'interrupted: ...' (that word first), and the run exits
non-zero within seconds. Sent to mpiexec (which forwards it to the ranks)
and to the ranks themselves (as Slurm's scancel does)."""
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from nunorun import read_run, signal_env, start_running


def start(tmp_path, name, interval=0.005):
    # Long enough that it is still running when the signal comes; two
    # progress lines after t = 0: the time loop is running.
    return start_running(tmp_path, name, env=signal_env(), scene="scene='hang'", lattice="nx=33 ny=33",
                         time="t_end=50 dt=1e-3", output=f"output_interval={interval}")


def finish(proc, h5, signame, t_sent):
    out, err = proc.communicate(timeout=60)
    assert time.time() - t_sent < 20, "took too long to stop"
    assert proc.returncode != 0
    assert f"interrupted: {signame} at t =" in err, err
    r = read_run(str(h5))
    assert r.status.startswith("interrupted: " + signame), r.status
    assert not r.complete
    assert r.time[-1] > 0.005 and len(r.time) >= 2
    assert np.all(np.isfinite(np.asarray(r.position[-1])))
    # The last state is the one after the step the run stopped at, not an
    # output-grid time only.
    assert r.time[-1] < 50


def test_sigterm_to_mpiexec_gives_an_interrupted_file(tmp_path):
    proc, h5 = start(tmp_path, "term")
    t0 = time.time()
    proc.send_signal(signal.SIGTERM)
    finish(proc, h5, "SIGTERM", t0)


def test_sigterm_to_mpiexec_with_a_line_every_step(tmp_path):
    # mpirun stops reading the ranks' stdout when it gets SIGTERM and
    # forwards it 1 s later: a line every step (1e-3 s, some hundred steps
    # a second) fills rank 0's pty (about 16 kB) in that second, and its
    # write blocks. The forwarded signal must still end the run with its
    # state and checkpoint written, not leave it to mpirun's SIGKILL.
    proc, h5 = start(tmp_path, "chatty", interval=1e-3)
    t0 = time.time()
    proc.send_signal(signal.SIGTERM)
    finish(proc, h5, "SIGTERM", t0)


def test_sigint_to_the_ranks_gives_an_interrupted_file(tmp_path):
    proc, h5 = start(tmp_path, "int")
    kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    ranks = [int(k) for k in kids
             if "nuno" in open(f"/proc/{k}/cmdline", "rb").read().decode(errors="replace")]
    if len(ranks) != 2:
        proc.kill()
        pytest.skip(f"could not find the 2 rank processes under mpiexec (found {kids})")
    t0 = time.time()
    for pid in ranks:
        os.kill(pid, signal.SIGINT)
    finish(proc, h5, "SIGINT", t0)
