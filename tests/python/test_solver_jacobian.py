# SPDX-License-Identifier: BSD-2-Clause
"""The assembled Jacobian against PETSc's finite-difference Jacobian
(-snes_test_jacobian), on deformed, flat and moving states, for each force
model. A large step makes the shift a = 1/dt small, so that the force
Jacobian K/m, C/m dominates ||J|| and an error in it cannot hide behind the
a I blocks. The approximate Jacobians (-nuno_gauss_newton, clamped springs)
must FAIL the same check: that shows the check can fail."""
import pytest

from nunorun import jacobian_ratios, run

# One Newton iteration per step, always accepted: the check runs at the
# first Newton iterate of the first step, whatever happens next.
ONE_STEP = ("-snes_test_jacobian", "-snes_max_it", "1", "-snes_convergence_test", "skip",
            "-ts_max_snes_failures", "-1")

CASES = {
    # paper bending at the flat state: its Jacobian is not zero (docs/model.md 3)
    "flat_paper": dict(scene="scene='flat'", lattice="nx=5 ny=4",
                       material="bending_model='paper' e_s=1e-3 e_d=1e-3 eta_s=0 eta_d=0"),
    # the report's fold, paper bending, axial dampers (at rest)
    "lift_release_paper": dict(scene="scene='lift_release'", lattice="nx=6 ny=5"),
    # energy bending with bending damping on a bent, spinning cloth
    "bend_energy_moving": dict(scene="scene='bend_release' initial_omega=0.3,-0.2,0.5", lattice="nx=5 ny=5",
                               material="bending_model='energy' eta_b=0.7 e_s=1e-2 e_d=1e-2 eta_s=0.3 eta_d=0.2"),
    # energy bending at the flat state (smooth at theta = 0)
    "flat_energy": dict(scene="scene='flat'", lattice="nx=4 ny=5",
                        material="bending_model='energy' k_b=5 e_s=1e-3 e_d=1e-3"),
    # axial springs with moving dampers (the n (Q v)^T term), no bending
    "wave_axial_moving": dict(scene="scene='flat' initial_omega=0.5,0.4,0.9", lattice="nx=5 ny=4",
                              material="bending_model='none' eta_s=2 eta_d=3 e_s=0.5"),
    # the linear spring model
    "linear_springs": dict(scene="scene='lift_release'", lattice="nx=5 ny=5",
                           material="spring_model='linear' bending_model='none'"),
    # area masses and gravity (hang, SI units)
    "hang": dict(scene="scene='hang' initial_omega=0,0.2,0", lattice="nx=5 ny=5"),
}


def ratios(tmp_path, name, case, extra=(), nranks=2, **override):
    groups = dict(CASES[case], **override)
    groups["time"] = "t_end=10 dt=10"
    groups["output"] = "output_interval=10"
    proc, _ = run(tmp_path, name, nranks=nranks, options=ONE_STEP + tuple(extra), check=False, **groups)
    r = jacobian_ratios(proc.stdout + proc.stderr)
    assert r, f"no Jacobian test output:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    return r


@pytest.mark.parametrize("case", sorted(CASES))
def test_assembled_jacobian_matches_finite_differences(tmp_path, case):
    r = ratios(tmp_path, case, case)
    assert max(r) < 1e-6, f"{case}: ||J - Jfd||/||J|| = {max(r):.3e}"


def test_gauss_newton_bending_jacobian_is_detected_as_approximate(tmp_path):
    r = ratios(tmp_path, "gn", "bend_energy_moving", extra=("-nuno_gauss_newton",))
    assert max(r) > 1e-4


def test_jacobian_check_on_three_ranks(tmp_path):
    r = ratios(tmp_path, "np3", "bend_energy_moving", nranks=3, lattice="nx=5 ny=7")
    assert max(r) < 1e-6
