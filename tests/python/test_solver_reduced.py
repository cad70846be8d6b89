# SPDX-License-Identifier: BSD-2-Clause
"""The reduced 3-dof solve (the default, module reduced) against the full
6-dof assembled Jacobian (-nuno_jacobian full): with exact linear solves and
tight Newton tolerances both must give the same trajectory on every scene of
input/, on 1 and 3 ranks. And the default solver on a large lattice: hang
129 x 129 takes 20 steps without a failure and falls as a free cloth does."""

import re
from pathlib import Path

import numpy as np
import pytest

import subprocess

from nunorun import ROOT, exe, mpiexec, read_run

from postprocess import namelist

LU = ("-pc_factor_mat_solver_type", "mumps")
REDUCED = ("-snes_rtol", "1e-12", "-reduced_ksp_type", "preonly", "-reduced_pc_type", "lu",
           "-reduced_pc_factor_mat_solver_type", "mumps")
# The same Newton for both: full steps (the reduced default; the 6-dof
# default bt takes other steps near the round-off floor).
FULL = ("-snes_rtol", "1e-12", "-snes_linesearch_type", "basic", "-nuno_jacobian", "full",
        "-ksp_type", "preonly", "-pc_type", "lu") + LU

SCENES = sorted(p.stem for p in (ROOT / "input").glob("*.nml"))


def set_key(text, key, value):
    """Namelist text with key (which must be there) set to value (Fortran text; f90nml)."""
    return namelist.set_key(text, key, repr(value) if isinstance(value, float) else str(value))


def run_input(tmp_path, scene, name, nranks, options, t_end, dt, timeout=300, **keys):
    text = (ROOT / "input" / f"{scene}.nml").read_text()
    text = set_key(text, "t_end", t_end)
    text = set_key(text, "dt", dt)
    text = set_key(text, "output_interval", t_end / 4)
    text = set_key(text, "output_file", f"'{name}.h5'")
    for k, v in keys.items():
        text = set_key(text, k, v)
    nml = Path(tmp_path) / f"{name}.nml"
    nml.write_text(text)
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(nml), *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{name} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc, read_run(str(Path(tmp_path) / f"{name}.h5"))


@pytest.mark.parametrize("nranks", [1, 3])
@pytest.mark.parametrize("scene", SCENES)
def test_reduced_and_full_newton_give_the_same_trajectory(tmp_path, scene, nranks):
    # paper bending amplifies round-off (docs/model.md section 3): short times
    t_end, dt = (0.2, 0.01) if scene != "hang" else (0.1, 0.005)
    # table_edge in steps of 2 ms: at 10 ms its impact on the box's edge
    # fails Newton solves (6 retried steps), each path retries its own
    # steps, and the two trajectories part (2e-3) for that reason alone;
    # at 2 ms no step is retried
    if scene == "table_edge":
        dt = 0.002
    # the contact scenes (21 x 21 as shipped) on 11 x 11, like the others
    keys = dict(nx=11, ny=11) if "n_obstacles" in (ROOT / "input" / f"{scene}.nml").read_text() else {}
    _, red = run_input(tmp_path, scene, f"{scene}_red", nranks, REDUCED, t_end, dt, **keys)
    _, full = run_input(tmp_path, scene, f"{scene}_full", nranks, FULL, t_end, dt, **keys)
    assert red.complete and full.complete
    ref = full.position
    scale = np.abs(ref).max()
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-4 * scale, f"{scene}: the cloth did not move ({moved:.3e})"
    err = np.abs(red.position - ref).max() / scale
    assert err < 1e-10, f"{scene} on {nranks} ranks: reduced differs from full by {err:.3e} (relative)"


def test_default_solver_runs_hang_129(tmp_path):
    """Twenty default steps of hang at 129 x 129 (dt = 1 ms): no failed or
    rejected step, and the middle of the cloth falls as backward Euler's
    free fall, -g dt^2 n (n+1)/2, within 5 % (the pins are far away and
    the flat cloth starts at rest length, so nothing holds it yet)."""
    n, dt = 20, 1e-3
    proc, r = run_input(tmp_path, "hang", "h129", 2, (), n * dt, dt, timeout=600, nx=129, ny=129)
    assert r.complete
    assert int(r.diagnostics["steps"][-1]) == n
    assert int(r.diagnostics["rejected_steps"][-1]) == 0
    z_mid = r.position[-1, 64, 64, 2]
    z_be = -9.81 * dt**2 * n * (n + 1) / 2
    assert abs(z_mid - z_be) < 0.05 * abs(z_be), f"middle node at z = {z_mid:.4e}, free fall {z_be:.4e}"
    # the pinned corners have not moved
    assert np.abs(r.position[-1, -1, 0] - r.position[0, -1, 0]).max() == 0.0
    assert np.abs(r.position[-1, -1, -1] - r.position[0, -1, -1]).max() == 0.0


