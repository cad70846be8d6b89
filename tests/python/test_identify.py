# SPDX-License-Identifier: BSD-2-Clause
"""Identification (&identify, docs/identification.md): exact gradients by
TSAdjoint against central differences of the objective, recovery of known
parameters from an observation nuno made itself, and the input errors."""
import re

import h5py
import numpy as np
import pytest

from nunorun import run

# Report scene, 11 x 11, short: the observation at 4 times.
LIFT = dict(scene="scene='lift_release'", time="t_end=0.2 dt=0.01")
TRUE = dict(e_s=1.0, e_d=1.0, eta_s=1.0, eta_d=1.0, k_b=1.0)


def material(values, extra=""):
    return " ".join(f"{k}={v}" for k, v in values.items()) + " " + extra


def observe(tmp_path, name, groups, output="output_interval=0.05"):
    """An observation made by nuno: its output file."""
    _, h5 = run(tmp_path, name, output=output, **groups)
    return h5


def gradient_errors(text):
    """{name: relative error} of the -identify_check_gradient lines."""
    return {m.group(1): float(m.group(2)) for m in
            re.finditer(r"identify: gradient (\w+) adjoint .* relerr\s+(\S+)", text)}


CASES = {
    # paper bending, pinned edge
    "paper": (dict(LIFT, material=material(TRUE)), dict(LIFT, material=material(
        dict(e_s=2.0, e_d=0.5, eta_s=3.0, eta_d=0.4, k_b=2.5))), "e_s,e_d,eta_s,eta_d,k_b,total_mass"),
    # energy bending with bending damping and gravity
    "energy": (dict(LIFT, material=material(dict(TRUE, k_b=10.0), "bending_model='energy' eta_b=1.0"),
                    scene="scene='lift_release' gravity=0,0,-100"),
               dict(LIFT, material=material(dict(e_s=2.0, e_d=0.5, eta_s=3.0, eta_d=0.4, k_b=25.0),
                                            "bending_model='energy' eta_b=0.3"),
                    scene="scene='lift_release' gravity=0,0,-100"),
               "e_s,e_d,eta_s,eta_d,k_b,eta_b,total_mass"),
    # no bending, a keyframed corner: windows at the keyframe times
    "none_keyframes": (dict(scene="scene='wave_point'", time="t_end=0.6 dt=0.02",
                            material=material(dict(e_s=1.0, e_d=1.0, eta_s=1.0, eta_d=1.0))),
                       dict(scene="scene='wave_point'", time="t_end=0.6 dt=0.02",
                            material=material(dict(e_s=3.0, e_d=0.5, eta_s=2.0, eta_d=0.3))),
                       "e_s,e_d,eta_s,eta_d,total_mass"),
}


@pytest.mark.parametrize("nranks", [1, 3])
@pytest.mark.parametrize("case", sorted(CASES))
def test_gradient_matches_central_differences(tmp_path, case, nranks):
    obs_groups, guess_groups, fit = CASES[case]
    obs = observe(tmp_path, "obs", obs_groups,
                  output="output_interval=0.1" if case == "none_keyframes" else "output_interval=0.05")
    proc, _ = run(tmp_path, "grad", nranks=nranks, options=["-identify_check_gradient"],
                  identify=f"observed_file='{obs.name}' fit='{fit}'", **guess_groups)
    errs = gradient_errors(proc.stdout)
    assert set(errs) == set(fit.split(",")), proc.stdout[-2000:]
    assert max(errs.values()) < 1e-6, errs


def fit_values(path):
    with h5py.File(path, "r") as f:
        g = f["identify"]
        names = [n.decode().strip() if isinstance(n, bytes) else str(n).strip() for n in g["names"][()]]
        return (dict(zip(names, g["values"][()])), dict(zip(names, g["uncertainty"][()])),
                float(g["objective"][()][0]), g["history"][()], f.attrs["status"])


