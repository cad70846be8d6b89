# SPDX-License-Identifier: BSD-2-Clause
"""The start-up memory check must never refuse a run that fits: its bytes a
node (src/input/input_limits.f90, quoted by --help) must stay below what a real
run takes. Measured here: the peak resident set of one-rank runs of the
leanest path (-snes_type ksponly), hang scene, 129 x 129 and 17 x 17 (the
per-process cost), a few steps; the difference over the extra nodes is the
measured peak a node."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from nunorun import exe, namelist

TIME = shutil.which("time", path="/usr/bin:/bin")
pytestmark = pytest.mark.skipif(TIME is None, reason="GNU time (/usr/bin/time) is not installed")
STEPS = ["-ts_max_steps", "3", "-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3"]


def peak_rss_bytes(tmp_path, n, bending):
    """Peak resident set of one run of nuno, by GNU time (%M, KiB). Not
    os.wait4 on a child of this process: a child's peak counts the memory of
    the Python process it was forked from, which GNU time's child does not
    carry (it is forked from the small time process)."""
    name = f"m{n}{bending}"
    (tmp_path / f"{name}.nml").write_text(namelist(
        f"{name}.h5",
        scene="scene='hang'", lattice=f"nx={n} ny={n}", material=f"bending_model='{bending}'"))
    proc = subprocess.run([TIME, "-f", "peak %M", exe(), f"{name}.nml", *STEPS], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return int(re.findall(r"^peak (\d+)$", proc.stderr, re.M)[-1]) * 1024


def estimate_bytes_per_node():
    """(with bending, without) from --help: 'at least A KB a node with
    bending, B KB without'."""
    text = subprocess.run([exe(), "--help"], capture_output=True, text=True, timeout=60).stdout
    m = re.search(r"at least ([0-9.]+) KB a node with\s+bending, ([0-9.]+) KB without", text)
    assert m, "the --help text quotes the memory estimate"
    return float(m.group(1)) * 1000, float(m.group(2)) * 1000


@pytest.mark.parametrize("bending", ["energy", "none"])
def test_memory_estimate_is_below_a_real_runs_peak(tmp_path, bending):
    with_bending, without = estimate_bytes_per_node()
    estimate = with_bending if bending != "none" else without
    small, large = 17, 129
    base = peak_rss_bytes(tmp_path, small, bending)
    peak = peak_rss_bytes(tmp_path, large, bending)
    per_node = (peak - base) / (large * large - small * small)
    # Measured 3.9 KB with bending, 2.4 KB without (src/input/input_limits.f90).
    assert 1000 < per_node < 20000, per_node
    assert estimate <= per_node, (
        f"the memory check takes {estimate:.0f} B a node, but a real run ({bending} bending, "
        f"{large} x {large}, 1 rank, -snes_type ksponly) peaks at {per_node:.0f} B a node: "
        "it could refuse a run that fits")
