# SPDX-License-Identifier: BSD-2-Clause
"""PETSc's linear-solver options as users type them (input/README.md,
"Linear solvers: PETSc options as you know them"), on 2 ranks.

On the default (reduced) path the outer linear solve is nuno's elimination;
-ksp_*, -pc_* (and -sub_*, -mg_levels_*, -mg_coarse_*) are read as the inner
3-dof solve's -reduced_ksp_*, -reduced_pc_*. Before, -pc_type lu and
-pc_type gamg replaced the elimination and stopped the run ("Could not
locate a solver type for factorization type LU and matrix type shell"),
-ksp_rtol was ignored, -pc_type fieldsplit failed every Newton solve with a
misleading hint, and -dm_mat_type nonsense passed silently.

Expectations: a habit gives the run of the option it stands for (-pc_type
lu = -reduced_pc_type lu: the same options reach PETSc, so the same numbers
but for MUMPS's run-to-run round-off) and the same start-up line naming
the inner solver; a refusal is one line
naming the option and the one to use, from a non-zero exit, before any
output file exists."""
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec, read_run

HANG = ROOT / "input" / "hang.nml"
SMALL = "nx=9,ny=9,t_end=0.02,output_interval=0.01"
NP = 2


def nuno(tmp_path, name, options=(), overrides=SMALL, nranks=NP, path=HANG):
    h5 = Path(tmp_path) / f"{name}.h5"
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(path),
           "-nuno_set", f"{overrides},output_file='{h5.name}'", *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    return proc, h5


def completes(tmp_path, name, options):
    proc, h5 = nuno(tmp_path, name, options)
    assert proc.returncode == 0, f"{options}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    r = read_run(str(h5))
    assert r.complete
    return proc, r


def inner_line(proc):
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("inner     :")]
    assert len(lines) == 1, proc.stdout
    return lines[0]


@pytest.mark.parametrize("habit,meant,inner", [
    (("-pc_type", "lu"), ("-reduced_pc_type", "lu"), "+ lu"),
    (("-pc_type", "gamg"), ("-reduced_pc_type", "gamg"), "+ gamg"),
    (("-ksp_type", "preonly", "-pc_type", "lu", "-pc_factor_mat_solver_type", "mumps"),
     ("-reduced_ksp_type", "preonly", "-reduced_pc_type", "lu", "-reduced_pc_factor_mat_solver_type", "mumps"),
     "preonly"),
    (("-ksp_type", "gmres"), ("-reduced_ksp_type", "gmres"), ": gmres"),
    (("-ksp_rtol", "1e-10"), ("-reduced_ksp_rtol", "1e-10"), "rtol 1.0E-10"),
    (("-pc_type", "bjacobi", "-sub_pc_type", "icc"), ("-reduced_pc_type", "bjacobi", "-reduced_sub_pc_type", "icc"),
     "+ bjacobi"),
])
def test_outer_option_acts_on_the_inner_solve(tmp_path, habit, meant, inner):
    proc, r = completes(tmp_path, "habit", habit)
    ref_proc, ref = completes(tmp_path, "meant", meant)
    assert inner in inner_line(proc), inner_line(proc)
    assert inner_line(proc) == inner_line(ref_proc)
    # the same options reached PETSc: the same numbers, up to the parallel
    # direct solver (MUMPS on 2 ranks), which is not bitwise reproducible
    # from run to run (1e-23 m measured on this 1 m cloth)
    x, xref = np.asarray(r.position[:]), np.asarray(ref.position[:])
    assert np.abs(x - xref).max() <= 1e-13 * np.abs(xref).max()
    # the run says what it made of the options
    said = [ln for ln in proc.stdout.splitlines() if "read as" in ln]
    assert len(said) == 1, proc.stdout
    for name, value in zip(meant[::2], meant[1::2]):
        assert f"{name} {value}" in said[0], said[0]
    assert "was not used" not in proc.stderr


def test_the_example_of_input_hang_runs(tmp_path):
    """input/hang.nml's own comment: petsc_options = '-ts_type bdf -pc_type gamg'."""
    text = HANG.read_text()
    example = "'-ts_type bdf -pc_type gamg'"
    assert f"! e.g. {example}" in text
    nml = Path(tmp_path) / "hang_bdf.nml"
    nml.write_text(text.replace("petsc_options   = ''", f"petsc_options   = {example}"))
    proc, h5 = nuno(tmp_path, "bdf", path=nml)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert read_run(str(h5)).complete
    assert "+ gamg" in inner_line(proc)


def test_fieldsplit_on_the_6dof_path_gets_aij(tmp_path):
    """PETSc's field split cannot split baij's 6 x 6 blocks: without
    -dm_mat_type the 6-dof Jacobian is stored aij for it."""
    completes(tmp_path, "fs", ("-nuno_jacobian", "full", "-pc_type", "fieldsplit"))


@pytest.mark.parametrize("options,names", [
    (("-pc_type", "fieldsplit"), ["-pc_type fieldsplit", "-nuno_jacobian full"]),
    (("-pc_type", "shell"), ["-pc_type shell", "-reduced_pc_type"]),
    (("-pc_type", "lu", "-reduced_pc_type", "gamg"), ["-pc_type lu", "-reduced_pc_type gamg"]),
    (("-dm_mat_type", "nonsense"), ["-dm_mat_type nonsense", "-reduced_dm_mat_type", "-nuno_jacobian full"]),
    (("-dm_mat_type", "aij"), ["-dm_mat_type aij", "-nuno_jacobian full"]),
    (("-nuno_jacobian", "full", "-dm_mat_type", "nonsense"), ["-dm_mat_type nonsense", "not a PETSc matrix type"]),
    (("-nuno_jacobian", "full", "-dm_mat_type", "baij", "-pc_type", "fieldsplit"),
     ["-pc_type fieldsplit", "-dm_mat_type baij", "aij"]),
])
def test_refused_in_one_line(tmp_path, options, names):
    proc, h5 = nuno(tmp_path, "bad", options)
    assert proc.returncode != 0
    lines = [ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.startswith("nuno: error")]
    assert len(lines) == 1, proc.stdout + proc.stderr
    for n in names:
        assert n in lines[0], lines[0]
    assert not h5.exists()


def test_help_shows_the_mapping(tmp_path):
    proc, _ = nuno(tmp_path, "help", ("-help",), nranks=1)
    text = proc.stdout
    assert "on the default (reduced) path -ksp_*, -pc_*" in text, text[-3000:]
    entry = [ln for ln in text.splitlines() if ln.strip().startswith("-pc_type") and "-reduced_pc_type" in ln]
    assert entry, "-help: no -pc_type entry naming -reduced_pc_type"
    usage = subprocess.run([exe(), "--help"], capture_output=True, text=True, timeout=60).stdout
    assert "-pc_type lu" in usage and "-reduced_pc_type lu" in usage, usage[-2000:]