def test_failing_inner_solves_fail_the_step_cleanly(tmp_path):
    """An inner solver that cannot converge (one iteration to 1e-12) must
    fail the Newton step (PC_SUBPC_ERROR -> SNES -> TS retries smaller),
    and after the retries end the run with the reason: exit 1 on every
    rank, the file marked failed, no hang."""
    text = (ROOT / "input" / "hang.nml").read_text()
    text = set_key(text, "t_end", 0.01)
    text = set_key(text, "output_file", "'fail.h5'")
    nml = Path(tmp_path) / "fail.nml"
    nml.write_text(text)
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(nml), "-reduced_ksp_max_it", "1",
           "-reduced_ksp_rtol", "1e-12"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    assert "nonlinear solve diverged" in proc.stdout + proc.stderr
    r = read_run(str(Path(tmp_path) / "fail.h5"))
    assert not r.complete and r.status.startswith("failed")


def test_a_step_retried_after_a_failed_inner_solve_goes_on(tmp_path):
    """A step whose inner solve fails is retried with a quarter step, and
    that retry, which the inner solver can do, must be accepted: the
    failure of one inner solve must not stick to the next ones. Jacobi
    needs about 210 CG iterations for a step of 1e-2 s on hang 21 x 21 and
    about 50 for 2.5e-3 s: with at most 100, every 1e-2 step fails once and
    its retry succeeds (before the fix every retry failed as well and the
    run stopped at t = 0)."""
    _, r = run_window(tmp_path, "retry", 2, ("-reduced_pc_type", "jacobi", "-reduced_ksp_max_it", "100"), 2, 0.01)
    assert r.complete
    rejected = int(r.diagnostics["rejected_steps"][-1])
    assert rejected >= 1, "no step failed: the test did not exercise a retry"
    assert int(r.diagnostics["steps"][-1]) > 2, "the retried steps were not taken smaller"


@pytest.mark.parametrize("option, value, words", [
    ("-nuno_jacobian", "foo", "Unknown option foo for -nuno_jacobian"),
    ("-nuno_pc_lag", "-1", "-nuno_pc_lag -1 must be >= 1"),
    ("-nuno_snes_floor", "2", "must be in [0, 1)"),
    # on 11 x 11 fewer than 3 levels fit: no multigrid
    ("-nuno_mg_interpolation", "cubic", "-nuno_mg_interpolation needs an inner multigrid"),
    ("-nuno_mg_cycle", "f", "Unknown option f for -nuno_mg_cycle"),
    ("-nuno_mg_cycle", "v",
     "-nuno_mg_cycle, -nuno_mg_sweeps, -nuno_mg_levels, -nuno_mg_product, -nuno_mg_coarse and -nuno_mg_gather are for nuno's multigrid"),
    ("-nuno_mg_product", "double", "-nuno_mg_gather are for nuno's multigrid"),
    ("-nuno_mg_coarse", "galerkin", "-nuno_mg_gather are for nuno's multigrid"),
    ("-nuno_mg_gather", "never", "-nuno_mg_gather are for nuno's multigrid"),
    ("-nuno_mg_coarse", "direct", "Unknown option direct for -nuno_mg_coarse"),
    ("-nuno_mg_gather", "always", "Unknown option always for -nuno_mg_gather"),
    ("-nuno_mg_product", "single", "Unknown option single for -nuno_mg_product"),
    ("-nuno_mg_sweeps", "0", "-nuno_mg_sweeps 0 must be >= 1"),
    ("-nuno_mg_interpolation", "quintic", "Unknown option quintic for -nuno_mg_interpolation"),
    ("-nuno_linesearch_fallback", "cp", "Unknown option cp for -nuno_linesearch_fallback"),
    ("-nuno_newton_start", "quartic", "Unknown option quartic for -nuno_newton_start"),
])
def test_bad_solver_option_is_refused_on_every_rank(tmp_path, option, value, words):
    proc = run_refused(tmp_path, (option, value))
    assert words in proc.stdout + proc.stderr


