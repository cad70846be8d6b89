# SPDX-License-Identifier: BSD-2-Clause
"""Contact's Newton solve and step limit (docs/design.md, "Contact"): the
shipped drape_sphere scene takes no retried step through its landing at
dt = 1 ms (the Jacobian at every Newton iteration with obstacles), and the
Baraff-Witkin mode (-snes_type ksponly, one linearised solve a step, no line
search) keeps every accepted state outside the obstacles (the step limit
runs as the post-solve of its KSP). 2 ranks, seconds each."""
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec
from postprocess import namelist
from postprocess.reader import read_run

INPUT = ROOT / "input"


def run_input(tmp_path, scene, overrides, options=()):
    """input/<scene>.nml on 2 ranks with -nuno_set overrides; (process, run)."""
    h5 = Path(tmp_path) / f"{scene}.h5"
    sets = f"output_file='{h5.name}'," + overrides
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(INPUT / f"{scene}.nml"), "-nuno_set", sets, *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{scene} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc, read_run(str(h5))


def test_drape_sphere_lands_without_a_retried_step(tmp_path):
    """The shipped scene (21 x 21, dt = 1 ms) through its landing and the
    first folds (t = 0.209 s: with S lagged to every other Newton iteration
    the friction of the four nodes next to the sphere's top made Newton
    two-cycle, ||F|| stuck at 80, and the step was retried)."""
    _, r = run_input(tmp_path, "drape_sphere", "t_end=0.22,output_interval=0.01")
    assert r.complete
    assert int(r.diagnostics["steps"][-1]) == 220               # t_end / dt, none cut
    assert int(r.diagnostics["rejected_steps"][-1]) == 0
    assert r.contact["min_gap_run"][-1] > 0.0
    assert r.contact["active"].max() > 0                       # it has landed


def check_bw_no_penetration(r, steps):
    assert r.complete
    assert int(r.diagnostics["steps"][-1]) == steps
    # every accepted state was checked (and the start) and none reached an obstacle
    assert int(r.contact["states_checked"][-1]) == steps + 1
    assert np.all(r.contact["min_gap_run"] > 0.0)
    assert np.all(r.contact["min_gap"] > 0.0)
    assert r.contact["active"].max() > 0


def test_bw_mode_drape_never_penetrates(tmp_path):
    """drape_sphere on 11 x 11 in the Baraff-Witkin mode: the one linearised
    solve a step overshot into the sphere at the landing (t = 0.101 s) while
    the step limit ran only in the line search that mode lacks."""
    _, r = run_input(tmp_path, "drape_sphere", "nx=11,ny=11,t_end=0.3,output_interval=0.1",
                     ("-snes_type", "ksponly"))
    check_bw_no_penetration(r, 300)


def test_bw_mode_drop_table_never_penetrates(tmp_path):
    """drop_table's impact in the Baraff-Witkin mode."""
    _, r = run_input(tmp_path, "drop_table", "t_end=0.2,output_interval=0.05", ("-snes_type", "ksponly"))
    check_bw_no_penetration(r, 200)


def test_guarded_forcing_saves_inner_iterations_where_contact_has_settled(tmp_path):
    """drop_table at 129 x 129 with the table 0.9 mm below the sheet (inside
    the barrier's reach from the first step, as bench/contact.py), 30 steps
    of 1 ms: the inexact-Newton forcing, guarded with obstacles (inner
    solves tight only where a step limit cut or an obstacle carried the
    start or an update), takes at most 0.7 of the inner iterations of the
    same run with the forcing off (-nuno_newton_forcing false: every inner
    solve to 1e-6, as every contact run was before issue 47 item 6: 0.51
    measured), with no retried step and no accepted state inside the
    table; the two runs' last states agree to the Newton tolerance's
    scale (1e-6 of the sheet's size)."""
    sets = "nx=129,ny=129,t_end=0.03,output_interval=0.03,obstacle_point(:,1)=0.0,0.0,-9e-4"
    runs = []
    for name, opts in (("guarded", ()), ("off", ("-nuno_newton_forcing", "false"))):
        d = tmp_path / name
        d.mkdir()
        _, r = run_input(d, "drop_table", sets, opts)
        assert r.complete
        assert int(r.diagnostics["steps"][-1]) == 30
        assert int(r.diagnostics["rejected_steps"][-1]) == 0
        assert r.contact["min_gap_run"][-1] > 0.0
        runs.append((int(r.diagnostics["linear_iterations"][-1]), np.asarray(r.position[-1])))
    (guarded, x_guarded), (off, x_off) = runs
    assert guarded <= 0.7 * off, (guarded, off)
    assert np.max(np.abs(x_guarded - x_off)) < 1e-6, np.max(np.abs(x_guarded - x_off))


def test_rediscretised_coarse_levels_carry_the_contact(tmp_path):
    """drop_table at 65 x 65 with the table 0.9 mm below the sheet (the
    barrier active from the first step), 60 steps of 1/600 s in the
    Baraff-Witkin mode, 2 ranks: the multigrid's rediscretised coarse levels
    (the default with bending) carry the barrier's node blocks, restricted
    with the bilinear weights as the masses are (module mg_coarse), so the
    inner iterations are no more than 1.1x those of the Galerkin products of
    the same finest S (-nuno_mg_coarse galerkin, which contain the blocks by
    construction); without the blocks on the coarse levels they were 1.6x
    (239 against 149 on one rank), measured on 853a335. The two runs' last
    states agree to the inner tolerance's scale."""
    sets = ("nx=65,ny=65,t_end=0.1,dt=0.0016666666666666668,output_interval=0.1,"
            "obstacle_point(:,1)=0.0,0.0,-9e-4")
    runs = []
    for name, opts in (("rediscretised", ()), ("galerkin", ("-nuno_mg_coarse", "galerkin"))):
        d = tmp_path / name
        d.mkdir()
        _, r = run_input(d, "drop_table", sets, ("-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3", *opts))
        assert r.complete
        assert int(r.diagnostics["steps"][-1]) == 60
        assert r.contact["active"].max() > 0
        runs.append((int(r.diagnostics["linear_iterations"][-1]), np.asarray(r.position[-1])))
    (redisc, x_r), (galerkin, x_g) = runs
    assert redisc <= 1.1 * galerkin, (redisc, galerkin)
    assert np.max(np.abs(x_r - x_g)) < 1e-5, np.max(np.abs(x_r - x_g))


