# SPDX-License-Identifier: BSD-2-Clause
"""postprocess.control_plot and postprocess.identify_plot (docs/identification.md
figures) and the reader's /control and /identify groups, on synthetic files
(conftest.make_run) with made-up /control and /identify groups of known
content: what the figures draw is checked against that content."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from postprocess import control_plot, identify_plot
from postprocess.reader import read_run, read_states

REPO = Path(__file__).resolve().parents[2]
KT = np.array([0.0, 0.2, 0.4])
OFFSETS = np.array([[0.0, 0.0, 0.0], [2.0, -1.0, 4.0], [3.0, 1.0, -2.0]])      # [keyframe][x, y, z]
INITIAL = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [1.0, 0.5, 0.0]])
OBJECTIVE = np.array([50.0, 3.0, 0.2, 1e-3])


def cli(*args):
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", *args], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=300)


def control_file(path, make_run):
    make_run(path, scene="wave_point", nt=6, dt=0.1)
    hist = np.stack([INITIAL, 0.5 * (INITIAL + OFFSETS), OFFSETS, OFFSETS])
    with h5py.File(path, "r+") as f:
        g = f.create_group("control")
        g["keyframe_time"] = KT
        g["keyframe_offset"] = OFFSETS
        g["initial_offset"] = INITIAL
        g["objective"] = OBJECTIVE[-1:]
        g["objective_history"] = OBJECTIVE
        g["keyframe_history"] = hist
        g["max_speed"] = [np.inf]
        g.attrs["components"] = np.bytes_(b"xyz")
    return path


def identify_file(path, make_run):
    make_run(path, scene="lift_release", nt=6, dt=0.1)
    with h5py.File(path, "r+") as f:
        g = f.create_group("identify")
        g["names"] = np.array([b"e_s       ", b"k_b       "], dtype="S16")
        g["values"] = [1.1, 9.0]
        g["uncertainty"] = [0.2, 0.5]
        g["initial"] = [2.5, 25.0]
        g["objective"] = [0.4]
        g["history"] = np.array([[30.0, 2.5, 25.0], [2.0, 1.5, 12.0], [0.4, 1.1, 9.0]])
    return path


def test_reader_reads_the_small_groups(tmp_path, make_run):
    r = read_run(control_file(tmp_path / "c.h5", make_run))
    np.testing.assert_array_equal(r.control["keyframe_offset"], OFFSETS)
    np.testing.assert_array_equal(r.control["objective_history"], OBJECTIVE)
    assert r.control["components"] == "xyz" and r.identify == {}
    r = read_run(identify_file(tmp_path / "i.h5", make_run))
    assert r.identify["names"] == ["e_s", "k_b"] and r.control == {}
    np.testing.assert_array_equal(r.identify["values"], [1.1, 9.0])


@pytest.mark.parametrize("with_initial", [False, True])
def test_control_figure_draws_the_path_and_the_objective(tmp_path, make_run, with_initial):
    opt = read_run(control_file(tmp_path / "c.h5", make_run))
    make_run(tmp_path / "t.h5", scene="wave_point", nt=6, dt=0.1, omega=0.2)
    target = read_states(tmp_path / "t.h5")
    initial = read_run(tmp_path / "t.h5") if with_initial else None
    fig = control_plot.build_figure(opt, target, initial)
    axes = fig.axes
    assert sum(ax.name == "3d" for ax in axes) == (2 if with_initial else 1)
    path_ax, obj_ax = [ax for ax in axes if ax.name != "3d"]
    for n, comp in enumerate("xyz"):
        (line,) = [ln for ln in path_ax.get_lines() if ln.get_label().startswith(comp + " ")]
        t, y = line.get_data()
        for tk, off in zip(KT, OFFSETS[:, n]):              # through the optimised keyframes
            assert abs(np.interp(tk, t, y) - off) < 1e-9
        assert abs(y[-1] - OFFSETS[-1, n]) < 1e-12           # held after the last (t_end 0.5 > 0.4)
        assert abs(np.interp(0.1, t, y) - 0.5 * OFFSETS[1, n]) < 1e-9
    (obj,) = obj_ax.get_lines()
    np.testing.assert_allclose(obj.get_ydata(), OBJECTIVE)
    assert "no speed bound" in obj_ax.get_title()


def test_identify_figure_draws_values_relative_to_the_truth(tmp_path, make_run):
    fit = read_run(identify_file(tmp_path / "i.h5", make_run))
    make_run(tmp_path / "o.h5", scene="lift_release", nt=6, dt=0.1)
    observed = read_states(tmp_path / "o.h5")
    fig = identify_plot.build_figure(fit, observed, None, {"e_s": 1.0, "k_b": 10.0})
    side, edge, vals, obj = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    (dots,) = [ln for ln in edge.get_lines() if ln.get_label() == "observed"]
    np.testing.assert_allclose(dots.get_ydata(), observed[1][:, (4 - 1) // 2, -1, 2])
    fitted = [ln for ln in vals.get_lines() if ln.get_marker() == "o"][0]
    np.testing.assert_allclose(fitted.get_ydata(), [10.0, -10.0])          # 1.1 / 1 - 1, 9 / 10 - 1 in %
    ticks = [t.get_text() for t in vals.get_xticklabels()]
    assert "1.1" in ticks[0] and "0.2" in ticks[0] and "start 2.5" in ticks[0] and "start 25" in ticks[1]
    np.testing.assert_allclose(obj.get_lines()[0].get_ydata(), [30.0, 2.0, 0.4])
    with pytest.raises(ValueError, match="eta_b"):
        identify_plot.build_figure(fit, observed, None, {"eta_b": 1.0})


@pytest.mark.parametrize("script", ["control_plot", "identify_plot"])
def test_command_line(tmp_path, make_run, script):
    assert "--output" in cli(f"postprocess.{script}", "--help").stdout
    plain = make_run(tmp_path / "plain.h5", scene="wave_point", nt=6, dt=0.1) and tmp_path / "plain.h5"
    flag = "--target" if script == "control_plot" else "--observed"
    proc = cli(f"postprocess.{script}", str(plain), flag, str(plain), "-o", str(tmp_path / "x.png"))
    assert proc.returncode == 1 and proc.stderr.startswith("error: ") and "not the output of" in proc.stderr
    good = (control_file if script == "control_plot" else identify_file)(tmp_path / "g.h5", make_run)
    extra = [] if script == "control_plot" else ["--true", "e_s=1,k_b=10"]
    proc = cli(f"postprocess.{script}", str(good), flag, str(plain), *extra, "-o", str(tmp_path / "g.png"))
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "g.png").stat().st_size > 10000