@pytest.mark.parametrize("options, words", [
    (("-nuno_linesearch_fallback", "l2", "-snes_linesearch_type", "bt"), "-nuno_linesearch_fallback and -snes_linesearch_type: give one"),
    (("-nuno_linesearch_fallback", "bt", "-nuno_jacobian", "full"), "-nuno_linesearch_fallback is for the reduced path"),
    (("-nuno_newton_start", "cubic", "-ts_type", "cn"), "-nuno_newton_start cubic needs -ts_type beuler"),
    (("-nuno_newton_start", "consistent", "-ts_type", "cn"), "-nuno_newton_start consistent needs -ts_type beuler"),
])
def test_a_line_search_fallback_the_run_cannot_use_is_refused(tmp_path, options, words):
    proc = run_refused(tmp_path, options)
    assert words in proc.stdout + proc.stderr


def run_refused(tmp_path, options):
    """hang 11 x 11 on 2 ranks with options it must refuse: a non-zero exit
    (every rank: mpiexec returns only when all have ended)."""
    text = set_key((ROOT / "input" / "hang.nml").read_text(), "output_file", "'bad.h5'")
    text = set_key(set_key(text, "nx", 11), "ny", 11)
    nml = Path(tmp_path) / "bad.nml"
    nml.write_text(text)
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(nml), *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    return proc


@pytest.mark.parametrize("impl, interpolation, cycle", [
    ("stencil", "coarse_cubic", "kaskade"), ("stencil", "linear", "kaskade"), ("stencil", "cubic", "v"),
    ("petsc", "linear", None), ("petsc", "cubic", None), ("petsc", "coarse_cubic", None)])
def test_parallel_multigrid_gives_the_one_rank_answer(tmp_path, impl, interpolation, cycle):
    """The default inner solver on 65 x 65 is nuno's structured multigrid
    (module stencil_mg: 5 levels on 1 rank, the coarsest replicated earlier
    on 3 ranks), with cubic interpolation below the finest level by default
    (hang has bending), everywhere, or bilinear, kaskade or V-cycles;
    -nuno_mg petsc is PETSc's PCMG with Galerkin operators (3 levels on 3
    ranks, where every coarse strip must keep the halo's rows). With tight
    tolerances 1 and 3 ranks give the same positions (the Galerkin sums and
    the cubic P cross the strips' boundaries)."""
    tight = ["-snes_rtol", "1e-12", "-reduced_ksp_rtol", "1e-11", "-reduced_ksp_view",
             "-nuno_mg", impl, "-nuno_mg_interpolation", interpolation]
    if cycle:
        tight += ["-nuno_mg_cycle", cycle]
    runs = {}
    for p in (1, 3):
        proc, runs[p] = run_input(tmp_path, "hang", f"mg_{impl}_{interpolation}_np{p}", p, tight, 0.005, 1e-3,
                                  nx=65, ny=65)
        used = "nuno structured multigrid" if impl == "stencil" else "type: mg"
        assert used in proc.stdout, f"no {impl} multigrid on {p} ranks"
    ref = runs[1].position
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-5
    err = np.abs(runs[3].position - ref).max() / moved
    assert err < 1e-8, f"3 ranks differ from 1 by {err:.3e} of the displacement"


@pytest.mark.parametrize("scene, nranks, product, bending", [
    ("hang", 1, None, None), ("hang", 3, None, None), ("hang", 3, "double", None), ("hang", 3, "mixed", None),
    ("wave_point_energy", 2, None, None), ("hang", 3, None, "none"), ("hang", 3, "mixed", "none")])
def test_default_inner_solver_gives_the_exact_newton_trajectory(tmp_path, scene, nranks, product, bending):
    """The default inner solve (FGMRES with nuno's single-precision
    multigrid, its product with S from the multigrid's single-precision
    blocks in difference form) asked for a tight tolerance gives the
    trajectory of the 6-dof path with LU (so the preconditioner's and the
    product's precision cost iterations, not accuracy): hang, and
    wave_point with its keyframed corner on a 33 x 33 lattice (where 4
    levels fit), constrained nodes exact; and with the product over S in
    double precision (-nuno_mg_product double) or in a pass of its own
    (mixed; the default, fused, forms it in the cycles). Without bending S
    is paired (module mg_kernels): the product takes each row's blocks to
    the row below from that row, so a wrong mirror would be a wrong S."""
    tight = ("-snes_rtol", "1e-12", "-reduced_ksp_rtol", "1e-11", "-reduced_ksp_view")
    if product:
        tight += ("-nuno_mg_product", product)
    keys = dict(nx=33, ny=33)
    if bending:
        keys["bending_model"] = f"'{bending}'"
    t_end, dt = (0.005, 1e-3) if scene == "hang" else (0.1, 0.01)
    proc, red = run_input(tmp_path, scene, f"def_{scene}_{nranks}_{product}_{bending}", nranks, tight, t_end, dt, **keys)
    assert "nuno structured multigrid" in proc.stdout
    _, full = run_input(tmp_path, scene, f"full_{scene}_{nranks}_{bending}", nranks, FULL, t_end, dt, **keys)
    ref = full.position
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-6
    err = np.abs(red.position - ref).max() / moved
    assert err < 1e-8, f"{scene} on {nranks} ranks: default differs from full by {err:.3e} of the displacement"


