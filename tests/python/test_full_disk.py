# SPDX-License-Identifier: BSD-2-Clause
"""A disk that fills up (issue 8 item 6): at start-up or in mid-run, the run
ends collectively within seconds with one line naming the file and the
cause, exit 1 on every rank, and the file keeps every output step it
reported, marked failed, never complete. Before this, a full disk hung the
job in a collective HDF5 call (parallel HDF5 1.10 returns the error on some
ranks only).

A real full disk: a small tmpfs mounted for the test (needs root, as CI
runs; skipped where mounting is not allowed)."""
import os
import subprocess
import time

import h5py
import numpy as np
import pytest

from nunorun import exe, mpiexec, namelist


@pytest.fixture
def small_disk(tmp_path, request):
    mnt = tmp_path / "disk"
    mnt.mkdir()
    size = getattr(request, "param", "600k")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def run_on(disk, tmp_path, nranks):
    nml = tmp_path / "full.nml"
    h5 = disk / "full.h5"
    nml.write_text(namelist(str(h5), scene="scene='hang'", lattice="nx=21 ny=21",
                            time="t_end=2 dt=0.002", output="output_interval=0.01"))
    t0 = time.time()
    proc = subprocess.run([mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(nml)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    return proc, h5, time.time() - t0


def one_error_line(proc):
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


def test_a_disk_that_fills_up_in_mid_run_ends_the_run_with_one_line(small_disk, tmp_path):
    proc, h5, wall = run_on(small_disk, tmp_path, 2)
    assert proc.returncode != 0
    assert wall < 60
    line = one_error_line(proc)
    assert "no space left" in line and str(h5) in line, line
    with h5py.File(h5, "r") as f:
        status = f.attrs["status"].decode()
        n = int(f.attrs["n_output_steps"])
        assert status.startswith("failed: output: no space left"), status
        assert n >= 5
        # Every step it counts is there and is a state (the steps before
        # the full disk were reported on stdout, one line each).
        assert np.all(np.isfinite(f["position"][:n]))
        assert np.all(np.diff(f["time"][:n]) > 0)
    reported = [ln for ln in proc.stdout.splitlines() if ln.startswith("t =")]
    assert len(reported) == n


@pytest.mark.parametrize("small_disk", ["8k"], indirect=True)
def test_a_full_disk_at_start_up_is_one_line_and_no_hang(small_disk, tmp_path):
    proc, h5, wall = run_on(small_disk, tmp_path, 3)
    assert proc.returncode != 0
    assert wall < 60
    line = one_error_line(proc)
    assert "no space left for a new output file" in line, line
    assert not h5.exists()
