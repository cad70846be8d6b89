# SPDX-License-Identifier: BSD-2-Clause
"""Checkpoint and restart (issue 8 item 2): a run continued from a checkpoint
with -nuno_restart must equal the run that went through, to the solver's
round-off for fixed-step backward Euler (the restart starts the solver's
aids afresh, where the run went on with them through its output steps:
issue 48), to the integrator's tolerance for adaptive and multistep
methods and other rank counts; SIGTERM leaves a file that can be
continued; the wall-clock trigger changes nothing in the result; a
half-written (invalid) checkpoint slot is never used; a restart that cannot
be done says why in one line and leaves the file as it was. A step too
small to advance t (continued at t = 1e6 with dt below t's resolution
there) ends the run with a one-line error on every rank's exit instead of
repeating forever.

The expectation is always another run (the continuous one), never the
program's own numbers pasted in."""
import hashlib
import signal

import h5py
import numpy as np
import pytest

from nunorun import SERIES, assert_same_run, run, series, start_running

HANG = dict(scene="scene='hang'", lattice="nx=9 ny=7", time="t_end=0.2 dt=0.005",
            output="output_interval=0.05 write_velocity=.true.")
def restart(tmp_path, name, h5, nranks=2, options=(), check=True, **groups):
    """Run the input `name` again with -nuno_restart h5."""
    return run(tmp_path, name, nranks=nranks, options=["-nuno_restart", str(h5), *options], check=check, **groups)


def checkpoints(h5):
    with h5py.File(h5, "r") as f:
        return sorted((int(g.attrs["sequence"]), float(g.attrs["time"]), g.attrs["reason"].decode())
                      for g in f["checkpoint"].values())


# A restart of fixed-step backward Euler: the run that went through to
# round-off (measured: 1e-15 here, 1e-12 on hang 65 x 65).
ROUND_OFF = 1e-11


def test_restart_equals_the_continuous_run_to_round_off(tmp_path):
    _, full = run(tmp_path, "full", nranks=2, **HANG)
    half_groups = dict(HANG, time="t_end=0.1 dt=0.005")
    _, half = run(tmp_path, "half", nranks=2, **half_groups)
    assert checkpoints(half)[-1][1:] == (0.1, "end")
    proc, _ = restart(tmp_path, "half", half, nranks=2, **HANG)
    assert "restart from checkpoint 1 at t = 1.00000E-01 (end)" in proc.stdout
    a, sa = series(full)
    b, sb = series(half)
    assert sa == sb == "complete"
    assert a.keys() == b.keys() == set(SERIES)
    assert_same_run(a, b, ROUND_OFF)
    with h5py.File(half, "r") as f:
        assert int(f["run"].attrs["restarts"]) == 1
        assert float(f["run/restart_1"].attrs["from_time"]) == 0.1
        # The wall time goes on from the first run's, it does not start again.
        w = f["wall_time"][:]
        assert np.all(np.diff(w) >= 0)


def test_a_restart_after_a_failed_newton_solve_backtracks_from_its_first_step(tmp_path):
    """The run's first Newton solve is failed on purpose (-nuno_fail_newton 1):
    from the retried step on it backtracks (-nuno_linesearch_fallback bt),
    and so does its continuation from the checkpoint at t = 0.1, from its
    first step (PETSc's line search monitor prints a line per Newton
    iteration only where a line search runs); it ends where the continuous
    run ends, to the integrator's error: after the retried step (dt/4) the
    steps no longer end on the output times, so the run that ends at 0.1
    cuts its last step short and its continuation takes other steps than
    the run that went through (before issue 48 every output time was a stop
    that put the steps back onto it)."""
    mon = ["-snes_linesearch_monitor"]
    proc_full, full = run(tmp_path, "full", nranks=2, options=["-nuno_fail_newton", "1", *mon], **HANG)
    assert "line search bt from t = " in proc_full.stdout
    half_groups = dict(HANG, time="t_end=0.1 dt=0.005")
    run(tmp_path, "half", nranks=2, options=["-nuno_fail_newton", "1"], **half_groups)
    proc, half = restart(tmp_path, "half", tmp_path / "half.h5", nranks=2, options=mon, **HANG)
    assert "line search bt from t = 1.00000E-01" in proc.stdout
    a, _ = series(full)
    b, _ = series(half)
    newton_after = int(b["diagnostics/newton_iterations"][-1] - b["diagnostics/newton_iterations"][2])
    assert proc.stdout.count("Line search:") == newton_after > 0
    np.testing.assert_array_equal(a["time"], b["time"])
    assert np.array_equal(a["position"][:2], b["position"][:2])              # the same steps to t = 0.05
    err = np.abs(a["position"] - b["position"]).max()
    assert err < 1e-3, err                                                   # measured 9.7e-5 (dt = 5 ms)