def newton_per_step(tmp_path, scene, contact, jacobians=False, n=65, steps=60, options=()):
    """input/<scene>.nml at n x n (65), `steps` steps (60) of 1 ms on 2 ranks, the
    obstacle's top 0.9 mm below the flat sheet (inside the barrier's reach
    from the first step, as bench/contact.py), or without obstacles (no
    &contact: the sheet falls freely), with the command-line options;
    Newton iterations a step, and with jacobians also the Jacobian
    assemblies a step (-log_view's SNESJacobianEval count)."""
    nml = namelist.read((INPUT / f"{scene}.nml").read_text())
    nml["lattice"].update(nx=n, ny=n)
    nml["time"].update(t_end=steps * 1.0e-3, dt=1.0e-3)
    nml["output"].update(output_interval=steps * 1.0e-3, output_file="b.h5")
    if contact:
        c = nml["contact"]
        x, y, _ = c["obstacle_point"][0]
        top = float(c["obstacle_radius"][0]) if scene == "drape_sphere" else 0.0
        c["obstacle_point"] = [[x, y, -(top + 9e-4)]]
    else:
        del nml["contact"]
    d = Path(tmp_path) / f"{scene}-{contact}-{len(list(Path(tmp_path).iterdir()))}"
    d.mkdir()
    (d / "b.nml").write_text(str(nml) + "\n")
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), "b.nml", *(("-log_view",) if jacobians else ()), *options]
    proc = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    r = read_run(str(d / "b.h5"))
    assert r.complete
    assert int(r.diagnostics["steps"][-1]) == steps
    assert int(r.diagnostics["rejected_steps"][-1]) == 0
    if contact:
        assert r.contact["min_gap_run"][-1] > 0.0
        assert r.contact["active"].max() > 0
    newton = int(r.diagnostics["newton_iterations"][-1]) / steps
    if not jacobians:
        return newton
    m = re.search(r"^SNESJacobianEval\s+(\d+)", proc.stdout, re.M)
    assert m, proc.stdout[-3000:]
    return newton, int(m.group(1)) / steps


@pytest.mark.parametrize("scene", ["drape_sphere", "drop_table"])
def test_contact_steps_take_at_most_two_newton_iterations(tmp_path, scene):
    """Issue 47 item 6: with obstacles Newton starts from the consistent
    start (the cubic start's positions x_n + dt v) limited by the step
    limit (hint smooth_start), and stops at the floor by its update where
    that start is at the residual's floor. The start is then feasible and
    in Newton's quadratic basin, and the barrier's nonlinearity is what is
    left: the first iteration leaves its Taylor remainder (the start's
    miss squared times the barrier's third derivative), above the floor at
    the barrier's stiffness near d = 0.9 mm; the second squares it again,
    below. So at most two Newton iterations a step on average over 60
    steps at 65 x 65 of contact from the first step, the onset of
    drape_sphere's growing contact set (4-7 a step there) included:
    1.93 (drape_sphere) and 1.95 (drop_table) measured, the free sheet
    1.02. From the cubic start (before auto chose the consistent one)
    they were 2.07 and 2.03, and from the limited linear start (2907dd0)
    2.45 and 2.27. The issue's target, a contact step within 1.5 times
    the free step's Newton iterations, is not met (1.9x: docs/
    performance.md, open problem 6); this bound guards the counts
    reached."""
    contact = newton_per_step(tmp_path, scene, True)
    assert contact <= 2.0, contact


def test_settled_contact_steps_keep_their_jacobian(tmp_path):
    """Issue 47 item 6: a Newton solve with obstacles assembles its
    Jacobian at every iteration until it has settled (hint
    jacobian_settled: no update or start cut by the step limit, ||F|| down
    100-fold to within 100 times the convergence test's residual), then
    keeps it, as the free sheet's second iteration does
    (-snes_lag_jacobian 2). drop_table at 129 x 129, 30 steps of contact
    from the first step, 2 ranks: at most 1.7 assemblies a step, with no
    more Newton iterations than 1.1 times those of the same run with a
    Jacobian assembled at every iteration (-snes_lag_jacobian 1, given:
    the hint is not used; it assembles one a Newton iteration): the
    chord step from a settled solve reaches the floor as a fresh Jacobian
    does (measured on 03ca18c: 1.87 Newton iterations a step both ways,
    1.20 assemblies a step against 1.87; the free sheet 1.03, which the
    test compared with before the consistent start took the free sheet's
    second iteration). Before (3377e50) every Newton iteration assembled:
    2.0 a step."""
    newton, jac = newton_per_step(tmp_path, "drop_table", True, jacobians=True, n=129, steps=30)
    fresh_newton, fresh_jac = newton_per_step(tmp_path, "drop_table", True, jacobians=True, n=129, steps=30,
                                              options=("-snes_lag_jacobian", "1"))
    assert fresh_jac == pytest.approx(fresh_newton, abs=0.05), (fresh_jac, fresh_newton)
    assert jac <= 1.7, (jac, newton)
    assert newton <= 1.1 * fresh_newton, (newton, fresh_newton)
