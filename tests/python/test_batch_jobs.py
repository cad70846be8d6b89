# SPDX-License-Identifier: BSD-2-Clause
"""Batch jobs as users run them (issue 9): PETSc options that are honoured
or refused, the fixed step after a retry, the progress line, and the
provenance recorded in the output file. Each test checks against values
worked out here (step counts, times, the state of an equivalent run), not
against the program's own report of itself."""
import datetime
import os
import re
import socket
import subprocess

import numpy as np
import pytest

from nunorun import ROOT, read_run, run, run_and_read

# A small moving scene: the fold of lift_release swings down, so states at
# different times differ and a lost or wrong last state is visible.
LIFT = dict(scene="scene='lift_release'", lattice="nx=5 ny=5")
DT = 1.0e-3


def lift(t_end, interval, dt=DT):
    return dict(LIFT, time=f"t_end={t_end!r} dt={dt!r}", output=f"output_interval={interval!r}")


def progress_lines(stdout):
    return [ln for ln in stdout.splitlines() if ln.startswith("t =")]


def fields(line):
    """The progress line as {name: value}: 't =' then blank-separated name
    value pairs; a value '-' (no rate yet at t = 0) as None."""
    words = line.split()
    assert words[:2] == ["t", "="], line
    out = {"t": float(words[2])}
    rest = words[3:]
    assert len(rest) % 2 == 0, line
    for name, value in zip(rest[::2], rest[1::2]):
        out[name] = None if value == "-" else float(value)
    return out


# --------------------------------------------------------------- -ts_max_steps

def test_ts_max_steps_ends_complete_with_the_last_state(tmp_path):
    """-ts_max_steps 5 inside the first output window: exit 0, status
    complete, the last written time 5 dt, and that state is the one a run to
    t_end = 5 dt ends in."""
    proc, r = run_and_read(tmp_path, "steps", nranks=2, options=("-ts_max_steps", "5"), **lift(0.02, 0.01))
    assert r.complete and r.status == "complete"
    assert r.time[-1] == pytest.approx(5 * DT, abs=1e-12)
    assert r.diagnostics["steps"][-1] == 5
    assert "-ts_max_steps 5 reached" in proc.stdout
    _, ref = run_and_read(tmp_path, "ref", nranks=2, **lift(5 * DT, 5 * DT))
    assert ref.time[-1] == pytest.approx(5 * DT, abs=1e-12)
    np.testing.assert_allclose(r.position[-1], ref.position[-1], rtol=0, atol=1e-10)
    assert not np.allclose(r.position[-1], r.position[0], atol=1e-6)   # it moved: the check can fail


def test_ts_max_steps_at_an_output_time(tmp_path):
    """The limit falling on an output time writes that step once."""
    _, r = run_and_read(tmp_path, "steps10", options=("-ts_max_steps", "10"), **lift(0.02, 0.005))
    assert r.complete
    np.testing.assert_allclose(r.time, [0.0, 0.005, 0.01], atol=1e-12)
    assert list(r.diagnostics["steps"]) == [0, 5, 10]


# ----------------------------------------------------- -ts_max_time and -ts_dt

def test_ts_max_time_wins_over_t_end_and_is_shown(tmp_path):
    proc, r = run_and_read(tmp_path, "tmax", options=("-ts_max_time", "0.004"), **lift(0.02, 0.01))
    assert r.complete
    # Output times are multiples of output_interval and the (effective) t_end.
    np.testing.assert_allclose(r.time, [0.0, 0.004], atol=1e-12)
    assert r.diagnostics["steps"][-1] == 4
    assert r.run_info["t_end"] == pytest.approx(0.004)
    solver = [ln for ln in proc.stdout.splitlines() if ln.startswith("solver    :")]
    assert len(solver) == 1 and "t_end = 4.00000E-03 (-ts_max_time; namelist 2.00000E-02)" in solver[0]


def test_ts_dt_is_the_effective_step(tmp_path):
    proc, r = run_and_read(tmp_path, "dt", options=("-ts_dt", "5e-4"), **lift(0.01, 0.01))
    assert r.complete and r.diagnostics["steps"][-1] == 20     # 0.01 / 5e-4
    assert r.run_info["dt"] == pytest.approx(5e-4)
    assert "dt = 5.00000E-04 (-ts_dt; namelist 1.00000E-03)" in proc.stdout