@pytest.mark.parametrize("nranks", [1, 3])
def test_recovers_parameters_without_noise(tmp_path, nranks):
    obs = observe(tmp_path, "obs", dict(LIFT, material=material(TRUE)))
    start = dict(e_s=2.0, e_d=0.5, eta_s=3.0, eta_d=0.25, k_b=4.0)
    _, h5 = run(tmp_path, "fit", nranks=nranks, timeout=900,
                identify=f"observed_file='{obs.name}' fit='e_s,eta_s,k_b'",
                **dict(LIFT, material=material(dict(start, e_d=1.0, eta_d=1.0))))
    values, unc, objective, hist, status = fit_values(h5)
    status = status.decode() if isinstance(status, bytes) else status
    assert status == "complete"
    for k in ("e_s", "eta_s", "k_b"):
        assert abs(values[k] / TRUE[k] - 1) < 1e-6, (k, values[k])
    assert objective < 1e-10
    assert hist.shape[1] == 4 and hist[0, 0] > hist[-1, 0]


def test_recovers_parameters_within_uncertainty_with_noise(tmp_path):
    obs = observe(tmp_path, "obs", dict(LIFT, material=material(TRUE)))
    with h5py.File(obs, "r") as f:
        t, x = f["time"][()], f["position"][()]
    rng = np.random.default_rng(11)
    scale = 0.01 * np.sqrt(np.mean((x[1:] - x[0]) ** 2))   # 1 % of the motion
    noisy = tmp_path / "noisy.h5"
    with h5py.File(noisy, "w") as f:
        f["time"] = t
        f["position"] = x + scale * rng.standard_normal(x.shape)
    start = dict(e_s=3.0, e_d=1.0, eta_s=0.4, eta_d=1.0, k_b=2.0)
    _, h5 = run(tmp_path, "fit", timeout=900, identify="observed_file='noisy.h5' fit='e_s,eta_s,k_b'",
                **dict(LIFT, material=material(start)))
    values, unc, _, _, _ = fit_values(h5)
    for k in ("e_s", "eta_s", "k_b"):
        # (0.2 s of lift_release determines e_s to some 70 %, k_b to 1 %)
        assert 0 < unc[k] < 2 * TRUE[k], (k, unc[k])
        assert abs(values[k] - TRUE[k]) < 3 * unc[k], (k, values[k], unc[k])


def test_recovers_hang_parameters_without_noise(tmp_path):
    """hang 21 x 21 (SI, energy bending, gravity, pinned corners): e_s and k_b
    from 2.5x off; one rank, LU for the (transposed) solves."""
    groups = dict(scene="scene='hang'", time="t_end=0.2 dt=0.01")
    obs = observe(tmp_path, "obs", groups, output="output_interval=0.05")
    _, h5 = run(tmp_path, "fit", timeout=900, options=["-pc_type", "lu"],
                identify=f"observed_file='{obs.name}' fit='e_s,k_b'",
                material="e_s=250 k_b=0.04", **groups)
    values, unc, objective, _, _ = fit_values(h5)
    assert abs(values["e_s"] / 100.0 - 1) < 1e-6, values
    assert abs(values["k_b"] / 0.1 - 1) < 1e-6, values


@pytest.mark.parametrize("nranks", [1, 2])
@pytest.mark.parametrize("bad,expect", [
    ("fit='e_s,young'", "unknown parameter 'young'"),
    ("fit='e_s' observed_file='missing.h5'", "no such file"),
    ("fit='eta_b'", "eta_b"),
    ("fit='e_s' wrong_lattice", "/position is"),
])
def test_bad_identify_input_is_one_line_on_every_rank(tmp_path, nranks, bad, expect):
    obs = observe(tmp_path, "obs", dict(LIFT, material=material(TRUE)))
    lattice = "nx=9 ny=11" if "wrong_lattice" in bad else "nx=11 ny=11"
    bad = bad.replace("wrong_lattice", "")
    if "observed_file" not in bad:
        bad += f" observed_file='{obs.name}'"
    proc, _ = run(tmp_path, "bad", nranks=nranks, check=False, identify=bad, lattice=lattice,
                  **dict(LIFT, material=material(TRUE)))
    assert proc.returncode == 1, proc.stdout[-1000:] + proc.stderr[-1000:]
    lines = [ln for ln in (proc.stdout + proc.stderr).splitlines() if "error" in ln]
    assert len(lines) == 1 and expect in lines[0], lines
