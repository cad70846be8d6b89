# SPDX-License-Identifier: BSD-2-Clause
"""Bad input: one clear line naming the key and the value, a non-zero exit
on every rank, no hang, and no output file that looks like a result.
Everything runs on 3 ranks under a time bound."""
import subprocess

import pytest

from nunorun import exe, mpiexec

CASES = {
    "unknown_key": ("&lattice nx=5 ny=6 nz=3 /", ["&lattice", "nz"]),
    "nx_too_small": ("&lattice nx=2 ny=6 /", ["nx", "2"]),
    "negative_mass": ("&lattice total_mass=-1.0 /", ["total_mass", "-1"]),
    "wrong_type": ("&lattice nx='abc' /", ["nx", "abc"]),
    "unknown_scene": ("&scene scene='tablecloth' /", ["scene", "tablecloth"]),
    "unknown_spring_model": ("&material spring_model='cubic' /", ["spring_model", "cubic"]),
    "negative_dt": ("&time dt=-0.1 /", ["dt"]),
    "continuum_paper": ("&lattice lattice_scaling='continuum' /\n&material bending_model='paper' /",
                        ["continuum", "paper"]),
    "too_many_ranks_for_ny": ("&lattice nx=5 ny=5 /", ["ny = 5", "ranks"]),
    "bad_petsc_option_string": ("&output petsc_options='ts_type cn' /", ["petsc_options", "ts_type"]),
    # Outside the key table's bounds (issue 48 item 4: e_s = 1e308 ran and
    # ended with "try a smaller step").
    "stiffness_beyond_bound": ("&material e_s=1e308 /", ["e_s", "<= 1e30"]),
    "damping_beyond_bound": ("&material eta_b=1e31 /", ["eta_b", "<= 1e30"]),
    "mass_beyond_bound": ("&lattice total_mass=1e-300 /", ["total_mass", ">= 1e-30"]),
}


def launch(tmp_path, args, nranks=3):
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), *args]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_namelist_fails_cleanly_on_three_ranks(tmp_path, case):
    text, words = CASES[case]
    if "&output" not in text:
        text += "\n&output output_file='bad.h5' /"
    (tmp_path / "bad.nml").write_text(text + "\n")
    proc = launch(tmp_path, ["bad.nml"])
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr       # one line, from rank 0 only
    for w in words:
        assert w in errors[0], errors[0]
    assert not (tmp_path / "bad.h5").exists()
    assert not list(tmp_path.glob("*.h5"))


def test_missing_input_file(tmp_path):
    proc = launch(tmp_path, ["no_such_file.nml"])
    assert proc.returncode != 0
    assert "no_such_file.nml" in proc.stderr
    assert not list(tmp_path.glob("*.h5"))


def test_no_input_file_prints_usage(tmp_path):
    proc = launch(tmp_path, [])
    assert proc.returncode != 0
    assert "usage" in proc.stderr


def test_unknown_ts_type_stops_every_rank(tmp_path):
    (tmp_path / "ok.nml").write_text("&lattice nx=5 ny=6 /\n&output output_file='x.h5' /\n")
    proc = launch(tmp_path, ["ok.nml", "-ts_type", "no_such_method"])
    assert proc.returncode != 0
    assert "no_such_method" in proc.stdout + proc.stderr


def test_help(tmp_path):
    proc = launch(tmp_path, ["--help"], nranks=1)
    assert proc.returncode == 0
    assert "usage" in proc.stdout.lower() and "&lattice" in proc.stdout


# --- issue 48 item 4: the command line checked before the run ---------------

OK_NML = "&scene scene='hang' /\n&lattice nx=5 ny=6 /\n&time t_end=0.004 dt=1e-3 /\n&output output_file='x.h5' /\n"


def one_error(proc):
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


@pytest.mark.parametrize("args,words", [
    (["ts_max_steps", "1"], ["'ts_max_steps' (argument 2)", "-ts_max_steps"]),
    (["ok.nml"], ["'ok.nml' (argument 2)", "one input file"]),
    (["-ts_monitor", "ascii", "extra"], ["'extra' (argument 4)"]),
    (["-nuno_set", "nx=5", "ny=6"], ["'ny=6' (argument 4)", "-nuno_set"]),
])
def test_a_stray_word_is_refused_before_the_run(tmp_path, args, words):
    """PETSc skips a word that is neither an option nor an option's value:
    `nuno in.nml ts_max_steps 1` ran the whole scene, a second namelist file
    was ignored. Now one line names the word, on 3 ranks, nothing written."""
    (tmp_path / "ok.nml").write_text(OK_NML)
    proc = launch(tmp_path, ["ok.nml", *args])
    assert proc.returncode != 0
    line = one_error(proc)
    for w in words:
        assert w in line, line
    assert not list(tmp_path.glob("x.h5*"))


def test_option_values_and_negative_numbers_are_not_stray(tmp_path):
    (tmp_path / "ok.nml").write_text(OK_NML)
    proc = launch(tmp_path, ["ok.nml", "-ts_monitor", "-ts_max_steps", "2", "-snes_rtol", "1e-9",
                             "-nuno_set", "gravity=0,0,-9.81", "-ts_dt", "1e-3"])
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "x.h5").exists()


@pytest.mark.parametrize("args,words", [
    (["-options_file", "no_such.opts"], ["-options_file no_such.opts", "cannot read it", "No such file"]),
    (["-options_file"], ["-options_file needs a file name"]),
])
def test_a_missing_options_file_is_one_line_of_ours(tmp_path, args, words):
    """PETSc's failure to read an options file was its 15-line report from
    every rank inside PetscInitialize and an abort."""
    (tmp_path / "ok.nml").write_text(OK_NML)
    proc = launch(tmp_path, ["ok.nml", *args])
    assert proc.returncode != 0
    line = one_error(proc)
    for w in words:
        assert w in line, line
    assert "PETSC ERROR" not in proc.stderr + proc.stdout
    assert not list(tmp_path.glob("x.h5*"))


def test_an_options_file_that_exists_is_read(tmp_path):
    (tmp_path / "ok.nml").write_text(OK_NML)
    (tmp_path / "run.opts").write_text("-ts_max_steps 2\n")
    proc = launch(tmp_path, ["ok.nml", "-options_file", "run.opts"])
    assert proc.returncode == 0, proc.stderr
    assert "-ts_max_steps 2 reached" in proc.stdout


def test_petsc_help_without_an_input_prints_the_usage(tmp_path):
    proc = launch(tmp_path, ["-help"], nranks=1)
    assert proc.returncode == 0, proc.stderr
    assert "usage" in proc.stdout.lower() and "&lattice" in proc.stdout
