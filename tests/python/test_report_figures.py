# SPDX-License-Identifier: BSD-2-Clause
"""postprocess.report_figures on tiny runs (--quick: 7 x 7, dt 5 ms, short t_end).

Runs the real program (NUNO_EXE, set by CTest; skipped without it) on all six
cases into a tmp dir, then checks the three PNGs and the panel counts of the
figures that the build_* functions return. The namelist editing is checked
without the program.
"""

from __future__ import annotations

import os

import f90nml
import pytest
from PIL import Image

from postprocess import plotting, report_figures
from postprocess.reader import read_run

from nunorun import exe as nuno_exe

NAMES = ("fig3_lift_release", "fig4_bend_release", "fig5_wave_point")


def test_set_key_replaces_one_value_in_its_group():
    text = "&lattice\n  nx = 11, ny = 11   ! nodes\n  lx = 100.0\n/\n&time t_end = 5.0 /\n"
    out = report_figures.set_key(text, "ny", "7")
    nml = f90nml.reads(out)
    assert (nml["lattice"]["nx"], nml["lattice"]["ny"], nml["lattice"]["lx"]) == (11, 7, 100.0)
    out = report_figures.set_key(out, "t_end", "0.5")
    nml = f90nml.reads(out)
    assert nml["time"]["t_end"] == 0.5 and nml["lattice"]["ny"] == 7
    with pytest.raises(ValueError, match="no such key"):
        report_figures.set_key(text, "nodes", "1")  # only in a comment
    with pytest.raises(ValueError, match="KEY=VALUE"):
        report_figures.parse_sets(["nx"])


def test_quick_namelist_drops_energy_k_b_and_sets_output():
    case = report_figures.FIGURES["fig3_lift_release"][1]
    text = report_figures.case_namelist(case, {"e_s": "2.0"}, quick=True)
    nml = f90nml.reads(text)
    assert "k_b" not in nml["material"]  # the program rescales k_b = 1 * ax for 7 x 7
    assert (nml["lattice"]["nx"], nml["lattice"]["ny"]) == (7, 7)
    assert nml["material"]["e_s"] == 2.0
    assert nml["output"]["output_file"] == "lift_release_energy.h5"
    # every other key as in the input file
    orig = f90nml.reads((report_figures.REPO / "input" / "lift_release_energy.nml").read_text())
    assert nml["scene"] == orig["scene"] and nml["material"]["eta_b"] == orig["material"]["eta_b"]


@pytest.fixture(scope="module")
def quick_figures(tmp_path_factory):
    exe = nuno_exe()          # skips without NUNO_EXE, fails if it is missing
    for key in ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
                "OMPI_MCA_rmaps_base_oversubscribe"):
        os.environ.setdefault(key, "1")
    work = tmp_path_factory.mktemp("report_figures")
    outdir, rundir = work / "figures", work / "runs"
    rc = report_figures.main(["--quick", "--exe", exe, "--nranks", "2",
                              "--outdir", str(outdir), "--rundir", str(rundir)])
    assert rc == 0
    return outdir, rundir


def test_quick_run_writes_three_pngs(quick_figures):
    outdir, _ = quick_figures
    for name in NAMES:
        path = outdir / f"{name}.png"
        assert path.is_file() and path.stat().st_size > 0, path
        with Image.open(path) as im:
            assert im.format == "PNG" and im.size[0] > 300 and im.size[1] > 200


def test_quick_runs_are_7x7_and_panel_counts(quick_figures):
    _, rundir = quick_figures
    for name, cases in report_figures.FIGURES.items():
        runs = [read_run(rundir / f"{c.name}.h5") for c in cases]
        assert all(r.complete and (r.nx, r.ny) == (7, 7) for r in runs)
        fig = report_figures.BUILDERS[name](runs, [c.label for c in cases])
        n_times = len(report_figures.TIMES[name])
        # Figs. 3, 4: a side view per model + two diagnostics; Fig. 5: models x times.
        expected = 4 if name != "fig5_wave_point" else 2 * n_times
        assert len(plotting.panels(fig)) == expected, name
    # Fig. 5 with the report's run alone: one row.
    wave = read_run(rundir / "wave_point.h5")
    fig = report_figures.build_fig5([wave], ["no bending"])
    assert len(plotting.panels(fig)) == len(report_figures.TIMES["fig5_wave_point"])


def test_skip_run_replots_and_missing_runs_fail(quick_figures, tmp_path, capsys):
    _, rundir = quick_figures
    assert report_figures.main(["--skip-run", "--rundir", str(rundir),
                                "--outdir", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.glob("*.png")) == [f"{n}.png" for n in NAMES]
    assert report_figures.main(["--skip-run", "--rundir", str(tmp_path / "none"),
                                "--outdir", str(tmp_path)]) == 1
    assert "run without --skip-run first" in capsys.readouterr().err


def test_failed_run_exits_nonzero_with_the_programs_message(quick_figures, tmp_path, capsys):
    rc = report_figures.main(["--quick", "--set", "nx=2", "--exe", os.environ["NUNO_EXE"],
                              "--outdir", str(tmp_path / "f"), "--rundir", str(tmp_path / "r")])
    assert rc == 1
    err = capsys.readouterr().err
    assert "run lift_release failed" in err and "nx" in err


def test_skip_run_plots_whatever_complete_runs_exist(quick_figures, tmp_path, capsys):
    """--skip-run with only some runs (issue 9 item 13): the figures whose
    runs exist are drawn, from those runs; the others are skipped with a line."""
    import shutil
    _, rundir = quick_figures
    part = tmp_path / "runs"
    part.mkdir()
    for name in ("bend_release", "bend_release_energy", "wave_point"):
        shutil.copy(rundir / f"{name}.h5", part)
    out = tmp_path / "fig"
    assert report_figures.main(["--skip-run", "--rundir", str(part), "--outdir", str(out)]) == 0
    assert sorted(p.name for p in out.glob("*.png")) == ["fig4_bend_release.png", "fig5_wave_point.png"]
    err = capsys.readouterr().err
    assert "lift_release.h5: no such file" in err and "wave_point_energy.h5: no such file" in err
