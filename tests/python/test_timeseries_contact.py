# SPDX-License-Identifier: BSD-2-Clause
"""nuno-timeseries of a run with obstacles: four contact panels more
(active pairs, smallest gap with contact_dhat, the contact force along -g
against the weight m |g|, the friction work), drawn from the file's
/contact; files without /contact keep the 8 panels. Checked against the
file read independently with h5py (and, for the real drop_table run, the
input file read with f90nml and the physics: the resting cloth's contact
force is its weight)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import f90nml
import h5py
import numpy as np
import pytest

from nunorun import exe, mpiexec
from postprocess import plotting, timeseries
from postprocess.reader import read_run

REPO = Path(__file__).resolve().parents[2]
GRAVITY_X = np.array([9.81, 0.0, 0.0])     # the gripper's frame: "down" is +x
DHAT = 2.5                                 # a contact_dhat unlike the default


def add_contact(path, nt, gravity=GRAVITY_X, dhat=DHAT, seed=3):
    """/contact, /energy/barrier and /config/{scene,contact} on a make_run file,
    arbitrary series of the layout of docs/model.md section 9; returns them."""
    rng = np.random.default_rng(seed)
    c = {
        "active": rng.integers(0, 20, nt).astype(np.int64),
        "force": rng.normal(size=(nt, 3)),
        "normal_force": rng.normal(size=(nt, 3)),
        "friction_work": np.cumsum(rng.random(nt)),
        "barrier_energy": rng.random(nt),
        "min_gap": rng.random(nt) * 10.0 + 0.01,
        "states_checked": np.arange(1, nt + 1, dtype=np.int64),
    }
    c["min_gap_run"] = np.minimum.accumulate(c["min_gap"])
    with h5py.File(path, "a") as f:
        for name, a in c.items():
            f.create_dataset(f"contact/{name}", data=a)
        f.create_dataset("energy/barrier", data=c["barrier_energy"])
        f.require_group("config").require_group("scene").attrs["gravity"] = np.asarray(gravity, float)
        g = f["config"].require_group("contact")
        g.attrs["n_obstacles"] = np.int32(1)
        g.attrs["contact_dhat"] = float(dhat)
    return c


def panel(fig, what):
    """The axes timeseries labels 'contact:<what>' (exactly one)."""
    found = [ax for ax in plotting.panels(fig) if ax.get_label() == f"contact:{what}"]
    assert len(found) == 1, [ax.get_label() for ax in plotting.panels(fig)]
    return found[0]


def horizontal_lines(ax):
    """y values of the horizontal reference lines (axhline: x data (0, 1) in axes coordinates)."""
    return [float(line.get_ydata()[0]) for line in ax.lines
            if list(line.get_xdata()) == [0, 1] and line.get_ydata()[0] == line.get_ydata()[1]]


def data_lines(ax):
    return [line for line in ax.lines if list(line.get_xdata()) != [0, 1]]


def test_contact_panels_show_the_files_contact_series(tmp_path, make_run):
    path = tmp_path / "c.h5"
    make_run(path, nx=5, ny=4, nt=9, scene="flat")
    c = add_contact(path, 9)
    with h5py.File(path, "r") as f:               # what the figure must show, read apart from the reader
        t = f["time"][()]
        weight = f["lattice/mass"][()].sum() * np.linalg.norm(GRAVITY_X)
    run = read_run(path)
    fig = timeseries.build_figure(run)
    assert len(plotting.panels(fig)) == 12 == timeseries.N_PANELS + timeseries.N_CONTACT_PANELS

    (line,) = data_lines(panel(fig, "active"))
    assert np.array_equal(line.get_xdata(), t) and np.array_equal(line.get_ydata(), c["active"])

    gap = panel(fig, "gap")
    assert gap.get_yscale() == "log"
    assert [list(ln.get_ydata()) for ln in data_lines(gap)] == [list(c["min_gap"]), list(c["min_gap_run"])]
    assert horizontal_lines(gap) == [DHAT]

    # gravity along +x: "up" is -x, so the curves are minus the x components
    force = panel(fig, "force")
    normal, total = data_lines(force)
    assert np.allclose(normal.get_ydata(), -c["normal_force"][:, 0], rtol=0, atol=1e-15)
    assert np.allclose(total.get_ydata(), -c["force"][:, 0], rtol=0, atol=1e-15)
    assert horizontal_lines(force) == [pytest.approx(weight, rel=1e-14)]
    assert force.get_ylabel() == "contact force [N]" or "g mm" in force.get_ylabel()

    (fw,) = data_lines(panel(fig, "friction_work"))
    assert np.array_equal(fw.get_ydata(), c["friction_work"])

    # the balance panel's title names the barrier energy the balance includes
    assert "E_{bar}" in plotting.panels(fig)[1].get_title()
    out = tmp_path / "c.png"
    assert timeseries.main([str(path), "-o", str(out)]) == 0 and out.stat().st_size > 0


def test_files_without_contact_keep_eight_panels(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nt=5)
    fig = timeseries.build_figure(read_run(tmp_path / "a.h5"))
    labels = [ax.get_label() for ax in plotting.panels(fig)]
    assert len(labels) == 8 and not any(lb.startswith("contact:") for lb in labels)


def test_overlay_adds_contact_panels_with_dhat_and_weight(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nt=6, scene="flat")
    make_run(tmp_path / "b.h5", nt=6, scene="flat")
    c = add_contact(tmp_path / "b.h5", 6, gravity=(0.0, 0.0, -9.81), dhat=0.5)
    runs = [read_run(tmp_path / "a.h5"), read_run(tmp_path / "b.h5")]
    fig = timeseries.build_overlay(runs, ["a", "b"])
    axes = plotting.panels(fig)
    assert len(axes) == 12
    # the cumulative linear iterations keep their symlog axis; the friction work is linear
    assert axes[7].get_yscale() == "symlog" and axes[11].get_yscale() == "linear"
    gap, force = axes[9], axes[10]
    (line,) = data_lines(gap)                      # the contact-free run has no line there
    assert np.array_equal(line.get_ydata(), c["min_gap"]) and horizontal_lines(gap) == [0.5]
    (line,) = data_lines(force)
    assert np.allclose(line.get_ydata(), c["normal_force"][:, 2], rtol=0, atol=1e-15)
    assert horizontal_lines(force) == [pytest.approx(runs[1].mass.sum() * 9.81, rel=1e-14)]


def test_drop_table_run_force_carries_the_weight(tmp_path):
    """input/drop_table.nml to t = 0.3 s on 2 ranks: the panels show the
    file's series, the gap starts at the 5 cm drop and the line contact_dhat
    is the input's; the contact force along -g is zero in free fall and,
    once the cloth has settled on the table, its weight m |g| (the input's
    total_mass times |gravity|)."""
    nml = f90nml.read(REPO / "input" / "drop_table.nml")
    mass = float(nml["lattice"]["total_mass"])
    g = np.asarray(nml["scene"]["gravity"], float)
    dhat = float(nml["contact"]["contact_dhat"])
    drop = -float(np.ravel(nml["contact"]["obstacle_point"])[2])       # the table top z = -h, the sheet at z = 0
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(REPO / "input" / "drop_table.nml"),
           "-nuno_set", "t_end=0.3,output_interval=0.01,output_file='drop.h5'"]
    env = dict(os.environ, OMPI_MCA_rmaps_base_oversubscribe="1")
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    h5 = tmp_path / "drop.h5"
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        t = f["time"][:n]
        active = f["contact/active"][:n]
        normal = f["contact/normal_force"][:n]
        gap0 = f["contact/min_gap"][0]
    run = read_run(h5)
    fig = timeseries.build_figure(run)
    assert len(plotting.panels(fig)) == 12
    (line,) = data_lines(panel(fig, "active"))
    assert np.array_equal(line.get_ydata(), active)
    gap = panel(fig, "gap")
    assert horizontal_lines(gap) == [dhat]
    assert data_lines(gap)[0].get_ydata()[0] == pytest.approx(drop, rel=1e-9)
    force = panel(fig, "force")
    (weight,) = horizontal_lines(force)
    assert weight == pytest.approx(mass * np.linalg.norm(g), rel=1e-9)
    up = data_lines(force)[0].get_ydata()
    assert np.allclose(up, normal[:, 2], rtol=0, atol=1e-12)         # gravity -z: up is +z
    free = t < 0.095                                                 # falls 5 cm in 0.101 s
    assert np.all(active[free] == 0) and np.all(up[free] == 0.0)
    rest = t >= 0.25
    assert np.all(active[rest] == run.nx * run.ny)
    assert np.mean(up[rest]) == pytest.approx(weight, rel=0.03)
    out = tmp_path / "drop.png"
    assert timeseries.main([str(h5), "-o", str(out)]) == 0 and out.stat().st_size > 0
