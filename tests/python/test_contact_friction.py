# SPDX-License-Identifier: BSD-2-Clause
"""Friction on an incline (&contact, docs/model.md section 10), the issue's
exact cases, and contact refused with identification and control.

The incline: the plane z = 0 (normal 0, 0, 1) under a tilted gravity
g (sin theta, 0, -cos theta), so the slope runs along +x. The sheet
('flat', uniform masses) starts at rest at the barrier's equilibrium gap
s_eq, where kappa (-b'(s_eq)) carries each node's normal load m_i g cos theta
(computed here from the barrier of docs/model.md, not from the program), so
it neither bounces nor sinks: every node's lagged normal force is its normal
load from the first step on, and the sheet has no internal force.

* mu < tan theta: every node slides faster than eps_v soon (a t > eps_v for
  t > eps_v / a ~ 1 ms), where the smoothed friction is Coulomb's mu f_n
  exactly, so the centre of mass accelerates at g (sin theta - mu cos theta).
  Backward Euler reproduces a constant acceleration exactly (v_n = v_0 + n a dt,
  x_n a quadratic in t_n with second derivative a), so the fit's error is the
  solver's, not the step's.
* mu > tan theta: IPC's smoothed friction f1(|u|) mu f_n (f1 < 1 below eps_v)
  holds the slope's pull m g sin theta only while sliding at the speed y* with
  f1(y*) = tan theta / mu, i.e. y* = eps_v (1 - sqrt(1 - tan theta / mu)) < eps_v:
  the sheet creeps at y*, so over T it moves y* T, below the bound eps_v T.
  The creep's time constant eps_v / (2 mu g cos theta) ~ 0.06 ms is far below
  the step, so the creep is y* from the first step on.
Small lattices, 1 s of simulated time, seconds each."""
import math
import os
import subprocess

import h5py
import numpy as np
import pytest

from nunorun import contact_lines, contact_sheet, exe, mpiexec, namelist, plane_below, run, slide_acceleration

G = 9.81
MASS = 0.1           # total mass, uniform over the nodes
KAPPA = 1.0          # contact_stiffness [force/length]
DHAT = 1e-3          # contact_dhat [length]
EPS_V = 1e-3         # friction_eps_v [length/time]
TAN = 0.5            # tan theta of the incline
THETA = math.atan(TAN)
T_END, DT, OUT = 1.0, 2e-3, 0.02

def barrier_force(s):
    """-kappa b'(s), b(s) = -(s - dhat)^2 log(s / dhat) (docs/model.md section 10)."""
    return KAPPA * (2.0 * (s - DHAT) * math.log(s / DHAT) + (s - DHAT) ** 2 / s)


def equilibrium_gap(load):
    """The gap s in (0, dhat) where the barrier carries `load` (bisection; the force falls from +inf to 0)."""
    lo, hi = 1e-30, DHAT
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if barrier_force(mid) > load:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


def incline(mu, n, lift=0.0):
    """The groups of a sheet of n x n nodes at rest on the incline, `lift` above its equilibrium gap."""
    node_load = MASS / (n * n) * G * math.cos(THETA)
    s_eq = equilibrium_gap(node_load)
    gx, gz = G * math.sin(THETA), -G * math.cos(THETA)
    return contact_sheet(plane_below(s_eq + lift, mu, dhat=DHAT, kappa=KAPPA, eps_v=EPS_V), T_END, OUT, n=n, dt=DT,
                         gravity=(gx, 0.0, gz), masses="uniform")


def centre_of_mass(h5):
    """Times and the centre of mass's x (uniform masses: the nodes' mean)."""
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        return np.array(f["time"][:n]), np.array(f["position"][:n, :, :, 0]).mean(axis=(1, 2))


@pytest.mark.parametrize("nranks", [1, 2])
def test_sliding_accelerates_at_g_sin_minus_mu_cos(tmp_path, nranks):
    mu = 0.3
    proc, h5 = run(tmp_path, "slide", nranks=nranks, **incline(mu, 7))
    t, x = centre_of_mass(h5)
    assert abs(t[-1] - T_END) < 1e-9
    # the window: from the first output where the speed exceeds 100 eps_v
    a = slide_acceleration(t, x, 100.0 * EPS_V)
    expected = G * (math.sin(THETA) - mu * math.cos(THETA))
    assert abs(a / expected - 1.0) < 0.01, (a, expected)
    # the contact force: the plane carries the normal load, friction is mu of it, against the slide
    rows = contact_lines(proc.stdout)
    fx, fy, fz = rows[-1][2:5]
    assert abs(fz / (MASS * G * math.cos(THETA)) - 1.0) < 1e-6, fz
    assert abs(fx / fz + mu) < 1e-6 and abs(fy) < 1e-9 * fz, (fx, fy, fz)
    assert rows[-1][6] > 0.0                                     # no accepted state reached the plane