def test_non_matchstep_final_time_is_refused(tmp_path):
    proc, h5 = run(tmp_path, "eft", options=("-ts_exact_final_time", "stepover"), check=False, **lift(0.01, 0.01))
    assert proc.returncode != 0
    assert "-ts_exact_final_time must be matchstep" in proc.stdout + proc.stderr


# ------------------------------------------------------------- unused options

def test_a_misspelt_option_is_refused_before_the_run(tmp_path):
    """Said once, before the first step (issue 48 item 4; it was a warning
    at the end of the run): tests/python/test_input_options.py."""
    proc, h5 = run(tmp_path, "typo", nranks=2, options=("-ts_tpye", "cn"), check=False, **lift(0.002, 0.002))
    assert proc.returncode != 0 and not h5.exists()
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1 and "-ts_tpye cn" in errors[0] and "-ts_type" in errors[0], proc.stderr


def test_an_option_read_late_is_still_reported_at_the_end(tmp_path):
    """An option of a kind PETSc reads only during the run (here a viewer of
    a solver this run does not have) is reported at the end, once."""
    proc, r = run_and_read(tmp_path, "late", nranks=2, options=("-fieldsplit_0_ksp_view",), **lift(0.002, 0.002))
    assert r.complete
    warnings = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: warning:")]
    assert len(warnings) == 1 and "-fieldsplit_0_ksp_view" in warnings[0], proc.stderr


def test_used_options_are_not_reported(tmp_path):
    proc, _ = run_and_read(tmp_path, "used", options=("-ts_type", "cn", "-nuno_pc_lag", "2", "-log_view"),
                           **lift(0.002, 0.002))
    assert "nuno: warning" not in proc.stderr, proc.stderr


# ------------------------------------------------------- retries of fixed steps

def test_fixed_step_returns_to_dt_after_a_retry(tmp_path):
    """-nuno_fail_newton 1 fails the first Newton solve: the step is retried
    with dt/4 = 0.25 dt, then the run goes on with dt. Over t_end = 10 dt
    that is 0.25 + 9 x 1 + 0.75 (clipped to t_end): 11 steps; a step left at
    dt/4 would take 40."""
    proc, r = run_and_read(tmp_path, "retry", nranks=2, options=("-nuno_fail_newton", "1"), **lift(10 * DT, 10 * DT))
    assert r.complete
    assert r.diagnostics["rejected_steps"][-1] == 1
    assert r.diagnostics["steps"][-1] == 11
    last = fields(progress_lines(proc.stdout)[-1])
    assert last["retries"] == 1 and last["rejected"] == 1 and last["steps"] == 11
    assert "1 retried after a failed Newton solve" in proc.stdout
    # the closing line and /run say that the fixed steps were not all dt
    # (issue 48 item 5)
    closing = [ln for ln in proc.stdout.splitlines() if ln.startswith("nuno: complete")]
    assert len(closing) == 1 and "fixed steps: 1 retried smaller, so not every step was dt" in closing[0], closing
    assert r.run_info["retried_steps"] == 1
    # Two windows: 0.25 + 1 + 1 + 1, then PETSc's matchstep halves the rest
    # (0.875 + 0.875); the second window is back to 5 steps of dt.
    _, r2 = run_and_read(tmp_path, "retry2", options=("-nuno_fail_newton", "1"), **lift(10 * DT, 5 * DT))
    assert list(r2.diagnostics["steps"]) == [0, 6, 11]
    assert r2.run_info["retried_steps"] == 1


def test_fixed_steps_without_a_retry_say_nothing_of_it(tmp_path):
    proc, r = run_and_read(tmp_path, "plain", options=(), **lift(10 * DT, 10 * DT))
    assert r.run_info["retried_steps"] == 0 and r.diagnostics["steps"][-1] == 10
    assert "fixed steps:" not in proc.stdout


def test_help_says_what_fixed_steps_mean_when_a_step_is_retried(tmp_path):
    """--help said fixed steps are "the same whatever the solution", which a
    failed Newton solve (an impact with contact) breaks (issue 48 item 5)."""
    from nunorun import exe
    text = subprocess.run([exe(), "--help"], capture_output=True, text=True, timeout=60).stdout
    block = " ".join(text[text.index("reproducible runs"):].split())
    assert "unless a Newton solve fails" in block and "retried at dt/4" in block, block[:400]
    assert "/run retried_steps" in block