def test_restart_on_other_ranks_and_adaptive_bdf_agrees_to_tolerance(tmp_path):
    adaptive = ["-ts_type", "bdf", "-ts_adapt_type", "basic", "-ts_rtol", "1e-7", "-ts_atol", "1e-7"]
    _, full = run(tmp_path, "full", nranks=1, options=adaptive, **HANG)
    _, half = run(tmp_path, "half", nranks=3, options=adaptive, **dict(HANG, time="t_end=0.1 dt=0.005"))
    restart(tmp_path, "half", half, nranks=2, options=adaptive, **HANG)
    a, _ = series(full)
    b, _ = series(half)
    assert np.array_equal(a["time"], b["time"])
    # Up to t = 0.05 the same steps were taken (other ranks: other
    # preconditioner blocks, so the same solution to the solver's tolerance).
    assert np.abs(a["position"][:2] - b["position"][:2]).max() < 1e-8
    # At t = 0.1 the half run's last step ends (t_end), where the full run's
    # output step is bdf's interpolant between its steps: the same solution
    # to the integrator's tolerance.
    assert np.abs(a["position"][2] - b["position"][2]).max() < 1e-6
    # After it the restarted bdf starts again at first order: the same
    # solution to the integrator's tolerance (cloth size 1).
    err = np.abs(a["position"] - b["position"]).max()
    assert 0 < err < 1e-5, err


def test_sigterm_leaves_a_file_that_continues_to_the_same_result(tmp_path):
    # Long enough (2000 steps, some seconds) that the signal finds the run
    # running: at t_end = 1 it took 1.1 s and sometimes ended first.
    groups = dict(scene="scene='hang'", lattice="nx=15 ny=15", time="t_end=4 dt=0.002",
                  output="output_interval=0.05")
    _, full = run(tmp_path, "full", nranks=2, **groups)
    proc, h5 = start_running(tmp_path, "term", **groups)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode != 0 and "interrupted: SIGTERM" in err, err
    ck = checkpoints(h5)
    assert ck[-1][2] == "SIGTERM" and 0.1 <= ck[-1][1] < 4
    _, status = series(h5)
    assert status.startswith("interrupted: SIGTERM")
    proc2, _ = restart(tmp_path, "term", h5, nranks=2, **groups)
    a, _ = series(full)
    b, status = series(h5)
    assert status == "complete"
    # The interrupted run wrote its last state off the output grid; the
    # restart's series holds it as well, then the grid from there on.
    on_grid = np.isin(b["time"], a["time"])
    assert np.array_equal(b["time"][on_grid], a["time"])
    err = np.abs(a["position"] - b["position"][on_grid]).max()
    assert err < 1e-9, err


def test_wall_clock_checkpoints_change_nothing(tmp_path):
    groups = dict(scene="scene='hang'", lattice="nx=21 ny=21", time="t_end=0.4 dt=0.002",
                  output="output_interval=0.1")
    _, plain = run(tmp_path, "plain", nranks=2, **groups)
    # A checkpoint after (nearly) every step: TSSolve ends after the step,
    # the driver writes it and goes on in the same window; the run must be
    # the same bit for bit.
    short = dict(groups, time="t_end=0.2 dt=0.002")
    _, plain_short = run(tmp_path, "plain_short", nranks=2, **short)
    proc, often = run(tmp_path, "often", nranks=2, options=["-nuno_checkpoint_walltime", "1e-4s"], **short)
    assert proc.stdout.count("(wall time)") >= 50, proc.stdout
    ck = checkpoints(often)
    assert ck[-1][2] == "end" and ck[-2][2] == "wall time"
    a, _ = series(plain_short)
    b, _ = series(often)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    a, _ = series(plain)
    # Continue from the wall-clock one, taken after the last step but
    # before that step's output was written: the same run again, to the
    # solver's round-off (ROUND_OFF).
    with h5py.File(often, "r+") as f:
        for g in f["checkpoint"].values():
            if g.attrs["reason"] == b"end":
                g.attrs["sequence"] = np.int32(0)
    proc, _ = restart(tmp_path, "often", often, nranks=2, **groups)
    assert "(wall time) in" in proc.stdout
    b, status = series(often)
    assert status == "complete"
    assert_same_run(a, b, ROUND_OFF)


def test_wall_clock_checkpoints_change_no_adaptive_multistep_run(tmp_path):
    """The wall-clock checkpoint ends TSSolve after the step that is due and
    the driver calls it again in the same window: an adaptive bdf run (its
    history of steps, the step its controller chose) must go on as if
    nothing happened. Expectation: the same run without the checkpoints."""
    groups = dict(HANG, time="t_end=0.1 dt=0.005")
    opts = ["-ts_type", "bdf", "-ts_adapt_type", "basic"]
    _, plain = run(tmp_path, "plain", nranks=2, options=opts, **groups)
    proc, often = run(tmp_path, "often", nranks=2, options=opts + ["-nuno_checkpoint_walltime", "1e-4s"], **groups)
    assert proc.stdout.count("(wall time)") >= 10, proc.stdout
    a, _ = series(plain)
    b, status = series(often)
    assert status == "complete"
    for k in a:
        assert np.array_equal(a[k], b[k]), k


