# SPDX-License-Identifier: BSD-2-Clause
"""Studies in one command and paper-ready figures (issue 38 items 4, 5, 8):
nuno-sweep (naming, -nuno_set lines, batch scripts, a real refinement),
compare/timeseries over N runs labelled by a swept key, workprecision from
run files, the side view's plane, tick labels that do not pile, labels that
are not clipped, usage lines that name the console scripts. Synthetic files
(conftest.make_run, test_postprocess.write_study_run) have known content;
the real runs are a few seconds of hang 9 x 9."""
from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from postprocess import cli, compare, plotting, snapshots, sweep, timeseries, workprecision
from postprocess.reader import read_run
from test_postprocess import assert_png, g_max_on, write_study_run

REPO = Path(__file__).resolve().parents[2]


def renderer(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def inside_figure(fig, artist, slack=1.0):
    """The artist's drawn box lies within the canvas (nothing clipped)."""
    box = artist.get_window_extent(renderer(fig))
    w, h = fig.canvas.get_width_height()
    return (box.x0 >= -slack and box.y0 >= -slack and box.x1 <= w + slack and box.y1 <= h + slack)


def overlapping(boxes) -> bool:
    """Whether any two of the boxes overlap (tick labels piled on each other)."""
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a.overlaps(b):
                return True
    return False


def swept_runs(tmp_path, make_run, values=(50.0, 100.0, 200.0, 400.0), motion="y"):
    """Synthetic runs whose namelist sets e_s; they move apart in y (or x)."""
    paths = []
    for k, v in enumerate(values):
        vel = (0.0, 1.0 + 0.1 * k, -2.0) if motion == "y" else (1.0 + 0.1 * k, 0.0, -2.0)
        p = tmp_path / f"run{k}.h5"
        make_run(p, nx=6, ny=5, nt=6, omega=0.0, velocity=vel, scene="hang",
                 namelist_extra=f"&material e_s = {v} /\n")
        paths.append(p)
    return paths


# ---------------------------------------------------------------- labels, overlays


def test_compare_labels_runs_by_the_swept_value(tmp_path, make_run, capsys):
    paths = swept_runs(tmp_path, make_run)
    out = tmp_path / "c.png"
    assert compare.main([*map(str, paths), "--label", "e_s", "--view", "side",
                         "-o", str(out)]) == 0
    assert_png(out)
    runs = [read_run(p) for p in paths]
    names = cli.run_labels(runs, "e_s")
    assert names == ["e_s = 50 N/m", "e_s = 100 N/m", "e_s = 200 N/m", "e_s = 400 N/m"]  # SI (hang)
    series = [compare.difference(runs[0], r, compare.common_interval(runs)) for r in runs[1:]]
    fig = compare.build_figure(runs, 0.5, series, "side", names)
    top, bottom = plotting.panels(fig)   # 4 runs: one overlay panel + the differences
    assert [t.get_text() for t in top.get_legend().get_texts()] == names
    assert [t.get_text() for t in bottom.get_legend().get_texts()] == \
        [f"{n} vs e_s = 50 N/m" for n in names[1:]]
    # the runs move in y: the side view is the y-z plane
    assert top.get_xlabel() == "y [m]" and top.get_ylabel() == "z [m]"
    # every axis label drawn whole inside the canvas, the x labels clear of the panel below
    for ax in (top, bottom):
        for label in (ax.xaxis.label, ax.yaxis.label):
            assert label.get_text() and inside_figure(fig, label), label.get_text()
    r = renderer(fig)
    assert top.xaxis.label.get_window_extent(r).y0 > bottom.get_window_extent(r).y1
    with pytest.raises(KeyError, match="no key 'e_b'"):
        cli.run_labels(runs, "e_b")


def test_compare_iso_panels_keep_their_labels(tmp_path, make_run):
    """Three runs, 3-D panels over the differences: the x, y, z labels of the
    boxes are drawn, inside the canvas and above the difference panel."""
    paths = swept_runs(tmp_path, make_run, values=(1.0, 2.0, 3.0))
    runs = [read_run(p) for p in paths]
    series = [compare.difference(runs[0], r, compare.common_interval(runs)) for r in runs[1:]]
    fig = compare.build_figure(runs, 0.5, series, "iso")
    *tops, bottom = plotting.panels(fig)
    r = renderer(fig)
    floor = bottom.get_tightbbox(r).y1
    for ax in tops:
        for label in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label):
            assert label.get_text() and inside_figure(fig, label), label.get_text()
            assert label.get_window_extent(r).y0 > floor - 2, label.get_text()
    assert bottom.get_xlabel() == "t [s]" and inside_figure(fig, bottom.xaxis.label)
    assert inside_figure(fig, bottom.yaxis.label)


