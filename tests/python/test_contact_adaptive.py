# SPDX-License-Identifier: BSD-2-Clause
"""Adaptive and second-order steps with obstacles (issue 47 item 4;
docs/contact.md, "Adaptive and second-order steps").

* The rtol matrix: beuler with -ts_adapt_type basic (the adaptive
  default with obstacles: e3c7ad0 refused an adaptive contact run without
  -ts_type, its default rosw) completes drop_table, drape_sphere and
  gripper (11 x 11, shortened) at -ts_rtol 1e-2 to 1e-6, with every
  accepted state above the acceptance floor (1e-6 contact_dhat) and a
  bounded number of steps (e3c7ad0 with -ts_type beuler stopped with a
  NaN norm at 1e-3 and 1e-6, with failed Newton solves at 1e-5, and at
  1e-4 looped with steps of 1e-13 s). Before the impact the sheet falls freely, flat
  and unstrained, so its exact motion is z0 - g t^2 / 2: there backward
  Euler's error is that of a first-order method under error-per-step
  control (each accepted step's local error at most about the tolerance,
  and in free fall the local errors of positions add up, the velocities'
  being exact), at most 10 (accepted steps) rtol L, L = 1 m the cloth size
  that scales the position tolerance; bdf2, whose local error is of
  higher order, stays within 10 rtol L.
* The order of bdf2 on a sliding incline (mu = 0.3 < tan theta = 0.5):
  once sliding, the centre of mass accelerates at g (sin - mu cos), so
  x(T) - x(0) = a T^2 / 2; bdf2's error at three fixed steps falls by 4
  per halving, backward Euler's by 2.
* Other integrators are refused in one line that names the allowed ones.
* A step that collapses (10 accepted steps in a row below 1e-10 t_end)
  ends the run with one line naming the time and the cause (e3c7ad0 went
  on with 1e-12 s steps until killed)."""
import math
import re
import subprocess

import h5py
import numpy as np
import pytest

from nunorun import contact_lines, contact_sheet, exe, mpiexec, namelist, plane_below, run
from test_contact_friction import G, THETA, centre_of_mass, incline

DHAT = 1e-3
FLOOR = 1e-6 * DHAT           # the acceptance floor [m]
N = 11
ADAPT = ["-ts_adapt_type", "basic"]
BDF2 = ["-ts_type", "bdf", "-ts_bdf_order", "2"]
RTOLS = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
MATERIAL = "e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='energy' k_b=0.1 eta_b=1e-4"
H_DROP = 0.05                 # drop_table's fall [m]: the impact at sqrt(2 (H - dhat) / g) = 0.0999 s


def drop():
    """input/drop_table.nml on 11 x 11 to t = 0.2 s (the impact and the settling)."""
    return contact_sheet(plane_below(H_DROP, 0.3, eps_v=1e-3), 0.2, 0.02, n=N, units="SI")


def drape():
    """input/drape_sphere.nml on 11 x 11 to t = 0.3 s (the landing and the first draping)."""
    g = contact_sheet(plane_below(H_DROP, 0.3, eps_v=1e-3), 0.3, 0.02, n=N, units="SI")
    g["contact"] = ("n_obstacles=1 obstacle_shape(1)='sphere' obstacle_point(:,1)=0.5,0.5,-0.3 "
                    "obstacle_radius(1)=0.25 obstacle_mu(1)=0.3 contact_dhat=1e-3 contact_stiffness=1.0 "
                    "friction_eps_v=1e-3")
    return g


