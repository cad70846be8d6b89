# SPDX-License-Identifier: BSD-2-Clause
"""Contact with a static plane (&contact): the normal force of a sheet at
rest is its weight, a drop reaches the plane at backward Euler's step of
the free fall (within one step of t = sqrt(2 h/g)), no accepted
state penetrates, 1 and 3 ranks and the reduced and 6-dof paths agree, bad
&contact keys are refused on 2 ranks. Small lattices, seconds each."""
import math
import re
import subprocess

import h5py
import numpy as np

from nunorun import contact_lines as lines, contact_sheet, exe, mpiexec, plane_below, run, run_and_read

G = 9.81
MASS = 0.1


def groups(h, t_end, out_dt, mu=0.0, n=7):
    return contact_sheet(plane_below(h, mu), t_end, out_dt, n=n)


def test_sheet_at_rest_carries_its_weight(tmp_path):
    # released 0.5 mm above the plane, inside the barrier's reach: it settles
    proc, _ = run(tmp_path, "rest", **groups(5e-4, 0.4, 0.1))
    last = lines(proc.stdout)[-1]
    fz = last[4]
    assert abs(fz - MASS * G) < 1e-3 * MASS * G, fz          # the barrier's force holds m g
    assert abs(last[2]) < 1e-9 and abs(last[3]) < 1e-9       # no tangential force on a level plane
    assert last[6] > 0.0                                       # no accepted state reached the plane


def beuler_drop(g, dt, n):
    """Backward Euler's free fall from rest, in closed form: v_k = v_{k-1}
    - g dt and z_k = z_{k-1} + dt v_k give the drop after n steps
    g dt^2 n (n + 1) / 2 = g t (t + dt) / 2 (t = n dt)."""
    return g * dt * dt * n * (n + 1) / 2.0


def test_drop_reaches_the_plane_at_the_free_fall_time(tmp_path):
    """A flat sheet at rest falls freely (no strain, no barrier force while
    every gap is >= dhat) onto a plane h below it, its nodes a distance
    `contact_thickness` from the plane's surface at contact: the gap is
    h - thickness - drop. Before the barrier acts, every step's smallest
    gap is backward Euler's closed-form fall (beuler_drop) to the solver's
    tolerance; the first step with a gap below dhat is the first step of
    that fall past h - thickness - dhat, and within one step of the exact
    time the free fall gets there, t* = sqrt(2 (h - thickness - dhat) / g).
    The drop is long (t* = 0.2992 s, 299 steps) so that a gravity off by
    1 % moves the first step by more than one step either way (checked
    below on the closed form): it would fail here."""
    h, thickness, dhat, dt = 0.45, 0.01, 1e-3, 1e-3
    g = groups(h, 0.31, dt)
    g["contact"] += f" contact_thickness={thickness}"
    proc, _ = run(tmp_path, "drop", **g)
    rows = lines(proc.stdout)
    steps = [round(r[0] / dt) for r in rows]
    assert steps == list(range(len(rows)))                      # a line at every step
    first = min(n for n, r in zip(steps, rows) if r[1] > 0)    # first state with a gap below dhat

    def first_step(gravity):
        return next(n for n in range(10 ** 6) if h - thickness - beuler_drop(gravity, dt, n) < dhat)

    assert first == first_step(G), (first, first_step(G))
    t_star = math.sqrt(2.0 * (h - thickness - dhat) / G)
    assert abs(first * dt - t_star) <= dt, (first * dt, t_star)
    for n, r in zip(steps, rows):
        if n < first:
            assert abs(r[5] - (h - thickness - beuler_drop(G, dt, n))) <= 1e-6 * h, (n, r[5])
    # a gravity off by 1 % would have landed more than one step from t*
    for wrong in (0.99 * G, 1.01 * G):
        assert abs(first_step(wrong) * dt - t_star) > dt, wrong
    assert all(r[5] > 0.0 for r in rows)                       # every output state outside the plane
    assert rows[-1][6] > 0.0                                   # and every accepted state (monitor's minimum)
    nsteps = int(re.search(r"complete at t = .*?: (\d+) steps", proc.stdout + proc.stderr).group(1))
    assert rows[-1][7] == nsteps + 1                           # ... all of them checked, and the start