def test_a_half_written_checkpoint_is_never_used(tmp_path):
    groups = dict(HANG, output=HANG["output"] + " checkpoint_interval=0.05")
    _, full = run(tmp_path, "full", nranks=2, **HANG)
    proc, h5 = run(tmp_path, "ck", nranks=2, **dict(groups, time="t_end=0.15 dt=0.005"))
    ck = checkpoints(h5)
    assert [round(t, 12) for _, t, _ in ck] == [0.1, 0.15], ck   # two slots: the last two
    # As a kill during the last checkpoint would leave it: invalid.
    with h5py.File(h5, "r+") as f:
        for g in f["checkpoint"].values():
            if abs(g.attrs["time"] - 0.15) < 1e-12:
                g.attrs["sequence"] = np.int32(0)
    proc, _ = run(tmp_path, "ck", nranks=3, options=["-nuno_restart", str(h5)], **groups)
    assert "at t = 1.00000E-01 (checkpoint_interval)" in proc.stdout, proc.stdout
    a, _ = series(full)
    b, _ = series(h5)
    # The steps after t = 0.1 were cut and computed again, to t_end = 0.2
    # (on 3 ranks instead of 2: to the solver's tolerance).
    assert np.array_equal(a["time"], b["time"])
    assert np.abs(a["position"] - b["position"]).max() < 1e-8


def md5(path):
    return hashlib.md5(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("case", ["missing", "no_checkpoint", "lattice", "not_later", "velocity", "walltime"])
def test_a_restart_that_cannot_be_done_says_why_and_changes_nothing(tmp_path, case):
    _, h5 = run(tmp_path, "r", nranks=2, **HANG)
    groups = dict(HANG)
    target = h5
    if case == "missing":
        target = tmp_path / "nothere.h5"
        expect = "nothere.h5: no such file"
    elif case == "no_checkpoint":
        with h5py.File(h5, "r+") as f:
            del f["checkpoint"]
        expect = "no valid checkpoint in it"
    elif case == "lattice":
        groups["lattice"] = "nx=9 ny=9"
        expect = "its lattice is nx = 9, ny = 7, the input's nx = 9, ny = 9"
    elif case == "not_later":
        expect = "not before t_end = 2.00000E-01: nothing to continue"
    elif case == "velocity":
        groups["output"] = "output_interval=0.05 write_velocity=.false."
        groups["time"] = "t_end=0.3 dt=0.005"
        expect = "write_velocity = .false. but the file was written with .true."
    else:
        groups["time"] = "t_end=0.3 dt=0.005"
        expect = "-nuno_checkpoint_walltime 5x: not a wall-clock duration"
    before = md5(h5)
    opts = ["-nuno_restart", str(target)] + (["-nuno_checkpoint_walltime", "5x"] if case == "walltime" else [])
    proc, _ = run(tmp_path, "bad", nranks=3, options=opts, check=False, timeout=120, **groups)
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1 and expect in errors[0], proc.stderr
    assert md5(h5) == before


def test_steps_that_do_not_advance_t_end_the_run(tmp_path):
    """A flat sheet at rest (no forces: every step converges at once) run to
    t = 1e6, then continued with dt = 1e-11, below the spacing of doubles
    at 1e6 (1.16e-10): t + dt == t, every step is accepted and t never
    moves. Without the stall guard TSSolve repeated that step until killed
    (a guard asked for in the TS monitor was undone by TSStep); now ten
    such steps end the run: a non-zero exit, one error line naming t and
    the step, the file marked failed with its output so far intact."""
    groups = dict(scene="scene='flat'", time="t_end=1.0e6 dt=1.0e5", output="output_interval=1.0e6")
    _, h5 = run(tmp_path, "far", nranks=2, **groups)
    proc, _ = restart(tmp_path, "far", h5, nranks=2, check=False, timeout=120,
                      options=["-nuno_set", "t_end=2.0e6,dt=1.0e-11", "-nuno_allow_long"], **groups)
    assert proc.returncode != 0
    errors = [line for line in proc.stderr.splitlines() if line.startswith("nuno: error:")]
    assert len(errors) == 1, proc.stderr[-2000:]
    assert "ten accepted steps at t = 1.00000E+06 did not advance t" in errors[0]
    assert "1.00000E-11" in errors[0]
    assert "nuno: failed at t =  1.00000E+06" in proc.stdout
    with h5py.File(h5, "r") as f:
        assert f.attrs["status"].decode().startswith("failed: ten accepted steps")
        assert int(f.attrs["n_output_steps"]) == 2
        assert list(f["time"][:2]) == [0.0, 1.0e6]
