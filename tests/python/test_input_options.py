# SPDX-License-Identifier: BSD-2-Clause
"""Options checked before the run (issue 48 item 4), on 3 ranks: an option
that nothing read is refused before the first step naming the nearest option
the run knows, an integer option beyond PETSc's integers is refused (3.18
wrapped -ts_max_steps 4294967297 to 1 and reported complete), a TS type that
nuno's residual cannot run is refused at set-up (euler failed at the first
step), and -help prints and exits without running or writing anything. Each
refusal leaves no output file, no .partial and no lock; the options PETSc
reads only later (viewers, reports, the solvers of the first solve) and the
documented ones still run. The refusals failed on the old code (it ran, or
failed during the run after making the file)."""
import subprocess

import pytest

from nunorun import exe, mpiexec, namelist

GROUPS = dict(scene="scene='hang'", lattice="nx=9 ny=9", time="t_end=0.004 dt=1e-3",
              output="output_interval=0.002")


def launch(tmp_path, options, nranks=3, name="o"):
    nml = tmp_path / f"{name}.nml"
    nml.write_text(namelist(f"{name}.h5", **GROUPS))
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), nml.name, *options]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=180)


def refused(tmp_path, options, words):
    proc = launch(tmp_path, options)
    assert proc.returncode != 0, proc.stdout[-2000:]
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr        # one line, from rank 0 only
    for w in words:
        assert w in errors[0], errors[0]
    assert not [ln for ln in proc.stdout.splitlines() if ln.startswith("t =")], "the time loop started"
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith("o.h5")], list(tmp_path.iterdir())
    return errors[0]


@pytest.mark.parametrize("options,words", [
    (["-ts_tpye", "cn"], ["-ts_tpye cn", "did you mean -ts_type?"]),
    (["-snes_monitr"], ["-snes_monitr", "did you mean -snes_monitor?"]),
    (["-ts_adapt", "basic"], ["-ts_adapt basic", "did you mean -ts_adapt_type?"]),
    (["-nuno_mg_level", "3"], ["-nuno_mg_level 3", "did you mean -nuno_mg_levels?"]),
    (["-reduced_ksp_rtoll", "1e-3"], ["did you mean -reduced_ksp_rtol?"]),
    (["-foo_bar", "-ts_tpye", "cn"], ["-foo_bar", "-ts_tpye cn (did you mean -ts_type?)", "not options of this run"]),
])
def test_an_option_nothing_reads_is_refused_before_the_first_step(tmp_path, options, words):
    refused(tmp_path, options, words)


def test_an_option_in_petsc_options_is_checked_too(tmp_path):
    GROUPS_OPT = dict(GROUPS, output="output_interval=0.002 petsc_options='-ts_tpye cn'")
    nml = tmp_path / "o.nml"
    nml.write_text(namelist("o.h5", **GROUPS_OPT))
    proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), "o.nml"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=180)
    assert proc.returncode != 0
    assert "did you mean -ts_type?" in proc.stderr
    assert not list(tmp_path.glob("o.h5*"))


@pytest.mark.parametrize("value", ["4294967297", "-4294967295"])
def test_an_integer_option_beyond_petscs_integers_is_refused(tmp_path, value):
    refused(tmp_path, ["-ts_max_steps", value], [f"-ts_max_steps {value}", "beyond the integers",
                                                 "PETSc would read it as 1"])


def test_an_integer_beyond_a_long_is_refused_too(tmp_path):
    """strtol saturates: PETSc reads -1, which the set-up refuses first."""
    refused(tmp_path, ["-ts_max_steps", "99999999999999999999999"], ["-ts_max_steps"])


def test_an_integer_of_nunos_own_options_is_checked(tmp_path):
    refused(tmp_path, ["-nuno_pc_lag", "4294967298"], ["-nuno_pc_lag 4294967298", "read it as 2"])