def test_timeseries_overlays_runs_in_sweep_order(tmp_path, make_run):
    paths = swept_runs(tmp_path, make_run)
    out = tmp_path / "ts.png"
    shuffled = [paths[k] for k in (2, 0, 3, 1)]   # as a shell glob sorts 100 < 200 < 400 < 50
    assert timeseries.main([*map(str, shuffled), "--label", "e_s", "-o", str(out)]) == 0
    assert_png(out)
    runs = [read_run(p) for p in paths]
    fig = timeseries.build_overlay(runs, cli.run_labels(runs, "e_s"))
    axes = plotting.panels(fig)
    assert len(axes) == timeseries.N_PANELS
    assert all(len(ax.lines) == 4 for ax in axes)
    assert [t.get_text() for t in fig.legends[0].get_texts()] == \
        ["e_s = 50 N/m", "e_s = 100 N/m", "e_s = 200 N/m", "e_s = 400 N/m"]
    # |p| = M |V| of the rigid motion (total mass 1): an independent value
    p_ax = axes[3]
    for k, line in enumerate(p_ax.lines):
        expected = np.hypot(1.0 + 0.1 * k, 2.0)
        np.testing.assert_allclose(line.get_ydata(), expected, rtol=1e-12)
    assert p_ax.get_ylabel() == "|momentum| [kg m/s]"
    proc = subprocess.run([sys.executable, "-m", "postprocess.timeseries", str(paths[0]), str(paths[1]),
                           "--labels", "only-one", "-o", str(tmp_path / "x.png")],
                          cwd=REPO, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert proc.returncode == 1 and proc.stderr == "error: --labels: 1 labels for 2 runs\n"


# ---------------------------------------------------------------- side views and ticks


@pytest.mark.parametrize("motion,plane", [("y", "yz"), ("x", "xz")])
def test_side_view_takes_the_plane_of_largest_motion(tmp_path, make_run, motion, plane):
    (path,) = swept_runs(tmp_path, make_run, values=(1.0,), motion=motion)
    run = read_run(path)
    fig = snapshots.build_figure(run, [0, 5], "panels", "side")
    ax = plotting.panels(fig)[0]
    assert ax.get_xlabel() == f"{plane[0]} [m]"
    # the projected lines are the nodes' (u, z) coordinates
    u = {"x": 0, "y": 1}[plane[0]]
    segs = ax.collections[0].get_segments()
    pos = np.asarray(run.position[0])
    np.testing.assert_allclose(segs[0], pos[0][:, [u, 2]])
    other = "xz" if plane == "yz" else "yz"
    fig = snapshots.build_figure(run, [0, 5], "panels", "side", plane=other)
    assert plotting.panels(fig)[0].get_xlabel() == f"{other[0]} [m]"
    out = tmp_path / "s.png"
    assert snapshots.main([str(path), "--view", "side", "--plane", other, "-o", str(out)]) == 0
    assert_png(out)
    assert snapshots.main([str(path), "--plane", "yz", "-o", str(out)]) == 1   # needs --view side


def test_side_panels_fill_the_canvas_and_ticks_do_not_pile(tmp_path, make_run):
    (path,) = swept_runs(tmp_path, make_run, values=(1.0,))
    run = read_run(path)
    fig = snapshots.build_figure(run, [0, 2, 4, 5], "panels", "side")
    r = renderer(fig)
    w, h = fig.canvas.get_width_height()
    used = sum(ax.get_tightbbox(r).width * ax.get_tightbbox(r).height for ax in plotting.panels(fig))
    assert used > 0.6 * w * h, used / (w * h)
    for ax in plotting.panels(fig):
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [t.get_window_extent(r) for t in axis.get_ticklabels() if t.get_text()]
            assert len(boxes) >= 2 and not overlapping(boxes)


def test_near_flat_3d_box_has_one_z_label(tmp_path, make_run):
    """A flat sheet (make_run moves in its plane): its z axis is a sliver of
    the box; one z tick label, not three piled on each other."""
    make_run(tmp_path / "flat.h5", nx=11, ny=9, nt=6)
    run = read_run(tmp_path / "flat.h5")
    fig = snapshots.build_figure(run, [0, 5], "panels", "iso")
    for ax in plotting.panels(fig):
        assert len(ax.get_zticks()) == 1
        r = renderer(fig)
        boxes = [t.get_window_extent(r) for t in ax.xaxis.get_ticklabels() if t.get_text()]
        assert not overlapping(boxes)
    w, h = fig.get_size_inches()
    assert h < 0.4 * w           # a strip no taller than the flat boxes need


# ---------------------------------------------------------------- workprecision from runs


def test_workprecision_from_run_files(tmp_path, capsys):
    """Errors C dt^2 g against an exact reference and wall times K / dt: the
    errors printed are C dt^2 max|g|, the slope of time against error -1/2,
    one series an integrator; axes name quantity and unit."""
    C, K = 3.0, 0.02
    paths = []
    for k, dt in enumerate((0.04, 0.02, 0.01)):
        paths.append(write_study_run(tmp_path / f"cn{k}.h5", 11, dt=dt, err=C * dt**2, run_attrs={
            "dt": dt, "ts_type": "cn", "ts_adapt_type": "none", "wall_time": K / dt}))
    paths.append(write_study_run(tmp_path / "be.h5", 11, dt=0.01, err=0.05, run_attrs={
        "dt": 0.01, "ts_type": "beuler", "ts_adapt_type": "none", "wall_time": 1.5}))
    ref = write_study_run(tmp_path / "ref.h5", 11, dt=1e-4, err=0.0)
    out = tmp_path / "wp.png"
    assert workprecision.main([*map(str, paths), "--reference-run", str(ref), "-o", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = [w.split() for w in lines if w.startswith("run ")]
    cn = sorted((float(r[3]), float(r[4])) for r in rows if r[2] == "cn,_fixed_steps")
    np.testing.assert_allclose([e for e, _ in cn], C * g_max_on(11) * np.array([0.01, 0.02, 0.04])**2,
                               rtol=1e-9)
    np.testing.assert_allclose([t for _, t in cn], [K / 0.01, K / 0.02, K / 0.04], rtol=1e-12)
    (slope,) = [float(w.split()[1]) for w in lines if w.startswith("slope ")]  # beuler: 1 point, no fit
    assert slope == pytest.approx(-0.5, abs=1e-9)
    assert_png(out)
    res = workprecision.from_runs([read_run(p) for p in paths], read_run(ref))
    fig, _ = workprecision.build_figure(res)
    ax = plotting.panels(fig)[0]
    assert ax.get_xlabel() == "max node distance from the reference run at t = 1 s [m]"
    assert ax.get_ylabel() == "wall time [s]"
    assert inside_figure(fig, ax.xaxis.label) and inside_figure(fig, ax.yaxis.label)
    assert workprecision.main([*map(str, paths), "-o", str(out)]) == 1   # no reference run


def test_workprecision_csv_axes_have_units(tmp_path):
    csv = tmp_path / "s.csv"
    csv.write_text("error,run_time\n1e-2,1.0\n1e-3,3.0\n1e-4,9.0\n")
    out = tmp_path / "wp.png"
    assert workprecision.main([str(csv), "--x-label", "error [m]", "-o", str(out)]) == 0
    assert_png(out)


# ---------------------------------------------------------------- nuno-sweep


def sweep_args(tmp_path, *extra):
    nml = tmp_path / "case.nml"
    nml.write_text("&scene scene='hang' /\n&lattice nx=9 ny=9 /\n&time t_end=0.1 dt=2e-3 /\n"
                   "&output output_interval=0.05 /\n")
    return [str(nml), "--outdir", str(tmp_path / "out"), *extra]


def test_sweep_names_files_and_sets_keys(tmp_path, capsys):
    assert sweep.main(sweep_args(tmp_path, "--set", "scene='hang','flat'", "--fixed",
                                 "t_end=0.2,e_s=5", "--options", "-ts_type cn", "-n", "2",
                                 "--exe", "NUNO", "--mpiexec", "mpiexec --x", "--dry-run")) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2
    words = shlex.split(lines[1])
    assert words[:5] == ["mpiexec", "--x", "-n", "2", "NUNO"]
    assert words[5] == str((tmp_path / "case.nml").resolve())
    assert words[6:8] == ["-nuno_set", "t_end=0.2,e_s=5,scene='flat',output_file='case_scene-flat.h5'"]
    assert words[8:] == ["-ts_type", "cn"]
    assert not (tmp_path / "out").exists()     # a dry run makes nothing
    assert sweep.file_stem("hang", "e_s", "1.0d3") == "hang_e_s-1.0d3"
    assert sweep.file_stem("hang", "gravity(3)", "-1.5") == "hang_gravity_3_--1.5"
    for bad, message in ((("--set", "e_s"), "write KEY=V1"), (("--lattice", "9,x"), "not a node count"),
                         (("--dt", "1e-3,-2"), "not a positive"), (("--set", "e_s=1,1"), "repeat"),
                         (("--set", "output_file='a.h5'"), "names the output files"),
                         (("--set", "e_s=1", "--dt", "1e-3"), "give one of"), ((), "give one of")):
        assert sweep.main(sweep_args(tmp_path, *bad, "--dry-run")) == 1
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and err.count("\n") == 1, err


def test_sweep_writes_slurm_jobs(tmp_path, capsys):
    """--batch slurm: runs.txt holds one line a value (the case, the named
    file and the value's -nuno_set) for a job array of tools/slurm/nuno.sbatch
    --runs; --submit runs submit.sh (a stub sbatch records its arguments and
    prints a job id): the array, then a plotting job after it. The whole
    sweep through stub Slurm commands: tests/python/test_sweep_batch.py."""
    stub = tmp_path / "bin"
    stub.mkdir()
    (stub / "sbatch").write_text('#!/bin/sh\necho "$@" >> "$STUB_LOG"\necho 77\n')
    (stub / "sbatch").chmod(0o755)
    log = tmp_path / "sbatch.log"
    env = dict(os.environ, PATH=f"{stub}:{os.environ['PATH']}", STUB_LOG=str(log))
    env.pop("NUNO_EXE", None)
    args = sweep_args(tmp_path, "--lattice", "9,17", "-n", "4", "--batch", "slurm", "--submit",
                      "--exe", sys.executable)
    proc = subprocess.run([sys.executable, "-m", "postprocess.sweep", *args], cwd=tmp_path, env=dict(
        env, PYTHONPATH=str(REPO)), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    runs = [shlex.split(line) for line in (tmp_path / "out" / "runs.txt").read_text().splitlines()]
    assert len(runs) == 2
    assert runs[1] == [str((tmp_path / "case.nml").resolve()), "case_nx-17.h5", "-nuno_set", "nx=17,ny=17"]
    recorded = [shlex.split(line) for line in log.read_text().splitlines()]
    assert len(recorded) == 2
    assert "--array=0-1" in recorded[0] and "--ntasks=4" in recorded[0]
    assert Path(recorded[0][-3]) == REPO / "tools" / "slurm" / "nuno.sbatch"
    assert recorded[0][-2:] == ["--runs", "runs.txt"]
    assert "--dependency=afterok:77" in recorded[1] and recorded[1][-1] == "plots.sbatch"
    submit = (tmp_path / "out" / "submit.sh").read_text().splitlines()
    assert f"export NUNO_EXE={shlex.quote(str(Path(sys.executable).resolve()))}" in submit
    study = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert study["kind"] == "lattice" and [r["file"] for r in study["runs"]] == \
        ["case_nx-9.h5", "case_nx-17.h5"]


def test_sweep_real_lattice_refinement(tmp_path, capsys):
    """hang with continuum scaling on 5, 9, 17 nodes: three runs named by N,
    each with the lattice it was asked for, and the comparison and
    convergence figures, the convergence tool's lines printed."""
    import nunorun
    exe = nunorun.exe()
    args = sweep_args(tmp_path, "--lattice", "5,9,17", "--fixed", "lattice_scaling='continuum'",
                      "--exe", exe, "--mpiexec", f"{nunorun.mpiexec()} --oversubscribe")
    assert sweep.main(args) == 0
    out = capsys.readouterr().out
    outdir = tmp_path / "out"
    for n in (5, 9, 17):
        run = read_run(outdir / f"case_nx-{n}.h5")
        assert (run.nx, run.ny) == (n, n) and run.complete
        assert run.config["lattice"]["lattice_scaling"].strip() == "continuum"
    for name in ("compare.png", "timeseries.png", "convergence.png"):
        assert_png(outdir / name)
    assert "observed_order_differences " in out and "using richardson" in out
    assert "sweep: nuno-convergence " in out


def test_sweep_failed_run_is_reported(tmp_path, capsys):
    import nunorun
    args = sweep_args(tmp_path, "--set", "e_s=1.0,-1.0", "--exe", nunorun.exe(), "--no-plots",
                      "--mpiexec", f"{nunorun.mpiexec()} --oversubscribe")
    assert sweep.main(args) == 1
    captured = capsys.readouterr()
    assert "2/2 e_s = -1.0: failed (exit" in captured.out
    assert captured.err == "error: 1 of 2 runs failed: case_e_s--1.0\n"
    assert "e_s" in (tmp_path / "out" / "case_e_s--1.0.log").read_text()


# ---------------------------------------------------------------- usage lines


@pytest.mark.parametrize("module", ["snapshots", "timeseries", "compare", "convergence",
                                    "workprecision", "sweep", "report_figures", "animate"])
def test_usage_names_the_console_script(module):
    proc = subprocess.run([sys.executable, "-m", f"postprocess.{module}", "--help"], cwd=REPO,
                          capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert proc.returncode == 0
    assert proc.stdout.startswith(f"usage: nuno-{module.replace('_', '-')} ")