def test_fixed_step_returns_to_dt_after_a_retry_with_obstacles(tmp_path):
    """-nuno_fail_newton 1 fails the first Newton solve; its step is retried
    with dt/4 and the next step is dt again, with obstacles as without. Over
    one output window of 10 dt (the sheet falls freely, 5 cm above the
    plane): the retried step of dt/4, then the 9.75 dt left in ceil(9.75) =
    10 steps of at most dt (the last ones shortened to end on the window's
    end): 11 steps, 1 rejected. A step left at dt/4 until the window's end
    would take 40 (as it did while contact's TS monitor replaced nuno's)."""
    proc, r = run_and_read(tmp_path, "retry", options=["-nuno_fail_newton", "1"], **groups(0.05, 0.01, 0.01))
    assert r.complete
    assert int(r.diagnostics["steps"][-1]) == 11
    assert int(r.diagnostics["rejected_steps"][-1]) == 1
    # counted where a user looks (issue 48 item 5): the closing line and /run
    assert "fixed steps: 1 retried smaller" in proc.stdout
    assert r.run_info["retried_steps"] == 1


def final_positions(h5):
    with h5py.File(h5, "r") as f:
        return np.array(f["position"][-1])


def test_ranks_and_paths_agree(tmp_path):
    exact = ["-snes_rtol", "1e-12", "-reduced_pc_type", "lu", "-reduced_ksp_type", "preonly"]
    g = groups(0.02, 0.1, 0.1, mu=0.3)
    for d in "abc":
        (tmp_path / d).mkdir()
    _, h1 = run(tmp_path / "a", "one", options=exact, **g)
    _, h3 = run(tmp_path / "b", "three", nranks=3, options=exact, **g)
    _, hf = run(tmp_path / "c", "full", options=["-snes_rtol", "1e-12", "-nuno_jacobian", "full", "-pc_type", "lu",
                                                 "-ksp_type", "preonly", "-snes_linesearch_type", "basic"], **g)
    x1, x3, xf = final_positions(h1), final_positions(h3), final_positions(hf)
    assert x1[..., 2].min() < -0.019                            # it has landed
    assert np.abs(x1 - x3).max() < 1e-10
    assert np.abs(x1 - xf).max() < 1e-9


def test_no_obstacles_runs_no_contact_code(tmp_path):
    g = groups(0.05, 0.01, 0.01)
    g["contact"] = "n_obstacles=0"
    proc, _ = run(tmp_path, "none", **g)
    assert "contact:" not in proc.stdout


def test_bad_contact_keys_are_refused_on_two_ranks(tmp_path):
    cases = {"contact_dhat=-1.0": ["contact_dhat", "-1"],
             "n_obstacles=1 obstacle_shape(1)='cube'": ["obstacle_shape(1)", "cube"],
             "n_obstacles=1 obstacle_shape(1)='sphere' obstacle_radius(1)=0.0": ["obstacle_radius(1)", "0"],
             "n_obstacles=9": ["n_obstacles", "9"]}
    for text, words in cases.items():
        (tmp_path / "bad.nml").write_text(f"&contact {text} /\n&output output_file='bad.h5' /\n")
        proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), "bad.nml"], cwd=tmp_path,
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode != 0
        errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
        assert len(errors) == 1, proc.stderr
        assert all(w in errors[0] for w in words), errors[0]
        assert not (tmp_path / "bad.h5").exists()


def test_contact_jacobian_against_finite_differences(tmp_path):
    """The 6-dof Jacobian with the contact blocks (barrier and sliding and
    smoothed friction: a sheet spinning 0.5 mm above the plane, mu = 0.3)
    against PETSc's finite differences of the residual."""
    from nunorun import jacobian_ratios
    g = groups(5e-4, 0.002, 0.002, mu=0.3, n=5)
    g["scene"] = "scene='flat' gravity=0.0,0.0,-9.81 initial_omega=0.0,0.0,0.5"
    proc, _ = run(tmp_path, "jac", options=["-nuno_jacobian", "full", "-snes_test_jacobian", "-snes_max_it", "1",
                                            "-snes_convergence_test", "skip", "-ts_max_snes_failures", "-1"], **g)
    r = jacobian_ratios(proc.stdout + proc.stderr)
    assert r and max(r) < 1e-5, r
    assert "active = 25" in proc.stdout                          # every node in the barrier's reach


def test_drape_over_a_sphere_never_penetrates(tmp_path):
    """input/drape_sphere.nml's scene on 11 x 11 nodes (2 ranks): the cloth
    lands on the sphere's top and folds down; the smallest gap over every
    accepted state stays > 0, and the sphere carries a load."""
    g = groups(0.0, 0.3, 0.1, mu=0.3, n=11)
    g["contact"] = ("n_obstacles=1 obstacle_shape(1)='sphere' obstacle_point(:,1)=0.5,0.5,-0.3 "
                    "obstacle_radius(1)=0.25 obstacle_mu(1)=0.3 contact_dhat=1e-3 contact_stiffness=1.0")
    proc, _ = run(tmp_path, "drape", nranks=2, **g)
    rows = lines(proc.stdout)
    assert rows[-1][6] > 0.0
    assert max(r[4] for r in rows) > 0.1 * MASS * G
