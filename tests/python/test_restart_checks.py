# SPDX-License-Identifier: BSD-2-Clause
"""Restarts that are what they say (issue 37 items 5, 7, 9, 14).

- A restart with the default options repeats the run it continues bit for
  bit: hang 65 x 65 (the multigrid's lattice) on 2 ranks, 120 fixed steps,
  continued from an end-of-run checkpoint, from a SIGTERM checkpoint and
  from another end-of-run checkpoint, against the run that went through.
- A corrupted checkpoint (a NaN time, a NaN state, a time past the series,
  counters that are not counts) is refused in one line on every rank's exit,
  and the file is left byte for byte as it was.
- A namelist of another scene or model on the same lattice is refused by
  the name of the key that differs, the file unchanged.
- The first checkpoint_interval checkpoint comes one interval after the
  start, not at the first output step.

The expectations are another run (the continuous one), the user's file
bytes and the interval's multiples, never the program's own numbers."""
import hashlib
import os
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest

from nunorun import SERIES, assert_same_run, exe, mpiexec, namelist, run, series

def checkpoints(h5):
    with h5py.File(h5, "r") as f:
        return sorted((int(g.attrs["sequence"]), float(g.attrs["time"]), g.attrs["reason"].decode())
                      for g in f["checkpoint"].values())


def md5(path):
    return hashlib.md5(path.read_bytes()).hexdigest()


def one_error(proc):
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr[-3000:]
    return errors[0]


# --- item 7: with the default options, the run that went through ----------

BIG = dict(scene="scene='hang'", lattice="nx=65 ny=65", time="t_end=0.24 dt=0.002",
           output="output_interval=0.02 write_velocity=.true.")


