# SPDX-License-Identifier: BSD-2-Clause
"""The cloth's self-contact (issue 49; docs/self-contact.md, "The wiring"):
a 15 x 15 cloth of 0.5 m dropped flat onto a thin capsule (radius 2 cm,
along y near the middle): its two halves fall about the capsule like
pendulums, swing under it and meet below it at about t = 0.29 s, at about
1 m/s. Without self-contact they pass through each other; with
`self_contact = .true.` they must not.

The guarantee is checked by tests/python/crossings.py, numpy of its own
over the output positions (independent of nuno's kernels): output at every
time step, and between consecutive steps no node changes the side of a
nearby triangle it lies over. With self_contact off the check finds the
crossings (the check can fail); with it on it finds none, in Newton mode
(the default) on 1, 2 and 3 ranks and in Baraff-Witkin mode
(-snes_type ksponly) on 1 and 3 ranks, every accepted state's smallest gap
(/self_contact/min_gap) is > 0, and the positions on 2 and 3 ranks agree
with one rank's to the solver's tolerance (1e-8 of the cloth's size in
Newton mode, 1e-6 in bw: one linear solve a step, whose block-Jacobi
preconditioner changes with the ranks).
With self_step = 'ogc' (each node's update shortened to its own bound
instead of the global ACCD fraction) the same holds on 1, 2 and 3 ranks in
both modes. A start within 2 contact_thickness of itself is refused before the run,
naming the pair, and a barrier reach of a lattice spacing is refused by
name. With contact_dhat = 1 mm (a barrier five times thinner) Newton
converges only with the blocks between a pair's different nodes in S (the
pair blocks): the run completes on 1 and 2 ranks, without a crossing.
About 3 minutes on the shared 2-core machine."""
import numpy as np
import pytest

from crossings import crossings
from nunorun import run
from postprocess.reader import read_run
import h5py

L = 0.5                       # cloth size [m]
N = 15                        # nodes a side
NEAR = 0.5 * L / (N - 1)      # the crossing check's reach: half a lattice spacing [m]
T_END = 0.34                  # [s]; the halves meet at about 0.29 s

GROUPS = dict(
    scene="scene='flat' units='SI' gravity=0.0,0.0,-9.81",
    lattice=f"nx={N} ny={N} lx={L} ly={L} total_mass=0.05 mass_distribution='area'",
    material="e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='energy' k_b=1.0e-3 eta_b=1.0e-5",
    time=f"t_end={T_END} dt=1.0e-3",
    output="output_interval=1.0e-3 write_velocity=.false.",
)
CAPSULE = ("n_obstacles=1 obstacle_shape(1)='capsule' obstacle_point(:,1)=0.26,-0.1,-0.0255 "
           "obstacle_end(:,1)=0.26,0.6,-0.0255 obstacle_radius(1)=0.02 contact_dhat=5.0e-3 contact_stiffness=1.0")


def drop(tmp_path, name, on, nranks=1, options=(), dhat=5.0e-3, step="accd"):
    """The scene with self_contact on or off (self_step: its step guarantee); the run's positions
    [nt][ny][nx][3] and file."""
    contact = CAPSULE.replace("contact_dhat=5.0e-3", f"contact_dhat={dhat}") + (" self_contact=.true." if on else "")
    if step != "accd":
        contact += f" self_step='{step}'"
    _, h5 = run(tmp_path, name, nranks=nranks, options=options, timeout=600, contact=contact, **GROUPS)
    r = read_run(str(h5))
    assert r.complete and abs(r.time[-1] - T_END) < 1e-12
    return np.asarray(r.position), h5


@pytest.mark.parametrize("mode", ["newton", "bw"])
def test_halves_that_cross_without_self_contact_do_not_cross_with_it(tmp_path, mode):
    options = ("-snes_type", "ksponly") if mode == "bw" else ()
    ranks = (1, 2, 3) if mode == "newton" else (1, 3)

    off, _ = drop(tmp_path, f"{mode}_off", False, options=options)
    assert len(crossings(off, NEAR)) > 10            # the check fails where the cloth crosses itself

    on = {}
    for n in ranks:
        on[n], h5 = drop(tmp_path, f"{mode}_on_{n}", True, nranks=n, options=options)
        found = crossings(on[n], NEAR)
        assert not found, (n, found[:5])
        with h5py.File(h5, "r") as f:
            assert (f["self_contact/min_gap"][:] > 0).all()
            assert f["self_contact/active"][:].max() > 0      # the halves did meet
    # the solver's tolerance: Newton's (-snes_rtol 1e-8), or in bw the one
    # linear solve's a step (its preconditioner, block Jacobi, changes with
    # the ranks: 1.8e-8 of the size measured on 3 ranks)
    tol = 1e-8 if mode == "newton" else 1e-6
    size = np.ptp(on[1].reshape(-1, 3), axis=0).max()
    for n in ranks[1:]:
        assert np.abs(on[n] - on[1]).max() <= tol * size, n


