# SPDX-License-Identifier: BSD-2-Clause
"""Friction between layers of the cloth (&contact's self_mu; issue 49
item 1; docs/self-contact.md, "Friction between layers"): a top sheet
sliding down an incline on a bottom sheet of the same cloth.

The incline as in test_contact_friction: a table (a plane with friction
0.9, which holds the bottom layer) under a tilted gravity
g (sin theta, 0, -cos theta), tan theta = 0.5, so the slope runs along +x.
The cloth (7 x 13 nodes, spacing 1 cm, uniform masses) lies folded in two
across its rows: rows 0-6 flat on the table, rows 7-12 over rows 5-0 (the
top layer), the layers' mid-surfaces H apart (about where the barrier
carries the top layer's weight). No scene of the program folds a sheet
this flat, so the state is made here (numpy) and written into the
checkpoint of a two-step run of the flat cloth, which the run then
continues (-nuno_restart). Every link is at its rest length but the fold's
(stretched by H^2/2a, 70 nm); there is no bending (bending_model = 'none')
and no shear link (e_d = 0), so the rows of the top layer slide along x
(the fold line) each on its own, held together only to third order in
their offsets by the soft y-links (1 N/m). A row far from the fold (11
and 12, over rows 1 and 0) is then a sheet on an incline whose ground is
the bottom layer: each of its nodes is carried by the barrier of its
pairs with the bottom layer, and each pair's friction is shared among the
nodes as its normal force is (the nearest points' weights), so sliding
faster than eps_v (after 1 ms) each node feels Coulomb's mu times its
normal load, m g cos theta, and the rows accelerate at
g (sin theta - mu cos theta), whatever the bottom layer does (it creeps on
the table). Backward Euler reproduces a constant acceleration exactly, so
a line fit of the rows' mean velocity after the layers settled (the
barrier's normal bounce, t >= 15 ms) tests the expectation. The rows next
to the fold are dragged by it (the fold's own pairs, 0.6 mm apart across
the fold's crossing diagonals, push them): they are not measured.
self_mu = 0 (the default): g sin theta; self_mu = 0.8 > tan theta: the
rows hold on the bottom layer, creeping below eps_v. 1 and 2 ranks (the
fold across the ranks' strips) agree. A few seconds a run."""
import math

import h5py
import numpy as np
import pytest

from nunorun import run

G = 9.81
TAN = 0.5
THETA = math.atan(TAN)
NX, NY = 7, 13                 # rows 0-6 on the table, 7-12 over rows 5-0
A = 0.01                       # lattice spacing [m]
MASS = 0.01                    # [kg], uniform over the nodes
THICK = 1e-4                   # contact_thickness [m]: xi = 2e-4 between layers
DHAT = 1e-3                    # [m]
EPS_V = 1e-3                   # friction_eps_v [m/s]
GAP_TABLE = 9.2e-4             # the bottom layer's start gap to the table [m]
H = 2 * THICK + 9.85e-4        # the layers' mid-surfaces apart at the start [m]
KAPPA = 100.0                  # contact_stiffness [N/m]
DT, T_END = 1e-3, 0.04
T0 = 2e-3                      # the flat run's end: the folded state's time [s]
TOP = slice(11, 13)            # the top layer's rows farthest from the fold (over rows 1 and 0)
MU_TABLE = 0.9


def groups(self_mu, t_end=T0):
    gx, gz = G * math.sin(THETA), -G * math.cos(THETA)
    contact = (f"n_obstacles=1 obstacle_shape(1)='plane' obstacle_point(:,1)=0.0,0.0,{-THICK - GAP_TABLE} "
               f"obstacle_normal(:,1)=0.0,0.0,1.0 obstacle_mu(1)={MU_TABLE} contact_thickness={THICK} "
               f"contact_dhat={DHAT} contact_stiffness={KAPPA} friction_eps_v={EPS_V}")
    contact += f" self_contact=.true. self_mu={self_mu}"
    return dict(contact=contact, scene=f"scene='flat' units='SI' gravity={gx},0.0,{gz}",
                lattice=f"nx={NX} ny={NY} lx={(NX - 1) * A} ly={(NY - 1) * A} total_mass={MASS} "
                        "mass_distribution='uniform'",
                material="spring_model='axial' e_s=1.0 eta_s=1.0e-3 e_d=0.0 eta_d=0.0 bending_model='none'",
                time=f"t_end={t_end} dt={DT}",
                output=f"output_interval={DT} write_velocity=.true.")


