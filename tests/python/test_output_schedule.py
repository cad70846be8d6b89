# SPDX-License-Identifier: BSD-2-Clause
"""Output never changes the solution (issue 48 item 1): for every TS type
nuno offers, a run that writes an output step every 0.02 s ends bit for
bit where the run that writes only its last one ends, with fixed and with
adaptive steps. The integrator stops only at keyframes, releases and
t_end; an output time is written from the state of the step that ends on
it, or else from the integrator's interpolant (TSInterpolate after the
step that passes it), and nothing in the solver starts afresh there.
Before, every output time stopped the integrator, restarted bdf at first
order and started the solver's aids afresh: adaptive bdf4 ended 5e-4 of
the cloth size away on hang, fixed-step bdf2 4e-5, the Baraff-Witkin mode
1e-2 (hang 21 x 21, dt = 10 ms, t = 1 s), backward Euler 1e-13.

The expectation is always the run with one output step, never the
program's own numbers pasted in."""
import numpy as np
import pytest

from nunorun import run_and_read

# hang: 1 m cloth, two corners pinned, bending with damping, gravity; 0.2 s.
HANG = dict(scene="scene='hang'", lattice="nx=9 ny=7", output="write_velocity=.true.")
T_END = 0.2
ADAPT = ("-ts_adapt_type", "basic", "-ts_rtol", "1e-4")

FIXED = {
    "beuler": (),
    "cn": ("-ts_type", "cn"),
    "theta": ("-ts_type", "theta"),
    "bdf": ("-ts_type", "bdf"),
    "arkimex": ("-ts_type", "arkimex", "-ts_arkimex_fully_implicit"),
    "rosw": ("-ts_type", "rosw"),
}
ADAPTIVE = {
    "default (rosw ra34pw2)": ADAPT,
    "beuler": ("-ts_type", "beuler", *ADAPT),
    "cn": ("-ts_type", "cn", *ADAPT),
    "bdf2": ("-ts_type", "bdf", *ADAPT),
    "bdf4": ("-ts_type", "bdf", "-ts_bdf_order", "4", *ADAPT),
    "arkimex3": ("-ts_type", "arkimex", "-ts_arkimex_fully_implicit", *ADAPT),
    "arkimex5": ("-ts_type", "arkimex", "-ts_arkimex_type", "5", "-ts_arkimex_fully_implicit", *ADAPT),
}


def ends(tmp_path, name, options, dt, every):
    """The run's output times, last position and velocity, with an output
    step every `every` seconds."""
    groups = dict(HANG, time=f"t_end={T_END} dt={dt}", output=HANG["output"] + f" output_interval={every}")
    proc, r = run_and_read(tmp_path, name, options=options, **groups)
    with r:
        assert r.complete
        return proc, np.asarray(r.time), np.asarray(r.position), np.asarray(r.velocity)


def one_and_many(tmp_path, name, options, dt):
    """(the run with one output step, the run with one every 0.02 s)."""
    one = ends(tmp_path, name + "_one", options, dt, T_END)
    many = ends(tmp_path, name + "_many", options, dt, 0.02)
    np.testing.assert_allclose(many[1], np.linspace(0.0, T_END, 11), rtol=0, atol=1e-12)
    return one, many


@pytest.mark.parametrize("name", list(ADAPTIVE))
def test_adaptive_steps_end_bit_for_bit_where_one_output_step_ends(tmp_path, name):
    one, many = one_and_many(tmp_path, "a", ADAPTIVE[name], 1e-3)
    assert np.array_equal(one[2][-1], many[2][-1]), np.abs(one[2][-1] - many[2][-1]).max()
    assert np.array_equal(one[3][-1], many[3][-1])
    assert "outputs   : the state of a step that ends on the output time, else the TS's interpolant" in many[0].stdout, many[0].stdout


@pytest.mark.parametrize("name", list(FIXED))
def test_fixed_steps_off_the_output_times_end_bit_for_bit(tmp_path, name):
    """dt = 3 ms does not divide 0.02 s: the steps no longer shrink to end
    on each output time (before: the last two before it, to 2.5 ms each)."""
    one, many = one_and_many(tmp_path, "f", FIXED[name], 3e-3)
    assert np.array_equal(one[2][-1], many[2][-1]), np.abs(one[2][-1] - many[2][-1]).max()


@pytest.mark.parametrize("name", [*FIXED, "Baraff-Witkin"])
def test_fixed_steps_on_the_output_times_end_bit_for_bit(tmp_path, name):
    """dt = 5 ms divides 0.02 s: each output step is the step's own state
    (before: bdf2 restarted, and every method's aids started afresh: 1e-13
    to 6e-12 of the cloth size for backward Euler's Newton, 4e-5 for bdf2,
    and the Baraff-Witkin mode, whose one inexact linear solve a step starts
    from the extrapolated state, 1e-3 here)."""
    opts = FIXED.get(name, ("-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3"))
    one, many = one_and_many(tmp_path, "g", opts, 5e-3)
    assert np.array_equal(one[2][-1], many[2][-1]), np.abs(one[2][-1] - many[2][-1]).max()
    assert np.array_equal(one[3][-1], many[3][-1])


