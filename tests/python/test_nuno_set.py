# SPDX-License-Identifier: BSD-2-Clause
"""-nuno_set: namelist keys from the command line (issue 9 item 1). The
override changes the run exactly as the same key in the file would, is
validated with the file's messages, and is recorded in the output."""
import numpy as np
import pytest

from nunorun import read_run, run, run_and_read

LIFT = dict(scene="scene='lift_release'", lattice="nx=5 ny=5", time="t_end=0.004 dt=1e-3",
            output="output_interval=0.002")


def test_override_equals_the_same_keys_in_the_file(tmp_path):
    """nx, ny, dt and a string key from the command line give the run that
    the same values in the file give (positions compared bitwise)."""
    _, a = run_and_read(tmp_path, "file", nranks=2,
                        scene="scene='lift_release' lift_height=10.0", lattice="nx=7 ny=6",
                        time="t_end=0.004 dt=5e-4", output="output_interval=0.002")
    proc, hb = run(tmp_path, "cmd", nranks=2, options=(
        "-nuno_set", "nx=7,ny=6,time%dt=5e-4,lift_height=10.0,output_file='over.h5'"), **LIFT)
    assert not hb.exists() and (tmp_path / "over.h5").exists()
    b = read_run(str(tmp_path / "over.h5"))
    assert b.complete and np.asarray(b.position).shape == np.asarray(a.position).shape
    assert np.array_equal(np.asarray(a.position), np.asarray(b.position))
    assert np.array_equal(np.asarray(a.time), np.asarray(b.time))
    assert "-nuno_set nx=7,ny=6" in b.namelist


def test_scene_override_picks_that_scene_defaults(tmp_path):
    _, r = run_and_read(tmp_path, "sc", nranks=1, options=("-nuno_set", "scene='hang',nx=5,ny=5"),
                        time="t_end=0.002 dt=1e-3", output="output_interval=0.002")
    assert r.units() == "m"              # hang is the SI scene
    assert r.position[0].shape == (5, 5, 3)


def test_bad_overrides_are_one_line_errors_on_every_rank(tmp_path):
    for value, words in [("nz=3", "unknown key 'nz'"),
                         ("nx=2", "nx = 2 must be >= 3"),
                         ("nx=abc", "-nuno_set"),
                         ("257", "expected key=value")]:
        proc, h5 = run(tmp_path, "bad", nranks=3, check=False, options=("-nuno_set", value), **LIFT)
        assert proc.returncode != 0
        lines = [ln for ln in proc.stderr.splitlines() if ln.strip() and not ln.startswith(("-----", " ", "Primary", "a non-zero", "mpiexec", "the job", "Process", "Exit code", "  "))]
        assert len([ln for ln in lines if ln.startswith("nuno: error")]) == 1, proc.stderr
        assert words in proc.stderr, (value, proc.stderr)
        assert not h5.exists()


# Strict -nuno_set (issue 37 item 8): no key is dropped silently. Each case
# below ran on the old code as a different run than written (exit 0), or
# failed with a message that named neither the key nor what it expects.

def error_lines(proc):
    return [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]


def test_keys_separated_by_blanks_are_the_keys_separated_by_commas(tmp_path):
    """"nx=7 ny=6" (a blank between the keys) is the run of "nx=7,ny=6" and
    of the same keys in the file; the old code dropped ny (7 x 5)."""
    _, a = run_and_read(tmp_path, "file", nranks=2, scene="scene='lift_release'", lattice="nx=7 ny=6",
                        time="t_end=0.004 dt=1e-3", output="output_interval=0.002")
    _, b = run_and_read(tmp_path, "blank", nranks=2, options=("-nuno_set", "nx=7 ny=6"), **LIFT)
    assert np.asarray(b.position).shape == np.asarray(a.position).shape
    assert np.array_equal(np.asarray(a.position), np.asarray(b.position))
    assert "-nuno_set nx=7 ny=6" in b.namelist


def test_several_nuno_set_options_are_read_in_order(tmp_path):
    """-nuno_set nx=7 -nuno_set ny=6 -nuno_set "dt=5e-4": all three apply
    (the old code kept the last option only), and the output records each."""
    _, a = run_and_read(tmp_path, "file", nranks=2, scene="scene='lift_release'", lattice="nx=7 ny=6",
                        time="t_end=0.004 dt=5e-4", output="output_interval=0.002")
    _, b = run_and_read(tmp_path, "merged", nranks=2,
                        options=("-nuno_set", "nx=7", "-nuno_set", "ny=6", "-nuno_set", "dt=5e-4"), **LIFT)
    assert np.array_equal(np.asarray(a.position), np.asarray(b.position))
    assert np.array_equal(np.asarray(a.time), np.asarray(b.time))
    assert "-nuno_set nx=7 -nuno_set ny=6 -nuno_set dt=5e-4" in b.namelist


STRICT_CASES = {
    "empty_value": (["nx="], ["nx has no value"]),
    "empty_option": ([""], ["-nuno_set has no value"]),
    "slash": (["nx=7 / ny=9"], ["'/'", "nx=7"]),
    "repeated_key": (["nx=7,ny=6,nx=9"], ["nx is given twice", "nx=7", "nx=9"]),
    "repeated_across_options": (["nx=7", "ny=6 nx=9"], ["nx is given twice"]),
    "element_and_array": (["gravity=0,0,-9 gravity(3)=1"], ["gravity(3) is given twice"]),
    "real_for_integer": (["nx=33.5"], ["nx=33.5", "expected an integer"]),
    "word_for_real": (["e_s=abc"], ["e_s=abc", "expected a real number"]),
    "number_for_logical": (["write_velocity=3"], ["write_velocity=3", "expected a logical"]),
    "unquoted_string": (["output_file=foo.h5"], ["output_file=foo.h5", "quoted", "\"output_file='foo.h5'\""]),
    "wrong_group": (["lattice%dt=1e-3"], ["dt is a key of &time"]),
}


@pytest.mark.parametrize("case", sorted(STRICT_CASES))
def test_strict_overrides_refused_by_name_on_three_ranks(tmp_path, case):
    values, words = STRICT_CASES[case]
    options = [x for v in values for x in ("-nuno_set", v)]
    proc, h5 = run(tmp_path, "strict", nranks=3, check=False, options=options, **LIFT)
    assert proc.returncode != 0, proc.stdout[-2000:]
    errors = error_lines(proc)
    assert len(errors) == 1, proc.stderr
    for w in words:
        assert w in errors[0], (case, errors[0])
    assert not h5.exists() and not list(tmp_path.glob("*.h5")) and not list(tmp_path.glob("*.partial"))
