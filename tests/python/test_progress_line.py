# SPDX-License-Identifier: BSD-2-Clause
"""The progress line printed between output steps (after 10 s of wall time
without a line) shows a rate and an ETA, as the output step's line does:
sim_per_wall_s = t / wall_s and eta_s = (t_end - t) / sim_per_wall_s,
checked here by arithmetic on the line's own t and wall_s and the t_end of
the input. The output step's line at t = 0, before any step, has no rate
yet: '-' for both. The run (hang 21 x 21 with tiny steps and one output
interval longer than the run) is stopped by SIGTERM as soon as the line
between output steps is seen."""
import re
import signal
import subprocess
import time

import pytest

from nunorun import exe, mpiexec, namelist

T_END = 5.0
NUM = r"([-+0-9.EeNaInf]+)"


def test_line_between_output_steps_has_rate_and_eta(tmp_path):
    (tmp_path / "slow.nml").write_text(namelist(
        "slow.h5", scene="scene='hang'", lattice="nx=21 ny=21", time=f"t_end={T_END} dt=1e-4",
        output=f"output_interval={T_END} write_velocity=.false."))
    proc = subprocess.Popen([mpiexec(), "-n", "1", exe(), "slow.nml"], cwd=tmp_path, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    line, seen = None, []
    deadline = time.time() + 120
    try:
        for out in proc.stdout:
            seen.append(out)
            if "(between output steps)" in out:
                line = out
                break
            if time.time() > deadline:
                break
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
    assert line is not None, "no progress line between output steps:\n" + "".join(seen[-20:])
    start = [ln for ln in seen if ln.startswith("t =")]
    assert len(start) == 1 and float(start[0].split()[2]) == 0.0, seen
    assert start[0].split()[-4:] == ["sim_per_wall_s", "-", "eta_s", "-"], start[0]
    fields = {}
    for key in ("t =", "steps", "dt", "wall_s", "sim_per_wall_s", "eta_s"):
        m = re.search(r"(?:^|\s)" + re.escape(key) + r"\s+" + NUM, line)
        assert m, f"no {key!r} in: {line}"
        fields[key] = float(m.group(1))
    t, wall = fields["t ="], fields["wall_s"]
    assert 0 < t < T_END and wall >= 10.0, line
    rate, eta = fields["sim_per_wall_s"], fields["eta_s"]
    assert rate == pytest.approx(t / wall, rel=2e-3), line            # printed with 4 digits
    assert eta == pytest.approx((T_END - t) / rate, rel=5e-3), line
    assert eta > 0