def gripper():
    """input/gripper.nml on 11 x 11 to t = 0.8 s: the fingers close on the
    hanging cloth from t = 0.2 s and pinch it."""
    return dict(
        scene=("scene='wave_point' wave_nodes='edge' gravity=9.81,0.0,0.0 units='SI' n_keyframes=1 "
               "keyframe_time=0.0 keyframe_dx=0.0 keyframe_dy=0.0 keyframe_dz=0.0"),
        lattice=f"nx={N} ny={N} lx=1.0 ly=1.0 total_mass=0.1 mass_distribution='area'",
        material=MATERIAL,
        contact=("n_obstacles=2 obstacle_shape(1:2)='capsule','capsule' "
                 "obstacle_point(:,1)=0.5,-0.1,0.05 obstacle_end(:,1)=0.5,1.1,0.05 "
                 "obstacle_point(:,2)=0.5,-0.1,-0.05 obstacle_end(:,2)=0.5,1.1,-0.05 "
                 "obstacle_radius(1:2)=0.01,0.01 obstacle_mu(1:2)=0.5,0.5 "
                 "obstacle_close_dir(:,1)=0.0,0.0,-1.0 obstacle_close_dir(:,2)=0.0,0.0,1.0 "
                 "obstacle_n_keyframes(1:2)=4,4 obstacle_time(1:4,1)=0.0,0.2,0.7,2.2 "
                 "obstacle_time(1:4,2)=0.0,0.2,0.7,2.2 obstacle_close(1:4,1)=0.0,0.035,0.0399,0.0399 "
                 "obstacle_close(1:4,2)=0.0,0.035,0.0399,0.0399 obstacle_offset(:,4,1)=0.0,0.0,0.05 "
                 "obstacle_offset(:,4,2)=0.0,0.0,0.05 contact_dhat=1e-3 contact_stiffness=10.0 "
                 "friction_eps_v=1e-2"),
        time="t_end=0.8 dt=1e-3",
        output="output_interval=0.02",
    )


SCENES = {"drop": drop, "drape": drape, "gripper": gripper}


def feasible_and_complete(proc, h5, t_end):
    """The run completed at t_end, every accepted state (the contact lines'
    run minimum and the file's) above the floor; its steps."""
    rows = contact_lines(proc.stdout)
    assert rows and min(r[6] for r in rows) >= FLOOR, rows[-1] if rows else proc.stdout[-2000:]
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        assert f.attrs["status"].decode() == "complete"
        assert abs(f["time"][n - 1] - t_end) < 1e-9
        assert np.all(np.array(f["contact/min_gap_run"][:n]) >= FLOOR)
        return np.array(f["time"][:n]), np.array(f["position"][:n]), np.array(f["diagnostics/steps"][:n])


def free_fall_error(t, x):
    """The largest node distance from the exact free fall z0 - g t^2 / 2 at
    each output time (the sheet flat, unstrained and at rest at t = 0) [m]."""
    exact = x[0].copy()
    err = []
    for k, tk in enumerate(t):
        exact[..., 2] = x[0][..., 2] - G * tk * tk / 2.0
        err.append(np.linalg.norm(x[k] - exact, axis=-1).max())
    return np.array(err)


@pytest.mark.parametrize("rtol", RTOLS)
@pytest.mark.parametrize("scene", list(SCENES))
def test_beuler_adaptive_completes_feasible(tmp_path, scene, rtol):
    g = SCENES[scene]()
    t_end = float(re.search(r"t_end=(\S+)", g["time"]).group(1))
    # (no -ts_type: with obstacles the adaptive default is beuler, not rosw)
    proc, h5 = run(tmp_path, scene, options=[*ADAPT, "-ts_rtol", str(rtol)], **g)
    assert "TS beuler, adapt basic" in proc.stdout, proc.stdout[:2000]
    t, x, steps = feasible_and_complete(proc, h5, t_end)
    assert steps[-1] < 20000, steps[-1]                          # no collapse, no loop
    if scene == "drop":
        before = t < 0.09                                        # before the impact (0.0999 s)
        err = free_fall_error(t, x)[before]
        assert np.all(err <= 10.0 * steps[before] * rtol * 1.0), (err, steps[before])
        assert err.max() > 0.0                                   # (the check can fail)


@pytest.mark.parametrize("rtol", RTOLS)
def test_bdf2_adaptive_drop_within_ten_rtol(tmp_path, rtol):
    proc, h5 = run(tmp_path, "drop", options=[*BDF2, *ADAPT, "-ts_rtol", str(rtol)], **drop())
    t, x, steps = feasible_and_complete(proc, h5, 0.2)
    assert steps[-1] < 20000, steps[-1]
    err = free_fall_error(t, x)[t < 0.09]
    assert err.max() <= 10.0 * rtol * 1.0, (err / rtol, rtol)