def test_sticking_creeps_at_most_eps_v(tmp_path):
    mu = 1.0
    proc, h5 = run(tmp_path, "stick", **incline(mu, 5))
    t, x = centre_of_mass(h5)
    assert abs(t[-1] - T_END) < 1e-9
    moved = x[-1] - x[0]
    creep = EPS_V * (1.0 - math.sqrt(1.0 - TAN / mu))              # the smoothed law's sticking speed
    assert 0.0 < moved <= EPS_V * T_END                              # IPC's bound: creep below eps_v
    assert abs(moved / (creep * T_END) - 1.0) < 0.02, (moved, creep * T_END)
    # static friction holds the slope's pull, the plane the normal load
    fx, fy, fz = contact_lines(proc.stdout)[-1][2:5]
    assert abs(fz / (MASS * G * math.cos(THETA)) - 1.0) < 1e-6, fz
    assert abs(fx / (MASS * G * math.sin(THETA)) + 1.0) < 1e-6, fx


def test_spinning_landing_ranks_and_paths_agree(tmp_path):
    """Friction with its directions varying over the sheet: a spinning sheet
    (area masses, so the nodes' loads differ) lands 2 mm above its
    equilibrium on the incline and slides. With exact inner solves and Newton
    to its floor, 1 and 3 ranks (reduced path) and the 6-dof path give the
    same states to the Newton tolerance's effect."""
    g = incline(0.3, 7, lift=0.002)
    g["scene"] += " initial_omega=0.0,0.0,2.0"
    g["lattice"] = g["lattice"].replace("'uniform'", "'area'")
    g["time"] = "t_end=0.1 dt=2e-3"
    g["output"] = "output_interval=0.1"
    exact = ["-snes_rtol", "1e-12", "-snes_atol", "1e-14", "-reduced_pc_type", "lu", "-reduced_ksp_type", "preonly"]
    full = ["-snes_rtol", "1e-12", "-snes_atol", "1e-14", "-nuno_jacobian", "full", "-pc_type", "lu",
            "-ksp_type", "preonly", "-snes_linesearch_type", "basic"]
    out = {}
    for name, nranks, opts in [("one", 1, exact), ("three", 3, exact), ("full", 1, full)]:
        (tmp_path / name).mkdir()
        proc, h5 = run(tmp_path / name, name, nranks=nranks, options=opts, **g)
        rows = contact_lines(proc.stdout)
        assert rows[-1][1] > 0 and rows[-1][6] > 0.0             # landed, never reached the plane
        with h5py.File(h5, "r") as f:
            out[name] = (np.array(f["position"][-1]), np.array(f["velocity"][-1]))
    x1, v1 = out["one"]
    assert np.ptp(v1[..., 0]) > 0.1 and np.ptp(v1[..., 1]) > 0.1   # still spinning: friction's direction varies
    for other in ("three", "full"):
        x, v = out[other]
        assert np.abs(x - x1).max() < 1e-10 and np.abs(v - v1).max() < 1e-8, (other, np.abs(x - x1).max())


@pytest.mark.parametrize("group,body,scene", [
    ("identify", "observed_file='observed.h5' fit='e_s'", "scene='flat'"),
    ("control", "target_file='target.h5'", "scene='wave_point'"),
])
def test_identify_and_control_refuse_obstacles_on_two_ranks(tmp_path, group, body, scene):
    """The adjoint has no contact terms (docs/identification.md): refused in
    one line naming n_obstacles, before any file is made or read."""
    nml = tmp_path / "bad.nml"
    nml.write_text(namelist("bad.h5", scene=scene, **{group: body},
                            contact="n_obstacles=1 obstacle_shape(1)='plane' obstacle_point(:,1)=0.0,0.0,-1.0"))
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), nml.name], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(errors) == 1 and errors[0].startswith("nuno: error"), proc.stderr
    assert "n_obstacles = 1" in errors[0] and f"&{group}" in errors[0], errors[0]
    assert not (tmp_path / "bad.h5").exists()
