# SPDX-License-Identifier: BSD-2-Clause
"""A run far outside the model's regime says so (issue 8 item 6): when a
link is stretched or compressed beyond stretch_limit (&output, default 5)
times its rest length, one warning names the time, the link and the
factor. The factor is checked against the stored positions."""
import re

import numpy as np

from nunorun import run, run_and_read

SPIN = dict(time="t_end=0.05 dt=1e-3", output="output_interval=0.01")


def max_link_ratio(x, rest):
    """Largest |x_p - x_q| / |X_p - X_q| over the 8-neighbour links; x, rest [ny][nx][3]."""
    best = 0.0
    for dj, di in ((0, 1), (1, 0), (1, 1), (1, -1)):
        ny, nx = x.shape[:2]
        j0, j1 = 0, ny - dj
        i0, i1 = max(0, -di), nx - max(0, di)
        a = x[j0:j1, i0:i1]
        b = x[j0 + dj:j1 + dj, i0 + di:i1 + di]
        ra = rest[j0:j1, i0:i1]
        rb = rest[j0 + dj:j1 + dj, i0 + di:i1 + di]
        best = max(best, (np.linalg.norm(b - a, axis=-1) / np.linalg.norm(rb - ra, axis=-1)).max())
    return best


def test_a_sheet_spun_apart_warns_once_with_the_right_factor(tmp_path):
    proc, r = run_and_read(tmp_path, "spin", nranks=2, scene="scene='flat' initial_omega=0,0,500", **SPIN)
    warn = [ln for ln in proc.stderr.splitlines() if "stretch_limit" in ln]
    assert len(warn) == 1, proc.stderr
    m = re.search(r"at t = *([0-9.E+-]+) .* by a factor *([0-9.E+-]+)", warn[0])
    t, factor = float(m.group(1)), float(m.group(2))
    k = int(np.argmin(np.abs(r.time - t)))
    assert abs(r.time[k] - t) < 1e-9
    expect = max_link_ratio(np.asarray(r.position[k]), np.asarray(r.rest_position))
    assert factor > 5 and abs(factor - expect) <= 1e-4 * expect, (factor, expect)
    # The output step before it was within the limit (warned at the first one beyond).
    assert max_link_ratio(np.asarray(r.position[k - 1]), np.asarray(r.rest_position)) <= 5


def test_no_warning_within_the_limit_or_when_off(tmp_path):
    proc, _ = run(tmp_path, "slow", nranks=2, scene="scene='flat' initial_omega=0,0,1", **SPIN)
    assert "stretch_limit" not in proc.stderr
    proc, _ = run(tmp_path, "off", nranks=2, scene="scene='flat' initial_omega=0,0,500",
                  time=SPIN["time"], output=SPIN["output"] + " stretch_limit=0")
    assert "stretch_limit" not in proc.stderr


def test_a_stretch_limit_below_one_is_refused(tmp_path):
    proc, h5 = run(tmp_path, "bad", nranks=3, check=False, scene="scene='flat'",
                   time=SPIN["time"], output=SPIN["output"] + " stretch_limit=0.5")
    assert proc.returncode != 0 and "stretch_limit = 0.5" in proc.stderr and not h5.exists()
