# SPDX-License-Identifier: BSD-2-Clause
"""The integrator stops exactly at keyframe, release and output times,
whatever the step size or adaptivity (docs/model.md sections 4 and 5), and the
energy balance closes with the work of a prescribed node (wave_point)."""
import numpy as np
import pytest

from nunorun import run_and_read

WAVE = dict(scene="scene='wave_point'", lattice="nx=7 ny=6",
            time="t_end=1.3 dt=0.03", output="output_interval=0.1 write_velocity=.true.")


@pytest.mark.parametrize("options", [
    ("-ts_type", "beuler"),                                   # 0.5 / 0.03 is not an integer
    ("-ts_type", "bdf", "-ts_adapt_type", "basic", "-ts_rtol", "1e-4", "-ts_atol", "1e-4"),
    ("-ts_type", "arkimex", "-ts_adapt_type", "basic", "-ts_rtol", "1e-4", "-ts_atol", "1e-4"),
])
def test_prescribed_corner_hits_keyframes_exactly(tmp_path, options):
    _, r = run_and_read(tmp_path, "wave", options=options, **WAVE)
    assert r.complete
    np.testing.assert_allclose(r.time, np.arange(14) * 0.1, rtol=0, atol=1e-12)
    z = r.position[:, 0, 0, 2]
    vz = r.velocity[:, 0, 0, 2]
    k05, k10 = 5, 10
    assert abs(z[k05] - (-10.0)) < 1e-9          # keyframe 1: -10 mm at t = 0.5
    assert abs(z[k10] - 15.0) < 1e-9             # keyframe 2: +15 mm at t = 1.0
    assert abs(z[3] - (-6.0)) < 1e-9             # on the first segment at t = 0.3
    assert abs(z[-1] - 15.0) < 1e-9              # held after the last keyframe
    # velocity of the segment that ends at an output time; of the one that starts at t = 0
    assert abs(vz[0] - (-20.0)) < 1e-12
    assert abs(vz[k05] - (-20.0)) < 1e-12
    assert abs(vz[k10] - 50.0) < 1e-12
    assert abs(vz[-1]) < 1e-12
    # the rest of the corner stays where it was
    assert np.abs(r.position[:, 0, 0, :2] - r.position[0, 0, 0, :2]).max() < 1e-12


def test_energy_balance_closes_with_constraint_work(tmp_path):
    """Backward Euler's numerical dissipation aside, E_kin + E_stretch +
    E_dissipated - W_external stays at its initial value; with cn it is
    second-order accurate, so halving dt shrinks the error about 4 times."""
    errs = []
    for dt in (0.01, 0.005):
        groups = dict(WAVE, time=f"t_end=1.3 dt={dt}")
        _, r = run_and_read(tmp_path, f"bal{dt}", options=("-ts_type", "cn"), **groups)
        bal = r.energy_balance()
        scale = np.abs(r.energy["external_work"]).max()
        assert scale > 0.1
        errs.append(np.abs(bal - bal[0]).max() / scale)
    print("relative balance errors", errs)
    assert errs[1] < 5e-3
    assert errs[0] / errs[1] > 3.0, errs


def test_release_time_frees_the_pinned_corners(tmp_path):
    """hang with release_time: pinned until then, falling freely after."""
    _, r = run_and_read(tmp_path, "rel", scene="scene='hang' release_time=0.25", lattice="nx=5 ny=5",
                        time="t_end=0.5 dt=0.01", output="output_interval=0.05")
    corner = r.position[:, -1, 0, :]
    assert np.abs(corner[:6] - corner[0]).max() < 1e-12             # up to t = 0.25
    assert corner[-1, 2] < corner[0, 2] - 0.01                        # then it falls
    # momentum after release changes only by gravity: dp/dt = M g
    p = r.diagnostics["momentum"][:, 2]
    mtot = r.mass.sum()
    slope = (p[-1] - p[-3]) / (r.time[-1] - r.time[-3])
    assert abs(slope - mtot * (-9.81)) < 1e-6 * abs(mtot * 9.81)