@pytest.mark.parametrize("mode", ["newton", "bw"])
def test_per_node_bounds_keep_the_halves_apart_on_any_number_of_ranks(tmp_path, mode):
    # self_step = 'ogc' (docs/self-contact.md, "The step guarantee: two
    # flavours"): no global fraction; each node's update shortened to 0.4
    # of its nearest pair's gap, the ranks' bounds each the owner's. The
    # same check as the ACCD guarantee's (without self-contact the halves
    # cross: the test above), on 1, 2 and 3 ranks in both modes; nodes were
    # shortened (the bounds acted) on every rank count alike
    options = ("-snes_type", "ksponly") if mode == "bw" else ()
    on, clamped = {}, {}
    for n in (1, 2, 3):
        on[n], h5 = drop(tmp_path, f"ogc_{mode}_{n}", True, nranks=n, options=options, step="ogc")
        found = crossings(on[n], NEAR)
        assert not found, (n, found[:5])
        with h5py.File(h5, "r") as f:
            assert (f["self_contact/min_gap"][:] > 0).all()
            assert f["self_contact/active"][:].max() > 0      # the halves did meet
            clamped[n] = int(f["self_contact/clamped"][-1])
            assert clamped[n] > 0 and f["self_contact/limited"][-1] > 0
    tol = 1e-8 if mode == "newton" else 1e-6
    size = np.ptp(on[1].reshape(-1, 3), axis=0).max()
    for n in (2, 3):
        assert np.abs(on[n] - on[1]).max() <= tol * size, n


def test_a_bad_self_step_is_refused_in_one_line(tmp_path):
    """self_step not a choice, and 'ogc' without self_contact (it would be
    ignored): one line naming the key and its value (test_contact_input's
    check; both ran as an unknown key before self_step existed)."""
    from test_contact_input import refused
    cases = [("self_contact=.true. self_step='global'", "self_step = 'global'", "is not one of accd, ogc"),
             ("self_step='ogc'", "self_step = 'ogc'", "needs self_contact = .true.")]
    for n, (keys, names, says) in enumerate(cases):
        d = tmp_path / f"case{n}"
        d.mkdir()
        line = refused(d, "n_obstacles=0 " + keys)
        assert f"input: &contact: {names}" in line and says in line, line


def test_a_thin_barrier_converges_with_the_pair_blocks(tmp_path):
    # contact_dhat = 1 mm: without the blocks between a pair's nodes in S
    # (each node corrected as if the other stood still) Newton oscillated
    # where the halves meet and the run failed at t = 0.285 s; with them
    # it completes, on 1 and 2 ranks, without a crossing, the ranks agreeing
    on = {}
    for n in (1, 2):
        on[n], h5 = drop(tmp_path, f"thin_{n}", True, nranks=n, dhat=1.0e-3)
        found = crossings(on[n], NEAR)
        assert not found, (n, found[:5])
        with h5py.File(h5, "r") as f:
            assert (f["self_contact/min_gap"][:] > 0).all()
            assert f["self_contact/active"][:].max() > 0
            assert f["diagnostics/rejected_steps"][-1] == 0
    size = np.ptp(on[1].reshape(-1, 3), axis=0).max()
    assert np.abs(on[2] - on[1]).max() <= 1e-8 * size