@pytest.mark.parametrize("bending", ["energy", "none"])
def test_fused_product_is_the_separate_product(tmp_path, bending):
    """-nuno_mg_product fused (the default): each multigrid cycle forms
    the product of its output with S in its last sweep, and the Krylov
    method's product of that output is a copy. It must be the separate pass
    (mixed) bit for bit, rows at the strips' edges included: hang 65 x 65
    with and without bending, solved loosely (the bw mode, where every
    rounding difference would change the iterates), on 1 and 3 ranks and
    with V-cycles of two sweeps; and the cycles' products must be used."""
    bw = ("-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3", "-reduced_ksp_view")
    keys = dict(nx=65, ny=65, bending_model=f"'{bending}'")
    for nranks, extra in ((1, ()), (3, ()), (3, ("-nuno_mg_cycle", "v", "-nuno_mg_sweeps", "2"))):
        runs, procs = {}, {}
        for product in ("mixed", "fused"):
            name = f"{product}_{bending}_{nranks}_{len(extra)}"
            procs[product], runs[product] = run_window(tmp_path, name, nranks,
                                                       bw + extra + ("-nuno_mg_product", product), 12, 1.0 / 600.0, **keys)
        used = [int(w) for w in re.findall(r"fused product: (\d+) products", procs["fused"].stdout)]
        assert used and max(used) >= 12, f"the cycles' products were not used ({used})"
        assert "fused product" not in procs["mixed"].stdout
        assert np.array_equal(runs["fused"].position, runs["mixed"].position), \
            f"fused and separate products differ on {nranks} ranks {extra}"
        its = [int(r.diagnostics["linear_iterations"][-1]) for r in runs.values()]
        assert its[0] == its[1]


def run_window(tmp_path, name, nranks, options, n, dt, **keys):
    """hang with one output window of n steps (the inner guesses start
    afresh at every window: run_input's four windows would leave few steps
    guessed)."""
    return run_input(tmp_path, "hang", name, nranks, options, n * dt, dt, output_interval=n * dt, **keys)


@pytest.mark.parametrize("guess", ["extrapolate", "project"])
def test_inner_guess_changes_iterations_not_the_trajectory(tmp_path, guess):
    """-nuno_inner_guess (module inner_guess): the inner solve of a step's
    first Newton iteration starts from the last steps' first corrections
    extrapolated, or from the least-squares combination of the last inner
    solves (project). Solved tightly, the trajectory is the zero guess's;
    solved to 1e-3 (the Baraff-Witkin mode) the falling cloth, whose
    acceleration changes smoothly, needs fewer inner iterations with it.
    project is the default with bending (auto), said in the start-up
    summary."""
    bw = ("-snes_type", "ksponly")
    n, dt = 20, 1.0 / 600.0
    runs, its = {}, {}
    tried = guess
    for guess in ("none", tried):
        _, runs[guess] = run_window(tmp_path, f"tight_{guess}", 2, bw + ("-reduced_ksp_rtol", "1e-11",
                                    "-nuno_inner_guess", guess), n, dt, nx=33, ny=33)
        _, loose = run_window(tmp_path, f"loose_{guess}", 2, bw + ("-reduced_ksp_rtol", "1e-3",
                              "-nuno_inner_guess", guess), n, dt, nx=33, ny=33)
        its[guess] = int(loose.diagnostics["linear_iterations"][-1])
    ref = runs["none"].position
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-3
    err = np.abs(runs[tried].position - ref).max() / moved
    assert err < 1e-8, f"the guess changed the tight trajectory by {err:.3e} of the displacement"
    assert its[tried] < its["none"], f"inner iterations with the guess {its[tried]}, without {its['none']}"
    if tried == "project":
        proc, _ = run_window(tmp_path, "default", 1, bw, 2, dt, nx=33, ny=33)
        assert "initial guess projected on the last 8 inner solves" in proc.stdout
        # adaptive steps change dt, which empties the projection: auto extrapolates there
        proc, _ = run_window(tmp_path, "adaptive", 1, ("-ts_type", "beuler", "-ts_adapt_type", "basic"), 2, dt,
                             nx=33, ny=33)
        assert "initial guess extrapolated" in proc.stdout


