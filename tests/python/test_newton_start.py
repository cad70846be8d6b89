# SPDX-License-Identifier: BSD-2-Clause
"""The Newton start of backward Euler (-nuno_newton_start,
module newton_start; issue 7, the nineteenth round): auto starts
Newton at fixed steps from the polynomial through the last accepted states
(cubic once four are at hand) with its positions x_n + dt v (consistent),
linear is PETSc's x_n + dt xdot_n.

The expectations are independent of the program: a free sheet falling
under gravity has, under backward Euler, velocities linear and positions
quadratic in the step number, so the linear start misses x_{n+1} by
g dt^2 at every node (the residual's x-rows, xdot - v, by g dt: ||F_0|| =
g dt sqrt(number of nodes)), while the quadratic and cubic starts are
exact (||F_0|| at round-off); and a start changes where Newton begins,
never where it ends (the same trajectory when solved tightly)."""
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nunorun import exe, mpiexec, run, run_and_read

G, DT, NODES = 9.81, 1.0e-3, 11 * 11          # the flat scene: 11 x 11 nodes
FALL = dict(scene="scene='flat' gravity=0,0,-9.81", time=f"t_end=0.01 dt={DT}", output="output_interval=0.005")


def first_residuals(text):
    """||F_0|| of every Newton solve in order (-snes_monitor's iteration 0)."""
    return np.array([float(m) for m in re.findall(r"^\s*0 SNES Function norm ([0-9.eE+-]+)", text, re.M)])


def test_a_falling_sheet_starts_exactly_from_the_third_step_on(tmp_path):
    """Ten steps on 3 ranks, an output step after the fifth. linear: every
    step but the run's first starts g dt sqrt(N) away (TS starts the run's
    first step from its state; the output step starts nothing afresh:
    issue 48, where before the sixth step started from its state too).
    auto (consistent here: Newton at fixed steps): the run's first step
    starts from its state, the second as linear does (two states kept),
    every later one at round-off, the sixth included: the kept states go on
    across the output step (with a reset at every output step, as before
    the twentieth round, that step would start from its state alone)."""
    lin, _ = run(tmp_path, "linear", nranks=3, options=["-snes_monitor", "-nuno_newton_start", "linear"], **FALL)
    cub, _ = run(tmp_path, "auto", nranks=3, options=["-snes_monitor"], **FALL)
    assert "started consistent (-nuno_newton_start)" in cub.stdout
    assert "(-nuno_newton_start)" not in lin.stdout
    f_lin, f_cub = first_residuals(lin.stdout), first_residuals(cub.stdout)
    assert f_lin.shape == f_cub.shape == (10,)
    miss = G * DT * np.sqrt(NODES)
    assert f_lin[0] > 100 * miss                                    # the run's first step: its state
    np.testing.assert_allclose(f_lin[1:], miss, rtol=1e-6)
    assert f_cub[0] == pytest.approx(f_lin[0], rel=1e-12)
    assert f_cub[1] == pytest.approx(miss, rel=1e-6)                # two states: linear
    assert np.all(f_cub[2:] < 1e-5 * miss), f_cub


def test_the_kept_states_end_where_a_keyframe_starts(tmp_path):
    """wave_point_energy: its corner follows keyframes at 0, 0.5 and 1 s, so
    its velocity jumps at t = 0.5. A polynomial through the states before
    would start the step after it at the old velocity: the kept states end
    there, and that step starts from its state alone as with the linear
    start (the same ||F_0|| to 1e-6: the two runs differ only at Newton's
    round-off before it), while the steps of the window before it started
    closer than the linear start."""
    text = (Path(__file__).resolve().parents[2] / "input" / "wave_point_energy.nml").read_text()
    for key, value in (("t_end", "0.51"), ("output_interval", "0.01"), ("output_file", "'kf.h5'")):
        text, n = re.subn(rf"^(\s*{key}\s*=\s*)[^!\n]*", rf"\g<1>{value} ", text, flags=re.M)
        assert n == 1, key
    nml = Path(tmp_path) / "kf.nml"
    nml.write_text(text)
    f = {}
    for start in ("linear", "cubic"):
        proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), str(nml), "-snes_monitor",
                               "-nuno_newton_start", start], cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        f[start] = first_residuals(proc.stdout)
    f_lin, f_cub = f["linear"], f["cubic"]
    assert f_lin.shape == f_cub.shape == (510,)
    assert f_cub[500] == pytest.approx(f_lin[500], rel=1e-6), (f_cub[495:505], f_lin[495:505])
    assert np.all(f_cub[492:500] < 0.1 * f_lin[492:500]), (f_cub[492:500], f_lin[492:500])


