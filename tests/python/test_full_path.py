# SPDX-License-Identifier: BSD-2-Clause
"""The 6-dof Newton step (-nuno_jacobian full) converges where the reduced
one does, with its own defaults (line search bt): both take the round-off
floor rule of module newton_control, the floor estimated from the
assembled matrix. Before it the 6-dof path reached the floor, its line
search found no decrease there, and the step failed: the shipped hang scene
failed at t = 0.08 s with LU and 0.55 s with the default solver, and
lift_release, wave_point and wave_point_energy within 0.1 s.

Expectations: the reduced path's positions (an independent solve of the
same implicit equations: a 3-dof elimination with its own inner solver),
within a bound from where Newton stops (see HANG_TOL), and a failure hint
that names the options of the path that failed."""
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec, read_run

HANG = ROOT / "input" / "hang.nml"
SCENES = sorted(p.stem for p in (ROOT / "input").glob("*.nml"))

# hang: 1 m cloth, dt = 1e-3 s, 600 steps. Each step's Newton stops at a
# residual below max(1e-6 ||F_0||, the floor estimate), at most 5e-7 here
# (||F_0|| <= 0.5 in these runs). F's x-rows are (x - x_n)/dt - v, so a
# residual r leaves a position error of at most dt r = 5e-10 m a step
# (the v-rows' error enters x through dt once more: smaller). 600 such
# errors, added up undamped: 3e-7 m. Measured: 1e-12 m.
HANG_TOL = 3e-7   # [m], the cloth is 1 m wide and falls 1.5 m


def run_input(tmp_path, path, name, options=(), nranks=1, overrides="", timeout=600, check=True):
    """Run an input file with -nuno_set overrides; return (process, run or None)."""
    h5 = Path(tmp_path) / f"{name}.h5"
    sets = f"output_file='{h5.name}'" + ("," + overrides if overrides else "")
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(path), "-nuno_set", sets, *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=timeout)
    if check:
        assert proc.returncode == 0, f"{name} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
        return proc, read_run(str(h5))
    return proc, None


@pytest.fixture(scope="module")
def hang_reduced(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("hang_reduced")
    _, r = run_input(tmp, HANG, "red", overrides="t_end=0.6")
    assert r.complete
    return r


@pytest.mark.parametrize("solver", [
    pytest.param((), id="default"),
    pytest.param(("-ksp_type", "preonly", "-pc_type", "lu"), id="lu"),
])
def test_hang_to_0_6_on_the_6dof_path(tmp_path, hang_reduced, solver):
    proc, full = run_input(tmp_path, HANG, "full", ("-nuno_jacobian", "full") + solver, overrides="t_end=0.6")
    assert full.complete
    assert abs(full.time[-1] - 0.6) < 1e-12
    # no step retried: Newton converged at every step
    assert "(0 retried" in proc.stdout, proc.stdout[-2000:]
    ref = hang_reduced.position
    assert full.position.shape == ref.shape
    # the cloth moved, or the comparison says nothing
    assert np.abs(ref[-1] - ref[0]).max() > 1.0
    err = np.abs(full.position - ref).max()
    assert err < HANG_TOL, f"6-dof and reduced paths differ by {err:.3e} m"


# scenes whose cloth rests until an obstacle reaches it: lift's bar at
# t = 0.2 s, gripper_lift's fingers at 0.5 s (on 11 x 11: 700 steps)
LATE = {"lift": "t_end=0.3,output_interval=0.05",
        "gripper_lift": "t_end=0.7,output_interval=0.05,nx=11,ny=11"}


@pytest.mark.parametrize("scene", SCENES)
def test_every_input_scene_on_the_6dof_path(tmp_path, scene):
    """Each shipped scene on its own lattice (11 x 11; hang 21 x 21 above)
    to t = 0.15 s (lift and gripper_lift past their obstacles' first touch,
    LATE) with the 6-dof path's default solver: past where it
    failed before (lift_release 0.089 s, wave_point 0.065 s,
    wave_point_energy 0.087 s), and the same motion as the reduced path."""
    path = ROOT / "input" / f"{scene}.nml"
    over = "t_end=0.15,output_interval=0.05" + (",nx=11,ny=11" if scene == "hang" else "")
    if scene in LATE:    # a cloth at rest until an obstacle reaches it
        over = LATE[scene]
    _, red = run_input(tmp_path, path, "red", overrides=over)
    proc, full = run_input(tmp_path, path, "full", ("-nuno_jacobian", "full"), overrides=over)
    assert red.complete and full.complete
    assert "(0 retried" in proc.stdout, proc.stdout[-2000:]
    ref = red.position
    scale = np.abs(ref).max()
    assert np.abs(ref[-1] - ref[0]).max() > 1e-3 * scale, "the cloth must move"
    # 150 steps of the bound above, relative to the scene's size
    err = np.abs(full.position - ref).max() / scale
    assert err < 1e-7, f"{scene}: 6-dof and reduced paths differ by {err:.3e} (relative)"


@pytest.mark.parametrize("nranks", [1, 2])
@pytest.mark.parametrize("path,expect,absent", [
    ("full", "-ksp_converged_reason", "-reduced_"),
    ("reduced", "-reduced_ksp_converged_reason", "-ksp_type preonly"),
])
def test_failure_hint_names_the_options_of_the_path(tmp_path, nranks, path, expect, absent):
    """A run whose Newton solves all fail (-nuno_fail_newton) ends with a
    hint: on the 6-dof path it names that path's options, never the reduced
    solve's, and the other way round."""
    options = ("-nuno_fail_newton", "100") + (("-nuno_jacobian", "full") if path == "full" else ())
    proc, _ = run_input(tmp_path, HANG, "fail", options, nranks=nranks, overrides="nx=9,ny=9,t_end=0.01",
                        timeout=120, check=False)
    assert proc.returncode != 0
    line = [ln for ln in (proc.stdout + proc.stderr).splitlines() if "failed: nonlinear solve diverged" in ln]
    assert len(line) == 1, proc.stdout + proc.stderr
    assert expect in line[0], line[0]
    assert absent not in line[0], line[0]