def restart_sigterm(tmp_path, name, groups, after_lines=3):
    """Continue name.h5 with -nuno_restart and send SIGTERM to its ranks
    once it has printed `after_lines` progress lines: returns (stdout, stderr, rc)."""
    nml = tmp_path / f"{name}.nml"
    nml.write_text(namelist(f"{name}.h5", **groups))
    proc = subprocess.Popen([mpiexec(), "-n", "2", "--oversubscribe", exe(), str(nml), "-nuno_restart", f"{name}.h5"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen, out = 0, []
    deadline = time.time() + 120
    while seen < after_lines and time.time() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        out.append(line)
        seen += line.startswith("t =")
    kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    ranks = [int(k) for k in kids
             if "nuno" in open(f"/proc/{k}/cmdline", "rb").read().decode(errors="replace")]
    # As Slurm's scancel does: to the ranks themselves (mpiexec forwards a
    # signal to it only after a delay); to mpiexec where they are not found.
    for pid in ranks or [proc.pid]:
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    rest, err = proc.communicate(timeout=120)
    return "".join(out) + rest, err, proc.returncode


def test_restart_with_the_default_options_is_the_same_run_at_65(tmp_path):
    """Continued three times (from an end-of-run, a SIGTERM and another
    end-of-run checkpoint): the run that went through, to the solver's
    round-off (measured 1.1e-12 of the largest value; bit for bit before
    issue 48, when every output step started the solver's aids afresh as a
    restart does, and so changed the solution with output_interval)."""
    _, full = run(tmp_path, "full", nranks=2, **BIG)
    # 1. an end-of-run checkpoint at t = 0.06
    _, h5 = run(tmp_path, "leg", nranks=2, **dict(BIG, time="t_end=0.06 dt=0.002"))
    assert checkpoints(h5)[-1][1:] == (0.06, "end")
    # 2. continued towards 0.24, stopped by SIGTERM
    out, err, rc = restart_sigterm(tmp_path, "leg", BIG)
    points = [0.06]
    if rc != 0:
        assert "interrupted: SIGTERM" in err, err[-2000:]
        seq, t_sig, reason = checkpoints(h5)[-1]
        assert reason == "SIGTERM" and 0.06 < t_sig < 0.24
        points.append(t_sig)
        # 3. from the SIGTERM checkpoint to an end-of-run checkpoint at 0.18
        if t_sig < 0.18 - 1e-9:
            proc, _ = run(tmp_path, "leg", nranks=2, options=["-nuno_restart", str(h5)],
                          **dict(BIG, time="t_end=0.18 dt=0.002"))
            assert "(SIGTERM) in" in proc.stdout
            points.append(0.18)
        # 4. on to 0.24
        proc, _ = run(tmp_path, "leg", nranks=2, options=["-nuno_restart", str(h5)], **BIG)
    else:
        # the run ended before the signal: still one restart point
        assert "complete" in out
    a, sa = series(full)
    b, sb = series(h5)
    assert sa == sb == "complete"
    for k in SERIES:
        assert a[k].shape == b[k].shape, (k, points)
    assert_same_run(a, b, 1e-10)
    assert len(points) >= 2, "SIGTERM did not find the run running"


# --- item 5: a corrupted checkpoint is refused ----------------------------

SMALL = dict(scene="scene='hang'", lattice="nx=9 ny=7", time="t_end=0.3 dt=0.005",
             output="output_interval=0.05 write_velocity=.true.")


def newest_slot(f):
    return max(f["checkpoint"].values(), key=lambda g: int(g.attrs["sequence"]))


@pytest.mark.parametrize("case", ["nan_time", "nan_state", "nan_start_state", "time_past_series", "counters"])
def test_a_corrupted_checkpoint_is_refused_and_the_file_unchanged(tmp_path, case):
    _, h5 = run(tmp_path, "c", nranks=2, **SMALL)
    with h5py.File(h5, "r+") as f:
        g = newest_slot(f)
        if case == "nan_time":
            g.attrs["time"] = np.nan
            expect = "its time is NaN"
        elif case == "nan_state":
            p = g["position"][...]
            p[-1, -1, 2] = np.nan      # the last row: on the last rank only
            g["position"][...] = p
            expect = "its state (position or velocity) is not finite"
        elif case == "nan_start_state":
            v = g["start_velocity_2"][...]
            v[0, 0, 0] = np.nan
            g["start_velocity_2"][...] = v
            expect = "a Newton start state in it is not finite"
        elif case == "time_past_series":
            g.attrs["time"] = 0.5      # its state and output steps end at 0.3
            expect = "its time 0.5 is past"
        else:
            c = g.attrs["counters"]
            c[2] = 1.5
            g.attrs["counters"] = c
            expect = "are not counts"
    before = md5(h5)
    proc, _ = run(tmp_path, "c", nranks=3, options=["-nuno_restart", str(h5)], check=False, timeout=120,
                  **dict(SMALL, time="t_end=0.4 dt=0.005"))
    assert proc.returncode != 0
    line = one_error(proc)
    assert "is not valid" in line and expect in line and "unchanged" in line, line
    assert md5(h5) == before


# --- item 9: another scene or model on the same lattice -------------------

@pytest.mark.parametrize("group,change,key", [
    ("scene", "scene='hang' gravity=0.0,0.0,-1.62", "&scene gravity"),
    ("material", "e_s=250.0", "&material e_s"),
    ("material", "bending_model='none'", "&material bending_model"),
    ("lattice", "nx=9 ny=7 lx=2.0", "&lattice lx"),
])
def test_a_restart_of_another_scene_is_refused_by_name(tmp_path, group, change, key):
    _, h5 = run(tmp_path, "s", nranks=2, **SMALL)
    before = md5(h5)
    groups = dict(SMALL, time="t_end=0.4 dt=0.005")
    groups[group] = change
    proc, _ = run(tmp_path, "s2", nranks=2, options=["-nuno_restart", str(h5)], check=False, timeout=120,
                  **groups)
    assert proc.returncode != 0
    line = one_error(proc)
    assert key in line and "is not the file's" in line, line
    assert md5(h5) == before


def test_the_same_scene_with_another_dt_and_t_end_still_restarts(tmp_path):
    """Only the scene and the model are checked: the step and the end time
    are the restart's to choose."""
    _, h5 = run(tmp_path, "s", nranks=2, **SMALL)
    proc, _ = run(tmp_path, "s", nranks=2, options=["-nuno_restart", str(h5)],
                  **dict(SMALL, time="t_end=0.4 dt=0.0025"))
    assert series(h5)[1] == "complete"


# --- item 14: the first checkpoint_interval checkpoint ---------------------

def test_the_first_interval_checkpoint_comes_one_interval_after_the_start(tmp_path):
    groups = dict(SMALL, output="output_interval=0.05 checkpoint_interval=0.1")
    proc, _ = run(tmp_path, "i", nranks=2, **groups)
    times = [float(ln.split("at t =")[1].split()[0]) for ln in proc.stdout.splitlines()
             if ln.startswith("nuno: checkpoint") and "(checkpoint_interval)" in ln]
    assert np.allclose(times, [0.1, 0.2]), proc.stdout


# --- issue 48 item 4: -nuno_restart needs its file --------------------------

@pytest.mark.parametrize("options", [["-nuno_restart"], ["-nuno_restart", "-ts_monitor"]])
def test_a_restart_without_its_file_is_refused_and_the_file_kept(tmp_path, options):
    """-nuno_restart with no file name (last on the line, or before another
    option) started a fresh run, which replaced the file it was meant to
    continue; it is refused on every rank before anything is written."""
    _, h5 = run(tmp_path, "s", nranks=2, **SMALL)
    before = md5(h5)
    proc, _ = run(tmp_path, "s", nranks=2, options=options, check=False, timeout=120, **SMALL)
    assert proc.returncode != 0
    line = one_error(proc)
    assert "-nuno_restart needs the file" in line, line
    assert md5(h5) == before
    assert not (tmp_path / "s.h5.partial").exists()
