# SPDX-License-Identifier: BSD-2-Clause
"""Output never changes the solution (issue 48 item 1): for every TS type
nuno offers, a run that writes an output step every 0.02 s ends where the
run that writes only its last one ends. Output times are reached by the
integrator's interpolant (TSInterpolate after the step that passes them),
so adaptive runs and fixed steps that do not land on the output times take
the same steps and end bit for bit at the same state; fixed steps that do
land on them write the step's own state, and the output step is a restart
point as before (the solver's aids start afresh there, so that a restart
repeats the run bit for bit: round-off, never a restart of bdf's history).
Before, every output time stopped the integrator and restarted bdf at
first order: adaptive bdf4 ended 5e-4 of the cloth size away on hang,
fixed-step bdf2 4e-5.

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
    assert "outputs   : from the TS's interpolant" in many[0].stdout, many[0].stdout


@pytest.mark.parametrize("name", list(FIXED))
def test_fixed_steps_off_the_output_times_end_bit_for_bit(tmp_path, name):
    """dt = 3 ms does not divide 0.02 s: the steps no longer shrink to end
    on each output time (before: the last two before it, to 2.5 ms each)."""
    one, many = one_and_many(tmp_path, "f", FIXED[name], 3e-3)
    assert np.array_equal(one[2][-1], many[2][-1]), np.abs(one[2][-1] - many[2][-1]).max()


@pytest.mark.parametrize("name", list(FIXED))
def test_fixed_steps_on_the_output_times_end_within_round_off(tmp_path, name):
    """dt = 5 ms divides 0.02 s: each output step is the step's own state
    and a restart point (the solver's aids start afresh there, as at a
    restart); that changes the last bits only (hang 21 x 21: 1e-13 to 6e-12
    of the cloth size), never bdf's history (before: 4e-5 for bdf2)."""
    one, many = one_and_many(tmp_path, "g", FIXED[name], 5e-3)
    err = np.abs(one[2][-1] - many[2][-1]).max()
    assert err < 1e-10, err


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


def test_a_method_without_an_interpolant_stops_at_the_output_times(tmp_path):
    """rosw rodas3 has no interpolant in PETSc 3.18: its output times stay
    stops of the integrator (said at the start); the run ends within the
    tolerance of the one-output run."""
    opts = ("-ts_type", "rosw", "-ts_rosw_type", "rodas3", *ADAPT)
    one, many = one_and_many(tmp_path, "r", opts, 1e-3)
    assert "outputs   : the integrator stops at every output time" in many[0].stdout, many[0].stdout
    err = np.abs(one[2][-1] - many[2][-1]).max()
    assert 0 < err < 1e-3, err