@pytest.mark.parametrize("options,words", [
    (["-ts_type", "euler"], ["-ts_type euler", "explicit method", "beuler, cn, theta"]),
    (["-ts_type", "rk"], ["-ts_type rk", "explicit method"]),
    (["-ts_type", "glee"], ["-ts_type glee", "explicit method"]),
    (["-ts_type", "pseudo"], ["-ts_type pseudo", "nuno runs the implicit methods"]),
    (["-ts_adapt_type", "basic", "-nuno_adaptive_ts_type", "ssp"], ["-nuno_adaptive_ts_type ssp", "explicit"]),
])
def test_a_ts_type_nuno_cannot_run_is_refused_at_set_up(tmp_path, options, words):
    refused(tmp_path, options, words)


@pytest.mark.parametrize("ts_type", ["beuler", "cn", "theta", "alpha", "bdf", "arkimex", "rosw", "eimex", "glle"])
def test_every_ts_type_nuno_runs_completes(tmp_path, ts_type):
    proc = launch(tmp_path, ["-ts_type", ts_type], nranks=2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "nuno: complete" in proc.stdout


@pytest.mark.parametrize("options", [
    # read only later: at the end of a solve or of the run, or by the solvers
    # PETSc makes at the first solve
    ["-log_view", "-ksp_view", "-snes_view", "-ts_view", "-reduced_ksp_view", "-options_left", "no"],
    ["-snes_converged_reason", "-reduced_ksp_converged_reason", "-ts_monitor", "-snes_monitor"],
    ["-reduced_pc_type", "bjacobi", "-reduced_sub_pc_type", "icc"],
    ["-pc_type", "bjacobi", "-sub_pc_type", "icc"],
    ["-nuno_jacobian", "full", "-snes_test_jacobian"],
    # documented combinations (README.md, input/README.md)
    ["-ts_type", "arkimex", "-ts_arkimex_type", "5", "-ts_arkimex_fully_implicit", "-ts_adapt_type", "basic",
     "-ts_adapt_wnormtype", "infinity", "-ts_rtol", "1e-5"],
    ["-ts_type", "bdf", "-ts_bdf_order", "4", "-ts_adapt_type", "basic", "-nuno_atol_position", "1e-5"],
    ["-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3", "-ksp_type", "preonly", "-pc_type", "lu"],
    ["-nuno_jacobian", "full", "-dm_mat_type", "aij", "-ksp_type", "fgmres", "-pc_type", "fieldsplit",
     "-pc_fieldsplit_type", "schur", "-pc_fieldsplit_schur_fact_type", "full",
     "-pc_fieldsplit_schur_precondition", "selfp", "-pc_fieldsplit_0_fields", "0,1,2",
     "-pc_fieldsplit_1_fields", "3,4,5", "-fieldsplit_0_ksp_type", "preonly", "-fieldsplit_0_pc_type", "jacobi"],
    ["-nuno_mg", "petsc", "-nuno_pc_lag", "2", "-nuno_newton_start", "linear", "-nuno_inner_guess", "extrapolate",
     "-nuno_checkpoint_walltime", "1h", "-ts_max_snes_failures", "-1", "-nuno_fail_newton", "1"],
])
def test_options_read_later_and_documented_ones_still_run(tmp_path, options):
    proc = launch(tmp_path, options, nranks=2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "nuno: complete" in proc.stdout
    assert "was not used" not in proc.stderr, proc.stderr


def test_help_prints_and_writes_nothing(tmp_path):
    proc = launch(tmp_path, ["-help"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    # PETSc's options of the set-up and nuno's own, then one closing line
    for option in ("-ts_type", "-snes_rtol", "-reduced_ksp_type", "-nuno_jacobian", "-nuno_restart"):
        assert option in proc.stdout, option
    assert "nothing was run or written" in proc.stdout.splitlines()[-1]
    assert not [ln for ln in proc.stdout.splitlines() if ln.startswith("t =")], "the time loop started"
    assert not list(tmp_path.glob("o.h5*"))


def test_help_into_a_closed_pipe_leaves_nothing_behind(tmp_path):
    nml = tmp_path / "o.nml"
    nml.write_text(namelist("o.h5", **GROUPS))
    proc = subprocess.run(f"{exe()} o.nml -help | head -3", shell=True, cwd=tmp_path, capture_output=True,
                          text=True, timeout=180)
    assert len(proc.stdout.splitlines()) == 3
    assert "PETSC ERROR" not in proc.stderr, proc.stderr
    assert not list(tmp_path.glob("o.h5*"))