@pytest.mark.parametrize("nranks", [1, 3])
def test_petsc_pcmg_with_the_pair_blocks_is_refused_before_the_run(tmp_path, nranks):
    # PETSc's PCMG makes its coarse levels from the assembled S alone and
    # left them unset beside the MATSHELL with the pair blocks: the run
    # stopped at its first inner solve ("PetscLayout for columns not yet
    # setup") after writing the file's head; now one line before the run
    contact = CAPSULE + " self_contact=.true."
    proc, h5 = run(tmp_path, "pcmg", nranks=nranks, check=False, options=["-reduced_pc_type", "mg"],
                   contact=contact, **dict(GROUPS, time="t_end=0.01 dt=1.0e-3"))
    text = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert "self_contact's pair blocks need nuno's multigrid" in text and "-reduced_pc_type mg" in text, text[-2000:]
    assert "PetscLayout" not in text
    assert not h5.exists()


def test_a_start_within_the_contact_distance_of_itself_is_refused_naming_the_pair(tmp_path):
    # bend_release's arc closed to 350 degrees (mm): its two ends 1.4 mm
    # apart, less than 2 contact_thickness = 2 mm
    proc, _ = run(tmp_path, "closed", check=False, scene="scene='bend_release' bend_angle=350.0",
                  time="t_end=0.01", contact="contact_thickness=1.0 self_contact=.true.")
    assert proc.returncode != 0
    line = [s for s in proc.stdout.splitlines() + proc.stderr.splitlines() if "self_contact" in s]
    assert line and "gap of" in line[0] and "nodes (" in line[0], proc.stdout[-2000:] + proc.stderr[-2000:]


def test_a_reach_of_a_lattice_spacing_is_refused_by_name(tmp_path):
    proc, _ = run(tmp_path, "reach", check=False, scene="scene='flat'", time="t_end=0.01",
                  contact="contact_dhat=8.0 self_contact=.true.")
    assert proc.returncode != 0
    text = proc.stdout + proc.stderr
    assert "self_contact = .true. needs contact_dhat + 2 contact_thickness" in text, text[-2000:]


def test_one_broad_phase_a_step_at_most(tmp_path):
    # The Verlet list is made again from an update's paths (swept
    # candidates) when the update leaves it, and that list also serves the
    # update's CCD; the accepted hook keeps a list that still holds. The
    # list, the step limit's swept candidates and the list again at the
    # limited candidate made three a step where the halves swing (measured
    # with this count on the build before: 36 every 12 steps at 129 x 129).
    contact = CAPSULE + " self_contact=.true."
    groups = dict(GROUPS, output="output_interval=1.0e-2 write_velocity=.false.")
    _, h5 = run(tmp_path, "searches", options=("-snes_type", "ksponly"), contact=contact, **groups)
    with h5py.File(h5, "r") as f:
        searches = f["self_contact/searches"][:]
        steps = f["diagnostics/steps"][:]
        assert f["self_contact/active"][:].max() > 0      # the halves did meet
    assert steps[-1] >= 300
    assert (np.diff(searches) <= np.diff(steps)).all(), (searches, steps)


def test_a_flat_cloth_lists_none_of_its_own_lattice_pairs(tmp_path):
    # A 33 x 33 cloth of 64 mm (spacing a = 2 mm) falling flat, contact_dhat
    # = 1 mm, contact_thickness 0: the nearest pairs of the lattice that
    # share no node (a node and the diagonal of a quad beside it) lie
    # a / sqrt(2) = 1.41 mm apart at rest. The Verlet list's reach is dhat +
    # skin with the skin capped at half the room between dhat and that gap
    # (docs/self-contact.md, "Candidate pairs"): 1.21 mm, so the list holds
    # none of them, and the smallest gap written is that reach. With skin =
    # dhat (reach 2 mm, the build before) every node's neighbours were
    # candidates, evaluated at every residual: the smallest gap was 1.41 mm.
    n, side, dhat = 33, 0.064, 1.0e-3
    a = side / (n - 1)
    reach = dhat + min(dhat, 0.5 * (a / np.sqrt(2.0) - dhat))
    groups = dict(GROUPS, lattice=f"nx={n} ny={n} lx={side} ly={side} total_mass=0.001 mass_distribution='area'",
                  time="t_end=5.0e-3 dt=1.0e-3")
    _, h5 = run(tmp_path, "flat", contact=f"contact_dhat={dhat} self_contact=.true.", **groups)
    with h5py.File(h5, "r") as f:
        assert np.allclose(f["self_contact/min_gap"][:], reach, rtol=1e-12, atol=0.0), f["self_contact/min_gap"][:]
        assert (f["self_contact/active"][:] == 0).all()
        assert (f["self_contact/candidates"][:] == 0).all()