def folded():
    """Positions [ny][nx][3] of the folded cloth: rows 0-6 flat, rows 7-12 over rows 5-0, h apart
    (the links of the fold, row 6 to row 7, stretched by h^2 / 2a, 25 nm)."""
    x = np.zeros((NY, NX, 3))
    x[:, :, 0] = np.arange(NX) * A
    for j in range(NY):
        x[j, :, 1] = (j if j <= 6 else 12 - j) * A
        x[j, :, 2] = 0.0 if j <= 6 else H
    return x


def slide(tmp_path, name, self_mu, nranks=1, t_end=T_END):
    """The flat run, its checkpoint made the folded state, the continued run: times and positions,
    velocities [nt][ny][nx][3] after T0."""
    run(tmp_path, name, nranks=nranks, **groups(self_mu))
    h5 = tmp_path / f"{name}.h5"
    x = folded()
    with h5py.File(h5, "r+") as f:
        for slot in f["checkpoint"].values():
            if slot.attrs["time"] != T0:
                continue
            for key in slot:
                slot[key][...] = x if "position" in key else 0.0
    run(tmp_path, name, nranks=nranks, options=["-nuno_restart", str(h5)], **groups(self_mu, t_end))
    return read_after(h5)


def read_after(h5):
    """Times, positions, velocities after T0 in the run's file."""
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        t = np.array(f["time"][:n])
        keep = t > T0 + 1e-12
        return t[keep], np.array(f["position"][:n])[keep], np.array(f["velocity"][:n])[keep], h5


def top_acceleration(t, v, t_from=0.015):
    """The measured rows' acceleration along x (uniform masses: their mean velocity), a line fit."""
    vx = v[:, TOP, :, 0].mean(axis=(1, 2))
    k = t >= t_from
    return np.polyfit(t[k], vx[k], 1)[0]


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_the_top_layer_slides_at_g_sin_minus_mu_cos(tmp_path, mu):
    t, x, v, _ = slide(tmp_path, f"slide_{mu}", mu)
    acc = top_acceleration(t, v)
    expect = G * (math.sin(THETA) - mu * math.cos(THETA))
    assert abs(acc - expect) <= 0.02 * expect, (acc, expect)


def test_the_top_layer_holds_with_mu_above_tan_theta(tmp_path):
    t, x, v, _ = slide(tmp_path, "hold", 0.8)
    rel = x[:, TOP, :, 0].mean(axis=(1, 2)) - x[:, 0:2, :, 0].mean(axis=(1, 2))
    assert abs(rel[-1] - rel[0]) <= EPS_V * (t[-1] - t[0]), rel


def test_one_and_two_ranks_agree(tmp_path):
    _, x1, _, _ = slide(tmp_path, "r1", 0.3, nranks=1)
    _, x2, _, _ = slide(tmp_path, "r2", 0.3, nranks=2)
    assert np.abs(x2 - x1).max() <= 1e-8 * (NY - 1) * A


def test_bad_self_mu_is_refused_in_one_line(tmp_path):
    """A negative or NaN self_mu, self_mu > 0 without self_contact (it
    would be ignored), and friction_eps_v outside its range with self_mu >
    0: one line naming the key and its value, on 2 ranks,
    no output (test_contact_input's check; each ran before self_mu existed
    as an unknown key; NaN is the reader's finite-number check)."""
    from test_contact_input import refused
    cases = [("self_contact=.true. self_mu=-0.1", "self_mu = -0.1", "must be a number >= 0"),
             ("self_contact=.true. self_mu=NaN", "self_mu = NaN", "must be a finite number"),
             ("self_mu=0.3", "self_mu = 0.3", "needs self_contact = .true."),
             # friction's smoothing band against the lattice, as with an
             # obstacle's friction (ran before: the range was checked only
             # where an obstacle had friction)
             ("self_contact=.true. self_mu=0.3 friction_eps_v=1e6", "friction_eps_v = ", "must be between 1e-7 and 1")]
    for n, (keys, names, says) in enumerate(cases):
        d = tmp_path / f"case{n}"
        d.mkdir()
        line = refused(d, "n_obstacles=0 " + keys)
        assert f"input: &contact: {names}" in line and says in line, line