def test_line_search_falls_back_after_a_failed_newton_solve(tmp_path):
    """After the failed Newton solve of -nuno_fail_newton 1 (its step retried
    smaller) the run's remaining steps backtrack (bt) instead of taking full
    steps: PETSc's line search monitor, which full steps never print to,
    reports one line per Newton iteration of the 10 steps after the retry,
    and the run says so once. With -nuno_linesearch_fallback none no line
    search runs. bt accepts the full Newton steps of this smooth scene, so
    both runs end in the same state up to Newton's tolerance."""
    opts = ("-nuno_fail_newton", "1", "-snes_linesearch_monitor")
    proc, r = run_and_read(tmp_path, "fb", nranks=2, options=opts, **lift(10 * DT, 10 * DT))
    assert proc.stdout.count("line search bt from t = ") == 1
    searches = proc.stdout.count("Line search:")
    newton = fields(progress_lines(proc.stdout)[-1])["newton"]
    assert 10 <= searches <= newton, (searches, newton)
    proc0, r0 = run_and_read(tmp_path, "nofb", nranks=2, options=opts + ("-nuno_linesearch_fallback", "none"),
                             **lift(10 * DT, 10 * DT))
    assert "Line search:" not in proc0.stdout and "from t = " not in proc0.stdout
    assert r.complete and r0.complete
    np.testing.assert_allclose(r.position[-1], r0.position[-1], rtol=0, atol=1e-9)


# ------------------------------------------------------------- progress line

def test_progress_line_parses_and_matches_the_file(tmp_path):
    proc, r = run_and_read(tmp_path, "prog", **lift(0.004, 0.001))
    lines = progress_lines(proc.stdout)
    assert len(lines) == r.nt
    for line, t, ekin in zip(lines, r.time, r.energy["kinetic"]):
        # No number glued to the word before it (E_total-3.96E-06 broke awk).
        assert not re.search(r"[A-DF-Za-df-z_]-\d", line), line
        f = fields(line)
        assert f["t"] == pytest.approx(t, rel=1e-5, abs=1e-12)
        assert f["E_kin"] == pytest.approx(ekin, rel=1e-5, abs=1e-30)
        for name in ("steps", "rejected", "newton", "linear", "retries", "E_total", "wall_s",
                     "sim_per_wall_s", "eta_s"):
            assert name in f, (name, line)
    first, last = fields(lines[0]), fields(lines[-1])
    assert first["t"] == 0.0 and first["sim_per_wall_s"] is None and first["eta_s"] is None
    assert last["eta_s"] == 0.0 and last["sim_per_wall_s"] > 0
    walls = [fields(ln)["wall_s"] for ln in lines]
    assert walls == sorted(walls)
    np.testing.assert_allclose(r.wall_time, walls, rtol=1e-3, atol=2e-3)


def test_failure_message_goes_to_stderr(tmp_path):
    proc, _ = run(tmp_path, "fail", check=False, options=("-nuno_fail_newton", "100"), **lift(0.002, 0.002))
    assert proc.returncode != 0
    assert "nuno: error: time step from t =" in proc.stderr
    assert "nuno: error" not in proc.stdout


# --------------------------------------------------------------- provenance

