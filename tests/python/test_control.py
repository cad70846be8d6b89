# SPDX-License-Identifier: BSD-2-Clause
"""Deformation control (&control, docs/identification.md): the exact
gradient with respect to the keyframe positions against central differences
of the objective, a target made by nuno from known keyframes recovered from
a perturbed start, the speed bound, the /control output, and the input
errors."""
import os
import re
import subprocess

import h5py
import numpy as np
import pytest

from nunorun import exe, mpiexec, namelist, run
from postprocess.reader import read_run

# wave_point, 11 x 11, 0.6 s: keyframes at 0, 0.3, 0.6 s.
TIMES = "keyframe_time=0,0.3,0.6"
TIME = "t_end=0.6 dt=0.02"
TRUE = np.array([[0.0, 0.0, 0.0], [5.0, 2.0, -10.0], [-3.0, 4.0, 15.0]])   # [keyframe][x, y, z], mm
GUESS = np.array([[0.0, 0.0, 0.0], [3.0, 1.0, -5.0], [-1.0, 2.0, 10.0]])


def path(offsets, extra=""):
    """&scene keys of wave_point with this keyframe path."""
    keys = " ".join(f"keyframe_d{c}={','.join(repr(float(v)) for v in offsets[:, n])}" for n, c in enumerate("xyz"))
    return f"scene='wave_point' {TIMES} {keys} {extra}"


def target(tmp_path, offsets, scene_extra="", output="output_interval=0.3", **groups):
    """A target made by nuno: its output file (positions and velocities)."""
    groups.setdefault("time", TIME)
    _, h5 = run(tmp_path, "target", scene=path(offsets, scene_extra),
                output=f"{output} write_velocity=.true.", **groups)
    return h5


def gradient_errors(text):
    """{label: relative error} of the -control_check_gradient lines."""
    return {m.group(1): float(m.group(2)) for m in
            re.finditer(r"control: gradient (\S+) adjoint .* relerr\s+(\S+)", text)}


CASES = {
    # no bending, the corner; targets at 0.2 and 0.4 s (mid-segment window
    # starts), velocities weighed, a Tikhonov term, a speed bound
    "corner_none": (dict(), "output_interval=0.2",
                    "components='xyz' velocity_weight=0.3 keyframe_tikhonov=0.5 max_speed=100"),
    # paper bending, the corner in z and x
    "corner_paper": (dict(material="bending_model='paper'"), "output_interval=0.3", "components='xz'"),
    # energy bending with bending damping, the edge i = 0 as a gripper
    # (driven nodes on every rank), released at 0.5 s, velocities weighed
    "edge_energy": (dict(material="bending_model='energy' k_b=10 eta_b=2", scene_extra="wave_nodes='edge' release_time=0.5",
                         time="t_end=0.7 dt=0.02"), "output_interval=0.2",
                    "components='xyz' velocity_weight=0.3"),
}


@pytest.mark.parametrize("nranks", [1, 3])
@pytest.mark.parametrize("case", sorted(CASES))
def test_gradient_matches_central_differences(tmp_path, case, nranks):
    groups, output, control = CASES[case]
    groups = dict(groups)
    extra = groups.pop("scene_extra", "")
    tgt = target(tmp_path, TRUE, extra, output, **groups)
    groups.setdefault("time", TIME)
    proc, _ = run(tmp_path, "grad", nranks=nranks, options=["-control_check_gradient"],
                  scene=path(GUESS, extra), control=f"target_file='{tgt.name}' {control}", **groups)
    errs = gradient_errors(proc.stdout)
    comps = re.search(r"components='(\w+)'", control).group(1)
    assert set(errs) == {f"keyframe_d{c}({m})" for c in comps for m in (2, 3)}, proc.stdout[-2000:]
    assert max(errs.values()) < 1e-6, errs


def control_group(h5):
    with h5py.File(h5, "r") as f:
        g = f["control"]
        return ({k: g[k][()] for k in g}, g.attrs["components"], f.attrs["status"])


def text(value):
    return value.decode() if isinstance(value, bytes) else str(value)


def test_recovers_known_keyframes(tmp_path):
    """The target is nuno's own motion under TRUE; from GUESS the optimiser
    finds TRUE again and the objective goes to 0. The written motion is the
    optimised one: its corner sits at rest + the optimised offsets at the
    keyframe times."""
    tgt = target(tmp_path, TRUE)
    _, h5 = run(tmp_path, "opt", timeout=600, scene=path(GUESS), time=TIME, output="output_interval=0.3",
                control=f"target_file='{tgt.name}'")
    g, comps, status = control_group(h5)
    assert text(status) == "complete" and text(comps) == "xyz"
    np.testing.assert_allclose(g["keyframe_offset"], TRUE, rtol=0, atol=1e-6 * 15)
    np.testing.assert_array_equal(g["initial_offset"], GUESS)
    np.testing.assert_array_equal(g["keyframe_time"], [0.0, 0.3, 0.6])
    assert g["objective"][0] < 1e-10
    hist, khist = g["objective_history"], g["keyframe_history"]
    assert khist.shape == (len(hist), 3, 3)
    np.testing.assert_array_equal(khist[0], GUESS)
    assert hist[0] > 1.0 and hist[-1] < 1e-10
    assert np.isinf(g["max_speed"][0])
    r = read_run(h5)
    for t, off in zip((0.3, 0.6), TRUE[1:]):
        k = r.step_index(t)
        np.testing.assert_allclose(r.position[k][0, 0], r.rest_position[0, 0] + off, rtol=0, atol=1e-5)
    np.testing.assert_allclose(r.config["scene"]["keyframe_dz"], TRUE[:, 2], rtol=0, atol=1e-5)


