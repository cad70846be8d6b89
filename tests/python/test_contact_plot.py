# SPDX-License-Identifier: BSD-2-Clause
"""postprocess.contact_plot: the cloth with its obstacles. The obstacles
are read back as they were written (a file's /config/contact, or the
namelist a file echoes), each shape is drawn where it is, the script writes
a PNG and a small GIF, and a missing file or a bad argument ends it with one
`error:` line and no output. Synthetic files (conftest's make_run) plus, with
NUNO_EXE, a real 9 x 9 drop onto a table."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from PIL import Image

from postprocess import contact_plot
from postprocess.reader import read_run

REPO = Path(__file__).resolve().parents[2]

# Four obstacles as nuno's /config/contact holds them (keys of input/README.md)
SHAPES = ["plane", "sphere", "box", "capsule"]
POINT = np.array([[0.0, 0.0, -5.0], [50.0, 40.0, -30.0], [20.0, 20.0, -20.0], [80.0, 10.0, -10.0]])
NORMAL = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
RADIUS = np.array([0.0, 20.0, 0.0, 4.0])
HALF = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [10.0, 5.0, 2.0], [0.0, 0.0, 0.0]])
END = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [80.0, 70.0, -10.0]])


def add_contact_config(path, n=4):
    """/config/contact with the first n obstacles above, flat arrays as nuno writes them."""
    with h5py.File(path, "a") as f:
        g = f.require_group("config").require_group("contact")
        g.attrs["n_obstacles"] = np.int32(n)
        g.attrs["obstacle_shape"] = ", ".join(SHAPES[:n])
        g.attrs["obstacle_point"] = POINT[:n].ravel()
        g.attrs["obstacle_normal"] = NORMAL[:n].ravel()
        g.attrs["obstacle_radius"] = RADIUS[:n]
        g.attrs[contact_plot.KEY_HALF] = HALF[:n].ravel()
        g.attrs[contact_plot.KEY_END] = END[:n].ravel()
        g.attrs["contact_dhat"] = 1.0


def cli(*args):
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "postprocess.contact_plot", *map(str, args)], cwd=REPO,
                          env=env, capture_output=True, text=True, timeout=300)


def test_obstacles_read_back_from_config(tmp_path, make_run):
    make_run(tmp_path / "a.h5")
    add_contact_config(tmp_path / "a.h5")
    with read_run(tmp_path / "a.h5") as run:
        obs = contact_plot.obstacles(run)
    assert [o.shape for o in obs] == SHAPES
    for k, o in enumerate(obs):
        assert np.allclose(o.point, POINT[k])
    assert np.allclose(obs[0].normal, [0.0, 0.0, 1.0])          # normalised
    assert obs[1].radius == 20.0 and obs[3].radius == 4.0
    assert np.allclose(obs[2].half, HALF[2]) and np.allclose(obs[2].axes, np.eye(3))
    assert np.allclose(obs[3].end, END[3])


def test_obstacles_from_the_namelist_without_config(tmp_path, make_run):
    extra = ("&contact n_obstacles = 2, obstacle_shape(1) = 'plane', obstacle_shape(2) = 'sphere',\n"
             "  obstacle_point(:, 1) = 0.0, 0.0, -1.0, obstacle_normal(:, 1) = 0.0, 1.0, 1.0,\n"
             "  obstacle_point(:, 2) = 1.0, 2.0, 3.0, obstacle_radius(2) = 0.5 /\n")
    make_run(tmp_path / "n.h5", namelist_extra=extra)
    with read_run(tmp_path / "n.h5") as run:
        assert not run.config
        obs = contact_plot.obstacles(run)
    assert [o.shape for o in obs] == ["plane", "sphere"]
    assert np.allclose(obs[0].point, [0.0, 0.0, -1.0])
    assert np.allclose(obs[0].normal, np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0))
    assert np.allclose(obs[1].point, [1.0, 2.0, 3.0]) and obs[1].radius == 0.5


def test_shapes_are_drawn_where_they_are():
    """Every vertex on its shape's surface: the sphere's at its radius from
    the centre, the box's on its faces, the capsule's at its radius from
    the segment, the plane patch in the plane and under the cloth's box."""
    ob = contact_plot.Obstacle
    s = contact_plot.sphere_quads([1.0, 2.0, 3.0], 0.5).reshape(-1, 3)
    assert np.allclose(np.linalg.norm(s - [1.0, 2.0, 3.0], axis=1), 0.5)
    box = ob("box", np.array([1.0, 1.0, 1.0]), half=np.array([2.0, 1.0, 0.5]))
    v = np.abs(contact_plot.box_quads(box).reshape(-1, 3) - 1.0) / [2.0, 1.0, 0.5]
    assert np.allclose(v.max(axis=1), 1.0) and v.max() <= 1.0 + 1e-12
    cap = ob("capsule", np.array([0.0, 0.0, 0.0]), radius=0.3, end=np.array([0.0, 2.0, 0.0]))
    p = contact_plot.capsule_quads(cap).reshape(-1, 3)
    t = np.clip(p[:, 1] / 2.0, 0.0, 1.0)
    dist = np.linalg.norm(p - np.outer(t, [0.0, 2.0, 0.0]), axis=1)
    assert np.allclose(dist, 0.3)
    assert p[:, 1].min() < -0.29 and p[:, 1].max() > 2.29              # both caps
    plane = ob("plane", np.array([0.0, 0.0, -1.0]), normal=np.array([0.0, 0.0, 1.0]))
    q = contact_plot.plane_quads(plane, np.array([0.0, 0.0, 0.0]), np.array([4.0, 2.0, 1.0])).reshape(-1, 3)
    assert np.allclose(q[:, 2], -1.0)
    assert q[:, 0].min() < 0.0 and q[:, 0].max() > 4.0 and q[:, 1].min() < 0.0 and q[:, 1].max() > 2.0


