# SPDX-License-Identifier: BSD-2-Clause
"""Input that cannot be mistaken and output files that cannot be lost (issue 8
items 1 and 4, issue 9 item 5), on 3 ranks under a time bound.

Every refused input must give exactly one line on stderr (Open MPI's own
banner is switched off with OMPI_MCA_orte_execute_quiet, so whatever else is
there came from us: no ERROR STOP, no backtrace, no HDF5 error stack, no
line per rank), a non-zero exit, and no output file. An earlier output file
must keep its bytes when a new run fails before its first successful step,
and a second writer of the same file must stop before touching it."""
import fcntl
import hashlib
import os
import subprocess
import time
from pathlib import Path

import h5py
import pytest

from nunorun import exe, mpiexec

SMALL = "&lattice nx=5 ny=6 /\n&time t_end=0.02 dt=0.01 /\n"


def launch(tmp_path, args, nranks=3, timeout=120):
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), *args]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=timeout, env=env)


def one_error_line(proc):
    """The single stderr line of a refused run (asserts there is exactly one)."""
    assert proc.returncode != 0, proc.stdout[-2000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("nuno: error"), lines[0]
    for noise in ("ERROR STOP", "Backtrace", "HDF5-DIAG", "#0"):
        assert noise not in proc.stdout + proc.stderr
    return lines[0]


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


# --------------------------------------------------------------------------
# Input that cannot be mistaken

BAD_INPUTS = {
    "empty": (b"", ["empty"]),
    "blanks_only": (b"  \n\n\t\n", ["empty"]),
    "comments_only": (b"! a comment\n  ! another\n", ["no namelist group"]),
    "text_outside": (b"! ok\n&time dt=0.01 /\nhello world\n", ["line 3", "hello world"]),
    "text_after_group": (b"&time dt=0.01 / junk\n", ["line 1", "junk"]),
    "nan_gravity": (b"&scene gravity = 0 0 NaN /\n", ["gravity(3) = NaN", "finite"]),
    "inf_omega": (b"&scene scene='flat' initial_omega = 0 0 Inf /\n", ["initial_omega(3) = +Infinity"]),
    "nan_keyframe_dz": (b"&scene scene='wave_point' keyframe_dz(2) = NaN /\n", ["keyframe_dz(2) = NaN"]),
    "inf_t_end": (b"&time t_end = Inf /\n", ["t_end = +Infinity"]),
    "tiny_dt": (b"&time dt = 1e-12 /\n", ["dt = 1.0E-12", "steps", "-nuno_allow_long"]),
    "tiny_output_interval": (b"&output output_interval = 1e-9 /\n",
                             ["output_interval = 1.0E-09", "output steps", "-nuno_allow_long"]),
    "index_overflow": (b"&lattice nx = 2000000000 /\n",
                       ["nx = 2000000000", "ny = 11", "1.32E+11", "2147483647"]),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_one_line_every_rank_fails(tmp_path, case):
    text, words = BAD_INPUTS[case]
    (tmp_path / "in.nml").write_bytes(text)
    proc = launch(tmp_path, ["in.nml"])
    line = one_error_line(proc)
    for w in words:
        assert w in line, line
    assert not list(tmp_path.glob("*.h5*"))


def test_binary_garbage_is_refused_in_printable_text(tmp_path):
    data = bytes(range(256)) * 4
    (tmp_path / "garbage.nml").write_bytes(data)
    line = one_error_line(launch(tmp_path, ["garbage.nml"]))
    assert "line 1" in line and "outside a namelist group" in line
    assert all(32 <= ord(c) < 127 for c in line), repr(line)
    assert not list(tmp_path.glob("*.h5*"))


def test_byte_order_mark_is_not_text(tmp_path):
    """A UTF-8 byte-order mark (some Windows editors write one) before the
    first group: the file runs as without it (the mark was skipped, and the
    group after it then refused as text outside a group); the same bytes
    anywhere else are still text."""
    body = SMALL + "&output output_file='bom.h5' /\n"
    (tmp_path / "bom.nml").write_bytes(b"\xef\xbb\xbf" + body.encode())
    proc = launch(tmp_path, ["bom.nml"])
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "bom.h5").exists()
    (tmp_path / "late.nml").write_bytes(b"\n\xef\xbb\xbf" + body.encode())
    line = one_error_line(launch(tmp_path, ["late.nml"]))
    assert "line 2" in line and "outside a namelist group" in line


def test_allow_long_lifts_only_the_step_bound(tmp_path):
    """-nuno_allow_long passes the step bound; the next check (the index
    space) then stops the run, so the option is seen and nothing runs long."""
    (tmp_path / "in.nml").write_bytes(b"&time dt = 1e-12 /\n&lattice nx = 2000000000 /\n")
    line = one_error_line(launch(tmp_path, ["in.nml"]))
    assert "-nuno_allow_long" in line
    line = one_error_line(launch(tmp_path, ["in.nml", "-nuno_allow_long"]))
    assert "nx = 2000000000" in line and "steps" not in line


def test_step_bound_uses_the_ts_dt_that_overrides_dt(tmp_path):
    (tmp_path / "in.nml").write_text(SMALL + "&output output_file='x.h5' /\n")
    line = one_error_line(launch(tmp_path, ["in.nml", "-ts_dt", "1e-11"]))
    assert "-ts_dt 1.0E-11" in line and "-nuno_allow_long" in line
    line = one_error_line(launch(tmp_path, ["in.nml", "-ts_dt", "nan"]))
    assert "-ts_dt NaN" in line
    assert not list(tmp_path.glob("*.h5*"))


def test_bad_option_value_is_one_line(tmp_path):
    """A PETSc error seen by every rank (a misspelt -ts_type) is one line
    with PETSc's reason, not a 30-line report from each rank."""
    (tmp_path / "ok.nml").write_text(SMALL + "&output output_file='x.h5' /\n")
    line = one_error_line(launch(tmp_path, ["ok.nml", "-ts_type", "no_such_method"]))
    assert "Unknown TS type: no_such_method" in line
    assert not list(tmp_path.glob("*.h5*"))


def _mem_available():
    for ln in Path("/proc/meminfo").read_text().splitlines():
        if ln.startswith("MemAvailable:"):
            return int(ln.split()[1]) * 1024
    return None


def test_lattice_beyond_memory_is_refused_before_allocation(tmp_path):
    avail = _mem_available()
    nodes = 15000 * 15000                      # 6 nodes < 2^31: the index check passes
    per_node = 3000                            # B, with bending (src/input/input_limits.f90)
    if avail is None or nodes * per_node < 2 * avail:
        pytest.skip("this host has memory for the test lattice")
    (tmp_path / "in.nml").write_bytes(b"&lattice nx = 15000 ny = 15000 /\n")
    t0 = time.monotonic()
    line = one_error_line(launch(tmp_path, ["in.nml"]))
    assert time.monotonic() - t0 < 60
    for w in ("nx = 15000", "ny = 15000", f"{nodes * per_node / 1e9:.1f} GB", f"{per_node / 1e3:.1f} KB a node",
              "available"):
        assert w in line, line


def test_help_names_the_new_option(tmp_path):
    proc = launch(tmp_path, ["--help"], nranks=1)
    assert proc.returncode == 0 and "-nuno_allow_long" in proc.stdout
    # PETSc's -help lists it from its options block, with its default.
    (tmp_path / "ok.nml").write_text(SMALL + "&output output_file='ok.h5' /\n")
    proc = launch(tmp_path, ["ok.nml", "-help"], nranks=1)
    assert proc.returncode == 0, proc.stderr
    assert "-nuno_allow_long: <FALSE" in proc.stdout


# --------------------------------------------------------------------------
# Safe files

def first_run(tmp_path, name="run"):
    """A complete run whose file the later runs must not destroy."""
    (tmp_path / f"{name}.nml").write_text(SMALL + f"&output output_file='{name}.h5' output_interval=0.01 /\n")
    proc = launch(tmp_path, [f"{name}.nml"])
    assert proc.returncode == 0, proc.stderr
    h5 = tmp_path / f"{name}.h5"
    with h5py.File(h5, "r") as f:
        assert f.attrs["status"].decode() == "complete"
    assert not (tmp_path / f"{name}.h5.partial").exists()
    assert not (tmp_path / f"{name}.h5.lock").exists()
    assert (tmp_path / f"{name}.xdmf").exists()
    return h5, digest(h5), digest(tmp_path / f"{name}.xdmf")


def test_output_file_may_not_be_the_input(tmp_path):
    text = "&lattice nx=5 ny=6 /\n&output output_file='same.nml' /\n"
    (tmp_path / "same.nml").write_text(text)
    line = one_error_line(launch(tmp_path, ["same.nml"]))
    assert "same.nml" in line and "input file" in line
    assert (tmp_path / "same.nml").read_text() == text
    # The same file by another spelling.
    (tmp_path / "sub").mkdir()
    text = "&lattice nx=5 ny=6 /\n&output output_file='../sub/./x.nml' /\n"
    (tmp_path / "sub" / "x.nml").write_text(text)
    line = one_error_line(launch(tmp_path / "sub", ["x.nml"]))
    assert "input file" in line
    assert (tmp_path / "sub" / "x.nml").read_text() == text
    assert not list(tmp_path.rglob("*.h5*"))


def test_first_step_failure_keeps_the_earlier_file(tmp_path):
    h5, before, xmf_before = first_run(tmp_path)
    # Same output name, a first step that fails (a bending triple at theta = pi).
    (tmp_path / "bad.nml").write_text(
        "&scene scene='bend_release' bend_angle=359.9999 /\n&lattice nx=3 ny=4 /\n"
        "&time t_end=0.1 dt=0.01 /\n&output output_file='run.h5' output_interval=0.05 /\n")
    proc = launch(tmp_path, ["bad.nml"], nranks=2)
    assert proc.returncode != 0
    assert digest(h5) == before
    assert digest(tmp_path / "run.xdmf") == xmf_before
    with h5py.File(tmp_path / "run.h5.partial", "r") as f:   # the failed attempt, kept aside
        assert f.attrs["status"].decode().startswith("failed")
    assert not (tmp_path / "run.h5.lock").exists()


def test_startup_failure_keeps_the_earlier_file(tmp_path):
    h5, before, _ = first_run(tmp_path)
    proc = launch(tmp_path, ["run.nml", "-ts_type", "no_such_method"])
    assert proc.returncode != 0
    assert digest(h5) == before


def test_a_good_rerun_replaces_the_file(tmp_path):
    h5, before, _ = first_run(tmp_path)
    (tmp_path / "run.nml").write_text(SMALL.replace("t_end=0.02", "t_end=0.03")
                                      + "&output output_file='run.h5' output_interval=0.01 /\n")
    proc = launch(tmp_path, ["run.nml"])
    assert proc.returncode == 0, proc.stderr
    with h5py.File(h5, "r") as f:
        assert f.attrs["status"].decode() == "complete"
        assert int(f.attrs["n_output_steps"]) == 4
    assert digest(h5) != before
    assert not (tmp_path / "run.h5.partial").exists()
    assert not (tmp_path / "run.h5.lock").exists()


def test_locked_output_stops_a_second_writer(tmp_path):
    h5, before, _ = first_run(tmp_path)
    with open(tmp_path / "run.h5.lock", "w") as lock:     # as another nuno would hold it
        lock.write("pid 4242 on elsewhere\n")
        lock.flush()
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        line = one_error_line(launch(tmp_path, ["run.nml"]))
    assert "run.h5" in line and "another run" in line and "pid 4242 on elsewhere" in line
    assert digest(h5) == before
    assert not (tmp_path / "run.h5.partial").exists()


def test_two_concurrent_runs_one_writer(tmp_path):
    """A real second nuno on the same file while the first one runs."""
    (tmp_path / "long.nml").write_text(
        "&scene scene='hang' /\n&time t_end=2.0 /\n&output output_file='same.h5' output_interval=0.1 /\n")
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    first = subprocess.Popen([mpiexec(), "-n", "1", exe(), "long.nml"], cwd=tmp_path, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "same.h5.partial").exists() and not (tmp_path / "same.h5").exists():
            assert first.poll() is None and time.monotonic() < deadline, "first run did not start"
            time.sleep(0.1)
        if first.poll() is not None:
            pytest.skip("the first run ended before the second could start")
        second = launch(tmp_path, ["long.nml"], nranks=2)
        still_running = first.poll() is None
        out, err = first.communicate(timeout=600)
    finally:
        if first.poll() is None:
            first.kill()
    if not still_running:
        pytest.skip("the first run ended while the second started")
    line = one_error_line(second)
    assert "same.h5" in line and "another run" in line
    assert first.returncode == 0, err
    with h5py.File(tmp_path / "same.h5", "r") as f:
        assert f.attrs["status"].decode() == "complete"
        assert int(f.attrs["n_output_steps"]) == 21
        assert int(f.attrs["n_ranks"]) == 1


def test_missing_directory_names_file_and_cause(tmp_path):
    (tmp_path / "in.nml").write_text(SMALL + "&output output_file='no_dir/x.h5' /\n")
    line = one_error_line(launch(tmp_path, ["in.nml"]))
    assert "no_dir/x.h5" in line and "No such file or directory" in line


def _kill_session(proc):
    """SIGKILL mpiexec and its ranks (Open MPI gives each rank its own
    process group, but they stay in the session that Popen started)."""
    ps = subprocess.run(["ps", "-o", "pid=", "--sid", str(proc.pid)], capture_output=True, text=True)
    for pid in [int(p) for p in ps.stdout.split()]:
        try:
            os.kill(pid, 9)
        except ProcessLookupError:
            pass
    proc.wait(timeout=30)


def _check_readable(path):
    """A file a kill left behind: opens, never 'complete' unless it is, and
    every step it counts is there and finite. Returns n_output_steps."""
    import numpy as np
    with h5py.File(path, "r") as f:
        status = f.attrs["status"].decode()
        n = int(f.attrs["n_output_steps"])
        assert status in ("running", "complete"), status
        if status == "complete":
            assert n == 21
        assert f["position"].shape[0] >= n and f["time"].shape[0] >= n
        assert np.isfinite(f["position"][:n]).all() and np.isfinite(f["time"][:n]).all()
        assert (np.diff(f["time"][:n]) > 0).all()
    return n


def test_kill_9_at_random_times_leaves_readable_files(tmp_path):
    import random
    rng = random.Random(8)
    (tmp_path / "k.nml").write_text(
        "&scene scene='hang' /\n&time t_end=1.0 /\n&output output_file='k.h5' output_interval=0.05 /\n")
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    for delay in [rng.uniform(0.3, 6.0) for _ in range(3)]:
        proc = subprocess.Popen([mpiexec(), "-n", "2", exe(), "k.nml"], cwd=tmp_path, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                start_new_session=True)
        time.sleep(delay)
        _kill_session(proc)
        reported = sum(ln.startswith("t =") for ln in proc.stdout.read().splitlines())
        counts = [_check_readable(p) for p in (tmp_path / "k.h5", tmp_path / "k.h5.partial") if p.exists()]
        # A step printed as written is in a file; once a step after the first
        # one is reported, the run's file has taken the final name, unless
        # an earlier k.h5 (a run before) is kept until this run completes.
        if reported >= 1:
            assert counts and max(counts) >= reported
    # The lock of a killed run died with it: the next run is not refused.
    proc = launch(tmp_path, ["k.nml"], nranks=2, timeout=600)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / "k.h5", "r") as f:
        assert f.attrs["status"].decode() == "complete" and int(f.attrs["n_output_steps"]) == 21
    assert not (tmp_path / "k.h5.partial").exists() and not (tmp_path / "k.h5.lock").exists()