@pytest.mark.parametrize("nranks", [1, 3])
def test_speed_bound_holds_and_binds(tmp_path, nranks):
    """z only, max_speed 30 mm/s: the target's first segment needs 33 mm/s
    (-10 mm in 0.3 s), the second 83 mm/s. The optimum keeps every segment
    within the bound, sits on it for the second, and cannot reach the target
    (objective > 0), while the same problem without the bound does (< 1e-8)."""
    tgt = target(tmp_path, TRUE)
    start = TRUE.copy()
    start[1:, 2] = [-5.0, 0.0]                    # speeds 16.7 and 16.7 mm/s
    bounded = dict(scene=path(start), time=TIME, output="output_interval=0.3")
    _, h5 = run(tmp_path, "bounded", nranks=nranks, timeout=600,
                control=f"target_file='{tgt.name}' components='z' max_speed=30", **bounded)
    g, _, _ = control_group(h5)
    speeds = np.abs(np.diff(g["keyframe_offset"][:, 2])) / 0.3
    assert speeds.max() <= 30 * (1 + 1e-12), speeds
    assert abs(speeds[1] - 30) < 1e-9, speeds
    np.testing.assert_array_equal(g["keyframe_offset"][:, :2], TRUE[:, :2])    # x, y not optimised
    assert g["max_speed"][0] == 30.0
    assert g["objective"][0] > 1.0
    _, h5 = run(tmp_path, "free", nranks=nranks, timeout=600,
                control=f"target_file='{tgt.name}' components='z'", **bounded)
    free, _, _ = control_group(h5)
    assert free["objective"][0] < 1e-8
    np.testing.assert_allclose(free["keyframe_offset"][:, 2], TRUE[:, 2], rtol=0, atol=1e-5)


def test_help_lists_the_check_option(tmp_path):
    tgt = target(tmp_path, TRUE, lattice="nx=5 ny=6")
    proc, _ = run(tmp_path, "help", options=["-control_check_gradient", "-help"], scene=path(GUESS), time=TIME,
                  lattice="nx=5 ny=6", control=f"target_file='{tgt.name}' components='z'")
    assert "-control_check_gradient: <FALSE : TRUE>" in proc.stdout
    assert "-identify_check_gradient: <FALSE" in proc.stdout


# --------------------------------------------------------------------------
# Bad input: one line on stderr, exit 1, no output file, on every rank count

BAD = {
    "component": ("components='xw'", {}, "components = 'xw' must be letters among x, y, z"),
    "component_twice": ("components='zxz'", {}, "names z twice"),
    "max_speed_negative": ("max_speed=-1", {}, "max_speed = -1.0 must be > 0"),
    "max_speed_initial": ("max_speed=20", {}, "keyframe_dz(3) - keyframe_dz(2) = 15.0 in 0.3 is a speed of 50.0"),
    "velocity_weight": ("velocity_weight=-0.5", {}, "velocity_weight = -0.5 must be >= 0"),
    "tikhonov_nan": ("keyframe_tikhonov=NaN", {}, "keyframe_tikhonov = NaN must be a finite number"),
    "unknown_key": ("speed=3", {}, "speed"),
    "no_target": ("", {}, "target_file is required"),
    "missing_target": ("target_file='missing.h5'", {}, "target_file 'missing.h5': no such file"),
    "wrong_lattice": ("", dict(lattice="nx=9 ny=11"), "/position is [3][11][11][3] but the run needs"),
    "no_keyframed_nodes": ("", dict(scene="scene='lift_release'"), "scene = 'lift_release' has no nodes on a keyframe path"),
    "one_keyframe": ("", dict(scene="scene='wave_point' n_keyframes=1"), "n_keyframes = 1 leaves nothing to optimise"),
    "with_identify": ("", dict(identify="observed_file='target.h5' fit='e_s'"), "&control and &identify cannot be in one input"),
}


@pytest.fixture(scope="module")
def bad_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_control")
    target(d, GUESS)
    return d


@pytest.mark.parametrize("nranks", [1, 3])
@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_control_input_is_one_line(bad_dir, case, nranks):
    keys, groups, expect = BAD[case]
    if "target_file" not in keys and case != "no_target":
        keys += " target_file='target.h5'"
    groups = dict(groups)
    groups.setdefault("scene", path(GUESS))
    name = f"bad_{case}_{nranks}"
    nml = bad_dir / f"{name}.nml"
    nml.write_text(namelist(f"{name}.h5", time=TIME, control=keys, **groups))
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    proc = subprocess.run([mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), nml.name], cwd=bad_dir,
                          capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 1, proc.stdout[-1000:] + proc.stderr[-1000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("nuno: error") and expect in lines[0], proc.stderr
    assert not (bad_dir / f"{name}.h5").exists()