def test_interpolated_output_steps_are_as_accurate_as_the_steps(tmp_path):
    """The output steps of adaptive bdf4 between its steps (TSInterpolate,
    its Lagrange polynomial) are within the tolerance of a tight run's, as
    its step ends are; the energy balance at them closes as at the end."""
    _, t, x, _ = ends(tmp_path, "ref", ("-ts_type", "bdf", "-ts_bdf_order", "5", "-ts_adapt_type", "basic",
                                        "-ts_rtol", "1e-10"), 1e-3, 0.02)
    proc, t4, x4, _ = ends(tmp_path, "bdf4", ADAPTIVE["bdf4"], 1e-3, 0.02)
    err = np.linalg.norm(x4 - x, axis=-1).max(axis=(1, 2))
    print("bdf4 rtol 1e-4, error at the output steps", err)
    assert err.max() < 1e-3, err
    # not one step's error larger than the final one by far: no jump at the
    # interpolated steps (a wrong interpolant is 1e2 off: see nuno_signals.c)
    assert err.max() < 20 * max(err[-1], 1e-6), err


@pytest.mark.parametrize("method", [("rosw", t) for t in ("ra34pw2", "ra3pw", "assp3p3s1c", "theta1", "theta2")] +
                         [("arkimex", t) for t in ("a2", "ars122", "2c", "2d", "2e", "3", "4", "5")])
def test_every_interpolant_nuno_uses_is_right(tmp_path, method):
    """The tableaus whose dense output nuno uses (nuno_ts_interpolates,
    from a probe of PETSc 3.18.5, where rosw lassp3p4s2c's was 300 times
    off): every output step of an adaptive run (of fixed steps of 3 ms,
    which do not land on the output times, for theta1 and theta2, which
    have no error estimate) within 20 times its final error of the tight
    reference's."""
    ts, sub = method
    _, _, x, _ = ends(tmp_path, "ref", ("-ts_type", "bdf", "-ts_bdf_order", "5", "-ts_adapt_type", "basic",
                                        "-ts_rtol", "1e-10"), 1e-3, 0.02)
    fixed = sub in ("theta1", "theta2")
    opts = ("-ts_type", ts, f"-ts_{ts}_type", sub, *(("-ts_arkimex_fully_implicit",) if ts == "arkimex" else ()),
            *(() if fixed else ADAPT))
    proc, _, xm, _ = ends(tmp_path, "m", opts, 3e-3 if fixed else 1e-3, 0.02)
    assert "outputs   : the state of a step that ends on the output time, else the TS's interpolant" in proc.stdout, proc.stdout
    err = np.linalg.norm(xm - x, axis=-1).max(axis=(1, 2))
    print(method, "error at the output steps", err)
    assert err.max() < 20 * max(err[-1], 1e-6), err


def test_a_method_without_an_interpolant_stops_at_the_output_times(tmp_path):
    """rosw rodas3 has no interpolant in PETSc 3.18: its output times stay
    stops of the integrator (said at the start); the run ends within the
    tolerance of the one-output run."""
    opts = ("-ts_type", "rosw", "-ts_rosw_type", "rodas3", *ADAPT)
    one, many = one_and_many(tmp_path, "r", opts, 1e-3)
    assert "outputs   : the integrator stops at every output time" in many[0].stdout, many[0].stdout
    err = np.abs(one[2][-1] - many[2][-1]).max()
    assert 0 < err < 1e-3, err


def test_a_checkpoint_at_an_interpolated_output_step_continues_the_run(tmp_path):
    """Adaptive steps: the checkpoint_interval checkpoint of an output step
    between two steps holds the state of the step that passed it (its time
    after the output time, its restart point); a run killed after it and
    continued from it writes the same output times and ends within the
    tolerance of the run that went through (the restart starts bdf
    afresh)."""
    from nunorun import run, series
    import h5py
    opts = ADAPTIVE["bdf4"]
    groups = dict(HANG, time=f"t_end={T_END} dt=1e-3", output=HANG["output"] + " output_interval=0.02")
    _, full = run(tmp_path, "full", options=opts, **groups)
    half = dict(groups, output=groups["output"] + " checkpoint_interval=0.1")
    proc, h5 = run(tmp_path, "half", options=opts, **half)
    with h5py.File(h5, "r+") as f:
        cks = {float(g.attrs["time"]): g for g in f["checkpoint"].values()}
        mid = [t for t in cks if 0.1 < t < 0.11]
        assert mid, sorted(cks)              # after the output time 0.1, before the next step's end
        assert float(cks[mid[0]].attrs["t_written"]) == pytest.approx(0.1, abs=1e-12)
        for t, g in cks.items():             # as if killed before its end
            if t == pytest.approx(T_END):
                g.attrs["sequence"] = np.int32(0)
    proc, _ = run(tmp_path, "half", options=["-nuno_restart", str(h5), *opts], **half)
    assert "(checkpoint_interval)" in proc.stdout, proc.stdout
    a, _ = series(full)
    b, status = series(h5)
    assert status == "complete"
    assert np.array_equal(a["time"], b["time"])
    assert np.array_equal(a["position"][:6], b["position"][:6])
    err = np.abs(a["position"] - b["position"]).max()
    assert 0 < err < 1e-4, err