def assert_image(path, fmt):
    assert path.is_file() and path.stat().st_size > 0
    with Image.open(path) as im:
        assert im.format == fmt
        assert im.size[0] >= 100 and im.size[1] >= 100
        return getattr(im, "n_frames", 1), im.size


def test_script_writes_png_and_small_gif(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nx=6, ny=5, nt=9)
    add_contact_config(tmp_path / "a.h5")
    png, gif = tmp_path / "a.png", tmp_path / "a.gif"
    proc = cli(tmp_path / "a.h5", "-o", png, "--gif", gif, "--frames", "5", "--size", "200")
    assert proc.returncode == 0, proc.stderr
    assert_image(png, "PNG")
    frames, size = assert_image(gif, "GIF")
    assert frames == 5 and size == (200, 200)
    assert gif.stat().st_size < 400 * 1024


def test_solids_first_draws_the_obstacles_under_the_cloth(tmp_path, make_run):
    """--solids-first: the solids (sphere, box, capsule) are one collection
    drawn after the plane and before the cloth, which is then alone in its
    own; by default the cloth and the solids are depth-sorted together. The
    script takes the option."""
    from postprocess import plotting
    make_run(tmp_path / "a.h5", nx=6, ny=5, nt=3)
    add_contact_config(tmp_path / "a.h5")
    run = read_run(str(tmp_path / "a.h5"))
    n_cloth = len(contact_plot.cloth_quads(run.position[0]))
    n_solid = sum(len(contact_plot.solid_quads(o)) for o in contact_plot.obstacles(run) if o.shape != "plane")
    assert n_solid > 0
    for first, expect in ((False, [n_cloth + n_solid]), (True, [n_solid, n_cloth])):
        fig, (ax,) = plotting.new_figure(1, ncols=1, projection="3d")
        artists = contact_plot.Scene(run, [0], solids_first=first).draw(ax, run.position[0])
        assert [a.get_zorder() for a in artists] == [1] * len(expect) + [2]
        fig.canvas.draw()                                                   # projects the quads
        assert [len(a.get_paths()) for a in artists[1:]] == expect          # artists[0]: the plane
    run.close()
    png = tmp_path / "a.png"
    proc = cli(tmp_path / "a.h5", "-o", png, "--solids-first")
    assert proc.returncode == 0, proc.stderr
    assert_image(png, "PNG")


def test_missing_file_and_bad_arguments_fail_cleanly(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nt=3)
    out = tmp_path / "x.png"
    cases = [((tmp_path / "missing.h5", "-o", out), "no such file"),
             ((tmp_path / "a.h5", "-o", out, "--gif", tmp_path / "x.mp4"), "--gif"),
             ((tmp_path / "a.h5", "-o", out, "--times", "99"), "outside"),
             ((tmp_path / "a.h5", "-o", out, "--gif", tmp_path / "x.gif", "--frames", "1"), "--frames")]
    for args, message in cases:
        proc = cli(*args)
        assert proc.returncode == 1, (args, proc.stderr)
        assert proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1, proc.stderr
        assert message in proc.stderr, proc.stderr
    assert not out.exists() and not (tmp_path / "x.gif").exists()
    proc = cli("--help")
    assert proc.returncode == 0 and "--gif" in proc.stdout


def test_unknown_shape_is_an_error(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nt=3)
    with h5py.File(tmp_path / "a.h5", "a") as f:
        g = f.require_group("config").require_group("contact")
        g.attrs["n_obstacles"] = np.int32(1)
        g.attrs["obstacle_shape"] = "torus"
    proc = cli(tmp_path / "a.h5", "-o", tmp_path / "t.png")
    assert proc.returncode == 1 and "torus" in proc.stderr, proc.stderr
    assert not (tmp_path / "t.png").exists()


def test_a_real_drop_onto_a_table(tmp_path):
    """input/drop_table.nml on 9 x 9 nodes, 2 ranks, 0.15 s: the file's
    /config gives the table, drawn under the cloth, and the script writes
    its figure."""
    from nunorun import exe, mpiexec
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(REPO / "input" / "drop_table.nml"),
           "-nuno_set", "nx=9,ny=9,t_end=0.15,output_interval=0.05,output_file='d.h5'"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    with read_run(tmp_path / "d.h5") as run:
        obs = contact_plot.obstacles(run)
        assert [o.shape for o in obs] == ["plane"] and np.isclose(obs[0].point[2], -0.05)
        scene = contact_plot.Scene(run, range(run.nt))
        assert np.isclose(scene.lo[2], -0.05)            # the table patch is the lowest thing drawn
    proc = cli(tmp_path / "d.h5", "-o", tmp_path / "d.png", "--units", "m")
    assert proc.returncode == 0, proc.stderr
    assert_image(tmp_path / "d.png", "PNG")