def slide_error(tmp_path, opts, dt, t_end=0.5):
    """x(T) - x(0) - a T^2 / 2 of the centre of mass of a 5 x 5 sheet
    sliding on the incline (mu = 0.3; friction_eps_v = 1e-4 m/s, so that
    even the first step of 1 ms leaves the smoothing band, a dt > eps_v),
    Newton to its floor."""
    mu = 0.3
    g = incline(mu, 5)
    g["contact"] = g["contact"].replace("friction_eps_v=0.001", "friction_eps_v=0.0001")
    assert "friction_eps_v=0.0001" in g["contact"]
    g["time"] = f"t_end={t_end} dt={dt}"
    g["output"] = "output_interval=0.1"
    d = tmp_path / f"dt{dt}"
    d.mkdir()
    proc, h5 = run(d, "slide", options=[*opts, "-snes_rtol", "1e-12", "-snes_atol", "1e-14"], **g)
    t, xc = centre_of_mass(h5)
    assert abs(t[-1] - t_end) < 1e-9
    assert min(r[6] for r in contact_lines(proc.stdout)) >= FLOOR
    a = G * (math.sin(THETA) - mu * math.cos(THETA))
    return xc[-1] - xc[0] - a * t_end ** 2 / 2.0


def test_bdf2_is_of_order_two_on_a_sliding_incline(tmp_path):
    """bdf2's error falls 4 times per halving of dt; backward Euler's, the
    same measure's control, 2 times (its x_n = a t (t + dt) / 2)."""
    for method, opts, order in [("bdf2", BDF2, 2.0), ("beuler", ["-ts_type", "beuler"], 1.0)]:
        (tmp_path / method).mkdir()
        errs = [slide_error(tmp_path / method, opts, dt) for dt in (4e-3, 2e-3, 1e-3)]
        p1 = math.log2(abs(errs[0] / errs[1]))
        p2 = math.log2(abs(errs[1] / errs[2]))
        assert abs(p1 - order) < 0.1 and abs(p2 - order) < 0.1, (method, errs, p1, p2)


@pytest.mark.parametrize("opts,named", [(["-ts_type", "cn"], "-ts_type cn"), (["-ts_type", "theta"], "-ts_type theta"),
                                        (["-ts_type", "bdf", "-ts_bdf_order", "3"], "-ts_type bdf -ts_bdf_order 3")])
def test_other_integrators_refused_naming_the_allowed(tmp_path, opts, named):
    """One line on two ranks, before any output, naming the option and the
    allowed integrators (e3c7ad0: beuler alone, in PETSc's error format)."""
    proc, h5 = run(tmp_path, "bad", nranks=2, options=opts, check=False, **drop())
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno")]
    assert len(errors) == 1 and errors[0].startswith("nuno: error: " + named + ":"), proc.stderr[-2000:]
    assert "beuler, or bdf with -ts_bdf_order 1 or 2" in errors[0], errors[0]
    assert not h5.exists()


def test_collapsed_step_ends_the_run_in_one_line(tmp_path):
    """-ts_adapt_dt_max 1e-12 holds every step below 1e-10 t_end: the run
    stops after 10 such steps, within seconds, with one error line that
    names the time and -ts_adapt_dt_max."""
    g = drop()
    nml = tmp_path / "col.nml"
    nml.write_text(namelist("col.h5", **g))
    proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), nml.name, "-ts_type", "beuler", *ADAPT,
                           "-ts_adapt_dt_max", "1e-12"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr[-3000:]
    m = re.search(r"the step collapsed at t = (\S+): 10 steps in a row shorter than 1e-10 t_end", errors[0])
    assert m and 0.0 < float(m.group(1)) < 0.01, errors[0]
    assert "-ts_adapt_dt_max" in errors[0], errors[0]
    steps = re.search(r"failed at t = +\S+: (\d+) steps", proc.stdout)
    assert steps and int(steps.group(1)) < 100, proc.stdout[-2000:]