def test_the_start_changes_the_iterations_not_the_trajectory(tmp_path):
    """hang 33 x 33 with bending, 2 ranks, 30 steps of 1 ms in one window:
    with the inner solves to 1e-11 (Newton to its round-off floor) the
    cubic start's trajectory is the linear start's to 1e-8 of the
    displacement; with the default tolerances it takes fewer Newton
    iterations (the point of it: about one a step instead of two)."""
    keys = dict(scene="scene='hang'", lattice="nx=33 ny=33", time="t_end=0.03 dt=0.001",
                output="output_interval=0.03")
    tight = ["-reduced_ksp_rtol", "1e-11"]
    runs, newton = {}, {}
    for start in ("linear", "cubic"):
        _, runs[start] = run_and_read(tmp_path, f"tight_{start}", nranks=2,
                                      options=[*tight, "-nuno_newton_start", start], **keys)
        _, r = run_and_read(tmp_path, f"default_{start}", nranks=2, options=["-nuno_newton_start", start], **keys)
        newton[start] = int(r.diagnostics["newton_iterations"][-1])
    ref = runs["linear"].position
    moved = np.abs(ref[-1] - ref[0]).max()
    assert moved > 1e-3
    err = np.abs(runs["cubic"].position - ref).max() / moved
    assert err < 1e-8, f"the start changed the tight trajectory by {err:.3e} of the displacement"
    assert newton["cubic"] < 0.8 * newton["linear"], newton


def test_the_baraff_witkin_mode_keeps_the_linear_start(tmp_path):
    """-snes_type ksponly: the start is the point of the one linearisation
    (and its residual the scale of the solve's tolerance): auto keeps
    PETSc's linear start there."""
    proc, _ = run(tmp_path, "bw", nranks=1, options=["-snes_type", "ksponly"], **FALL)
    assert "Newton step reduced" in proc.stdout
    assert "(-nuno_newton_start)" not in proc.stdout


def test_where_the_cubic_start_is_worse_the_linear_one_is_taken(tmp_path):
    """hang 129 x 129 without bending, 4 ms steps from rest, one rank: in
    this transient the membrane's steps wiggle, and the cubic through the
    last four states starts steps 4-9 from residuals 1.3-2.5 times the
    linear start's (measured with the cubic alone). The start compares
    the two residuals and takes the smaller, so no step may start worse
    than from the linear start (up to the runs' own differences, which the
    tolerance of 5 % covers); taking the cubic alone fails this."""
    keys = dict(scene="scene='hang'", lattice="nx=129 ny=129", material="bending_model='none'",
                time="t_end=0.048 dt=0.004", output="output_interval=0.048")
    lin, _ = run(tmp_path, "linear", nranks=1, options=["-snes_monitor", "-nuno_newton_start", "linear"], **keys)
    aut, _ = run(tmp_path, "auto", nranks=1, options=["-snes_monitor"], **keys)
    assert "started consistent" in aut.stdout
    f_lin, f_aut = first_residuals(lin.stdout), first_residuals(aut.stdout)
    assert f_lin.shape == f_aut.shape == (12,)
    assert np.all(f_aut <= 1.05 * f_lin), np.c_[f_aut, f_lin]


def test_the_consistent_start_saves_the_second_newton_iteration(tmp_path):
    """-nuno_newton_start consistent, and auto (the default) which is it at
    fixed steps (issue 46 item 4, 47 item 6): the cubic start's positions
    made backward Euler's x_n + dt v. The cubic start extrapolates
    positions and velocities apart; its positions' miss, which Newton's
    first iteration puts right in full, moves the elastic forces and
    leaves a second iteration in many steps of drop_table's sheet falling
    free (33 x 33, area masses, 60 steps of 1 ms). With the positions
    consistent the start's position rows are exact and its velocity rows
    miss by the cubic's extrapolation error alone, so one iteration
    reaches the tolerance: nearly every step ends in one (at most 1.1 a
    step, and at most 0.8 times the cubic start's), and the states are
    the same (a start changes where Newton begins, not where it ends).
    The default's run is the consistent one's; before auto chose cubic
    here, and the default took the cubic's count."""
    from nunorun import contact_sheet, read_run
    counts, ends = {}, {}
    for start in ("cubic", "consistent", "auto"):
        d = tmp_path / start
        d.mkdir()
        options = [] if start == "auto" else ["-nuno_newton_start", start]
        proc, h5 = run(d, "fall", options=options, **contact_sheet("n_obstacles=0", 0.06, 0.06, n=33))
        last = [line for line in proc.stdout.splitlines() if line.startswith("t = ")][-1]
        counts[start] = int(re.search(r"newton\s+(\d+)", last).group(1))
        with read_run(str(h5)) as r:
            ends[start] = np.asarray(r.position)[-1]
    assert counts["consistent"] <= 1.1 * 60, counts
    assert counts["consistent"] <= 0.8 * counts["cubic"], counts
    assert np.abs(ends["consistent"] - ends["cubic"]).max() <= 1e-9, np.abs(ends["consistent"] - ends["cubic"]).max()
    assert counts["auto"] <= 1.1 * 60, counts
    assert np.array_equal(ends["auto"], ends["consistent"])