def expected_commits():
    """What the build may have recorded: the short commit of the source tree
    (plus -dirty) or 'unknown' outside git."""
    src = os.environ.get("NUNO_SOURCE_DIR", str(ROOT))
    try:
        head = subprocess.run(["git", "-C", src, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        head = ""
    return head


def test_output_records_the_run(tmp_path):
    before = datetime.datetime.now(datetime.timezone.utc)
    _, r = run_and_read(tmp_path, "prov", nranks=2, options=("-ts_type", "bdf", "-ts_adapt_type", "basic"),
                        **lift(0.004, 0.002))
    info = r.run_info
    head = expected_commits()
    assert info["git_commit"] == "unknown" or (head and info["git_commit"] in (head, head + "-dirty")), \
        (info["git_commit"], head)
    assert "3.18" in info["petsc_version"]
    assert re.fullmatch(r"1\.\d+\.\d+", info["hdf5_version"]), info["hdf5_version"]
    assert info["ts_type"] == "bdf" and info["ts_adapt_type"] == "basic"
    assert info["n_ranks"] == 2 and r.n_ranks == 2
    assert info["host"].split(".")[0] == socket.gethostname().split(".")[0]
    start = datetime.datetime.fromisoformat(info["start_date"])
    assert before - datetime.timedelta(seconds=2) <= start <= datetime.datetime.now(datetime.timezone.utc)
    assert r.wall_time is not None and r.wall_time.shape == (r.nt,)
    assert np.all(np.diff(r.wall_time) >= 0) and 0 < r.wall_time[-1] <= info["wall_time"]


@pytest.mark.parametrize("scene, lattice, system, length", [
    ("flat", "nx=5 ny=5", "mm g s", "mm"),
    ("hang", "nx=5 ny=5", "SI", "m"),
])
def test_units_come_from_the_file(tmp_path, scene, lattice, system, length):
    _, r = run_and_read(tmp_path, scene, scene=f"scene='{scene}'", lattice=lattice,
                        time="t_end=0.002 dt=0.001", output="output_interval=0.002")
    assert r.unit_system == system and r.units() == length


def test_reader_prefers_the_units_attribute(tmp_path, make_run):
    """A hang-named file whose units attribute says mm is labelled mm: the
    attribute, not the scene name, decides."""
    import h5py
    path = tmp_path / "u.h5"
    make_run(path, scene="hang")
    assert read_run(path).units() == "m"          # old files: the guess
    with h5py.File(path, "r+") as f:
        f.attrs["units"] = np.bytes_(b"mm g s")
    assert read_run(path).units() == "mm"


def test_output_records_the_resolved_configuration(tmp_path):
    """/config holds every key as resolved: the namelist's, the scene's
    defaults for the rest (lift_release: 100 x 100, fold 30 up 15; input/
    README.md), and dt as overridden by -ts_dt."""
    _, r = run_and_read(tmp_path, "cfg", options=("-ts_dt", "5e-4"), **lift(0.002, 0.002))
    c = r.config
    assert c["lattice"]["nx"] == 5 and c["lattice"]["ny"] == 5
    assert c["lattice"]["lx"] == 100.0 and c["lattice"]["ly"] == 100.0
    assert c["scene"]["scene"] == "lift_release"
    assert c["scene"]["lift_length"] == 30.0 and c["scene"]["lift_height"] == 15.0
    np.testing.assert_array_equal(c["scene"]["gravity"], [0.0, 0.0, 0.0])
    assert c["time"]["t_end"] == pytest.approx(0.002) and c["time"]["dt"] == pytest.approx(5e-4)
    assert c["output"]["output_file"] == "cfg.h5" and c["output"]["write_velocity"] == 1
    assert c["material"]["bending_model"] in ("paper", "energy", "none")


def test_progress_reaches_a_redirected_file_while_running(tmp_path):
    """stdout redirected to a file (a batch job): each progress line is in
    the file as soon as it is printed, not when an 8 KiB buffer fills (some
    30 lines later, tens of seconds here). The first line after t = 0 must
    appear within a few seconds of its own wall_s."""
    import time
    from nunorun import exe, namelist
    nml = tmp_path / "long.nml"
    nml.write_text(namelist("long.h5", scene="scene='flat'", lattice="nx=5 ny=5",
                            time="t_end=1000.0 dt=1e-3", output="output_interval=2.0"))
    log = tmp_path / "long.out"
    with open(log, "w") as out:
        # Launched alone (a singleton): under mpiexec Open MPI gives ranks a
        # pty, which gfortran line-buffers anyway.
        start = time.monotonic()
        proc = subprocess.Popen([exe(), str(nml)], cwd=tmp_path,
                                stdout=out, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            first = None
            while time.monotonic() < start + 60 and proc.poll() is None:
                lines = [ln for ln in progress_lines(log.read_text()) if not ln.startswith("t = 0.00000E+00")]
                if lines:
                    first = (time.monotonic() - start, lines[0])
                    break
                time.sleep(0.1)
            assert proc.poll() is None, "the run ended: the check needs it still running"
            assert first is not None, "no progress line after t = 0 in the file after 60 s"
            elapsed, line = first
            assert elapsed - fields(line)["wall_s"] < 5.0, (elapsed, line)
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=30)
