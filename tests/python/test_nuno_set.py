"""-nuno_set: namelist keys from the command line (issue 9 item 1). The
override changes the run exactly as the same key in the file would, is
validated with the file's messages, and is recorded in the output."""
import numpy as np

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