@pytest.mark.parametrize("guess", ["extrapolate", "auto"])
def test_second_newton_iteration_starts_from_the_last_steps(tmp_path, guess):
    """The inner solve of a step's second Newton iteration starts from a
    guess: with extrapolate the last step's second correction (scaled by
    the right-hand sides, module inner_guess second_weight), with auto
    (project, with bending) the projection on the last inner solves, the
    step's first among them: full Newton on hang 33 x 33 with bending, 2
    ranks. Nearly every second solve after the first steps starts from a
    nonzero guess (-reduced_ksp_view says so), and, solved tightly, the
    trajectory is the zero guess's. From the linear start: the default
    cubic one (-nuno_newton_start) takes most steps in one iteration."""
    n, dt = 20, 1.0e-3
    lin = ("-nuno_newton_start", "linear")
    proc, _ = run_window(tmp_path, "second", 2, ("-snes_monitor", "-reduced_ksp_view", "-nuno_inner_guess", guess) + lin,
                         n, dt, nx=33, ny=33)
    starts = {0: [], 1: []}
    k = None
    for line in proc.stdout.splitlines():
        m = re.match(r"\s*(\d+) SNES Function norm", line)
        if m:
            k = int(m.group(1))
        elif "initial guess" in line and k in starts:
            starts[k].append("nonzero" in line)
            k = None
    assert len(starts[1]) >= n, f"fewer second Newton iterations than steps: {len(starts[1])}"
    assert sum(starts[1][3:]) >= len(starts[1][3:]) - 2, f"second solves from a guess: {starts[1]}"
    runs = {}
    tried = guess
    for guess in ("none", tried):
        _, runs[guess] = run_window(tmp_path, f"tight2_{guess}", 2, ("-reduced_ksp_rtol", "1e-11",
                                    "-nuno_inner_guess", guess) + lin, n, dt, nx=33, ny=33)
    ref = runs["none"].position
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-4
    err = np.abs(runs[tried].position - ref).max() / moved
    assert err < 1e-8, f"the guesses changed the tight trajectory by {err:.3e} of the displacement"


@pytest.mark.parametrize("options, words", [
    (("-nuno_inner_guess", "extrapolate", "-ts_type", "rosw"), "needs a one-stage method"),
    (("-nuno_inner_guess", "previous", "-nuno_jacobian", "full"), "-nuno_inner_guess is for the reduced solve"),
    (("-nuno_inner_guess", "quadratic"), "Unknown option quadratic for -nuno_inner_guess"),
    (("-nuno_inner_guess", "extrapolate", "-reduced_ksp_type", "preonly", "-reduced_pc_type", "lu"),
     "needs an iterative inner solver"),
])
def test_an_inner_guess_the_run_cannot_use_is_refused(tmp_path, options, words):
    proc = run_refused(tmp_path, options)
    assert words in proc.stdout + proc.stderr
    assert not (Path(tmp_path) / "bad.h5").exists() or not read_run(str(Path(tmp_path) / "bad.h5")).complete
    assert not (Path(tmp_path) / "bad.h5").exists() or not read_run(str(Path(tmp_path) / "bad.h5")).complete


def test_constant_jacobian_of_linear_springs(tmp_path):
    """Linear springs without bending: K and C are constant, S is assembled
    once per shift and constraint window, not per Newton iteration; the
    trajectory must still be the full path's. dt = 0.03 does not divide the
    keyframe times 0.5 and 1.0, so the shift changes at the shortened steps."""
    from nunorun import run_and_read
    groups = dict(scene="scene='wave_point'", lattice="nx=7 ny=6",
                  material="spring_model='linear' bending_model='none'",
                  time="t_end=1.2 dt=0.03", output="output_interval=0.3")
    _, red = run_and_read(tmp_path, "lin_red", options=REDUCED, **groups)
    _, full = run_and_read(tmp_path, "lin_full", options=FULL, **groups)
    ref = full.position
    assert np.abs(ref[-1] - ref[0]).max() > 1.0
    err = np.abs(red.position - ref).max() / np.abs(ref).max()
    assert err < 1e-10, f"linear springs: reduced differs from full by {err:.3e}"
    # the system is linear: with an exact S and an exact inner solve, one
    # Newton iteration a step (a stale S, e.g. of another shift at the
    # shortened steps before keyframes, would take more)
    steps = int(red.diagnostics["steps"][-1])
    assert steps > 40
    assert int(red.diagnostics["newton_iterations"][-1]) == steps
