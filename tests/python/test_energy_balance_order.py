# SPDX-License-Identifier: BSD-2-Clause
"""The energy balance closes at the integrator's order (issue 10 item 2):
the dissipated energy and the constraint work are integrated over each step
with Gauss-Legendre points on the integrator's own interpolant (beuler,
theta, cn, bdf), not by the trapezoid rule over accepted steps (second
order whatever the method). Expectations: the balance
E_kin + E_stretch + E_bend + E_dissipated - W_external, a conservation law,
is constant up to the method's error, which falls at the method's order."""
import numpy as np
import pytest

from nunorun import run_and_read

# Free, dissipative (eta = 1 on every link), energy bending: a closed balance.
SCENE = dict(scene="scene='bend_release'", material="bending_model='energy'",
             output="output_interval=0.05")


def drift(r):
    b = np.asarray(r.energy_balance())
    scale = max(np.abs(np.asarray(r.energy[k])).max() for k in ("kinetic", "stretch", "bend"))
    return np.abs(b - b[0]).max() / scale


def test_tight_bdf4_closes_the_balance(tmp_path):
    """Measured 2.4e-9 of the largest energy, at the last output step, the
    same as with one output step (the output steps between bdf's steps are
    its interpolant's; issue 48); the trapezoid sums gave 5.7e-8 on the
    same run. (3.6e-10 was measured while every output step restarted bdf
    at first order: more and smaller steps, 1158 instead of 953.)"""
    _, r = run_and_read(tmp_path, "bdf4", nranks=2, time="t_end=0.5", **SCENE,
                        options=("-ts_type", "bdf", "-ts_bdf_order", "4", "-ts_adapt_type", "basic",
                                 "-ts_rtol", "1e-10", "-ts_atol", "1e-10"))
    assert r.complete
    assert drift(r) < 5e-9, drift(r)


def test_bdf4_balance_below_1e_10_at_a_tighter_tolerance(tmp_path):
    """The issue's bound, 1e-10 of the largest energy: at -ts_rtol 1e-10 the
    balance closes at 2.4e-9 (the state's own error, which the per-step
    error control allows), at 1e-11 at 2.1e-10, at 1e-12 below the bound
    (measured 1.6e-11, 2370 steps), falling about as the tolerance."""
    _, r = run_and_read(tmp_path, "bdf4t", nranks=2, time="t_end=0.5", **SCENE,
                        options=("-ts_type", "bdf", "-ts_bdf_order", "4", "-ts_adapt_type", "basic",
                                 "-ts_rtol", "1e-12", "-ts_atol", "1e-12"))
    assert r.complete
    assert drift(r) < 1e-10, drift(r)


@pytest.mark.parametrize("ts_type,order", [("cn", 2), ("beuler", 1)])
def test_balance_falls_at_the_method_order(tmp_path, ts_type, order):
    d = []
    for dt in (2e-3, 1e-3, 5e-4):
        _, r = run_and_read(tmp_path, f"{ts_type}{dt:g}", nranks=2, time="t_end=0.5", **SCENE,
                            options=("-ts_type", ts_type, "-ts_dt", repr(dt)))
        assert r.complete
        d.append(drift(r))
    observed = np.log2(np.array(d[:-1]) / np.array(d[1:]))
    assert np.all(np.abs(observed - order) < 0.25), (d, observed)
