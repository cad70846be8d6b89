# SPDX-License-Identifier: BSD-2-Clause
"""The default integrator of adaptive runs (issue 10 item 6): with only
-ts_adapt_type basic, a run uses the method that won the work-precision
measurement at moderate tolerance (docs/workprecision.md, "The default of
adaptive runs": PETSc's Rosenbrock-W ra34pw2); an explicit -ts_type always
wins; fixed steps stay backward Euler (the report's scheme). The expected
values are the documented ones: a change of the default that does not go
through the docs, README and --help fails here."""
import re
import subprocess

from nunorun import ROOT, exe, run, run_and_read

# docs/workprecision.md, "The default of adaptive runs"; README.md; nuno --help.
DEFAULT = ("rosw", "ra34pw2")
KW = dict(scene="scene='bend_release'", material="bending_model='energy'",
          time="t_end=0.05", output="output_interval=0.05")


def solver_line(stdout):
    return next(ln for ln in stdout.splitlines() if ln.startswith("solver    :"))


def test_only_adaptive_steps_asked_gets_the_measured_default(tmp_path):
    proc, r = run_and_read(tmp_path, "d", options=("-ts_adapt_type", "basic", "-ts_view"), **KW)
    assert r.complete
    assert r.run_info["ts_type"] == DEFAULT[0] and r.run_info["ts_adapt_type"] == "basic"
    line = solver_line(proc.stdout)
    assert line.startswith(f"solver    : TS {DEFAULT[0]} {DEFAULT[1]} (the default of adaptive runs"), line
    assert re.search(rf"Rosenbrock-W {DEFAULT[1]}\b", proc.stdout), proc.stdout[-2000:]
    # Its scheme's options still apply.
    proc, r = run_and_read(tmp_path, "sub", options=("-ts_adapt_type", "basic", "-ts_rosw_type", "rodas3"), **KW)
    assert r.run_info["ts_type"] == "rosw" and "TS rosw rodas3 (the default" in solver_line(proc.stdout)


def test_explicit_ts_type_wins_and_fixed_steps_stay_beuler(tmp_path):
    proc, r = run_and_read(tmp_path, "bdf", options=("-ts_type", "bdf", "-ts_adapt_type", "basic"), **KW)
    assert r.run_info["ts_type"] == "bdf"
    assert "TS bdf order 2, adapt basic" in solver_line(proc.stdout)
    proc, r = run_and_read(tmp_path, "fixed", **KW)
    assert r.run_info["ts_type"] == "beuler" and r.run_info["ts_adapt_type"] == "none"
    assert "(the default of adaptive runs" not in solver_line(proc.stdout)
    proc, r = run_and_read(tmp_path, "none", options=("-ts_adapt_type", "none"), **KW)
    assert r.run_info["ts_type"] == "beuler"
    # In the namelist's petsc_options as on the command line.
    kw = dict(KW, output="output_interval=0.05 petsc_options='-ts_adapt_type basic'")
    proc, r = run_and_read(tmp_path, "nml", **kw)
    assert r.run_info["ts_type"] == DEFAULT[0]


def test_the_default_is_an_option_shown_by_help(tmp_path):
    proc, r = run_and_read(tmp_path, "opt", options=("-ts_adapt_type", "basic", "-nuno_adaptive_ts_type", "bdf"), **KW)
    assert r.run_info["ts_type"] == "bdf"
    proc, _ = run(tmp_path, "help", options=("-help",), **KW)
    m = re.search(r"-nuno_adaptive_ts_type <now (\w+)", proc.stdout)
    assert m and m.group(1) == DEFAULT[0], proc.stdout[-3000:]


def test_help_and_readme_name_the_default():
    text = subprocess.run([exe(), "--help"], capture_output=True, text=True, timeout=60).stdout
    assert re.search(rf"without -ts_type they\s+use {DEFAULT[0]} \(Rosenbrock-W {DEFAULT[1]}",
                     re.sub(r"\s+", " ", text)), text
    assert "-nuno_adaptive_ts_type" in text and "Which integrator for which goal" in text
    readme = re.sub(r"\s+", " ", (ROOT / "README.md").read_text())
    assert f"`-ts_adapt_type basic` alone uses `{DEFAULT[0]}` ({DEFAULT[1]}," in readme


def test_identification_keeps_backward_euler(tmp_path):
    """An identification's adjoint needs a theta method: with -ts_adapt_type
    basic and no -ts_type it stays beuler (docs/workprecision.md)."""
    groups = dict(scene="scene='lift_release'", lattice="nx=5 ny=5", time="t_end=0.04 dt=0.01")
    _, obs = run(tmp_path, "obs", output="output_interval=0.02", **groups)
    proc, _ = run(tmp_path, "id", options=("-ts_adapt_type", "basic", "-identify_check_gradient"),
                  identify=f"observed_file='{obs.name}' fit='k_b'", output="output_interval=0.02", **groups)
    line = solver_line(proc.stdout)
    assert line.startswith("solver    : TS beuler, adapt basic"), line
