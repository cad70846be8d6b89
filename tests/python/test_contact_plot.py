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

from postprocess import contact_plot, plotting
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


# ---------------------------------------------------------------- moving obstacles, box axes, side sections

# input/gripper.nml's fingers as /config/contact packs them (src/run/provenance.F90):
# each obstacle's n_keyframes(k) keyframes one after the other.
FINGER_TIME = [0.0, 0.2, 0.7, 2.2]
FINGER_CLOSE = [0.0, 0.035, 0.0399, 0.0399]
FINGER_PULL = 0.05        # offset along +z at the last keyframe


def add_fingers(path, gravity=(9.81, 0.0, 0.0)):
    with h5py.File(path, "a") as f:
        f.attrs["units"] = "SI"
        f.require_group("config").require_group("scene").attrs["gravity"] = np.asarray(gravity, float)
        g = f["config"].require_group("contact")
        g.attrs["n_obstacles"] = np.int32(2)
        g.attrs["obstacle_shape"] = "capsule, capsule"
        g.attrs["obstacle_point"] = np.array([0.5, -0.1, 0.05, 0.5, -0.1, -0.05])
        g.attrs["obstacle_end"] = np.array([0.5, 1.1, 0.05, 0.5, 1.1, -0.05])
        g.attrs["obstacle_radius"] = np.array([0.01, 0.01])
        g.attrs["obstacle_n_keyframes"] = np.array([4.0, 4.0])
        g.attrs["obstacle_time"] = np.array(FINGER_TIME * 2)
        g.attrs["obstacle_close"] = np.array(FINGER_CLOSE * 2)
        offset = np.zeros((4, 3))
        offset[3, 2] = FINGER_PULL
        g.attrs["obstacle_offset"] = np.concatenate([offset.ravel(), offset.ravel()])
        g.attrs["obstacle_close_dir"] = np.array([0.0, 0.0, -1.0, 0.0, 0.0, 1.0])
        g.attrs["contact_dhat"] = 1e-3


def finger_z(t, k):
    """Finger k's axis z at time t, worked out by hand from the keyframes:
    start -+0.05, closing offset along -+z, pull along +z (linear between
    keyframes, held after the last)."""
    close = np.interp(t, FINGER_TIME, FINGER_CLOSE)
    pull = np.interp(t, FINGER_TIME, [0.0, 0.0, 0.0, FINGER_PULL])
    return (0.05 - close if k == 0 else -0.05 + close) + pull


def set_positions(path, z_of_step, lx=1.0, ly=0.8):
    """Positions of a make_run file replaced by the flat rest sheet at heights z_of_step [nt]
    (or a function of the rest position (x, y) and the step)."""
    with h5py.File(path, "a") as f:
        pos = f["position"][()]
        ny, nx = pos.shape[1:3]
        xs, ys = np.meshgrid(np.linspace(0.0, lx, nx), np.linspace(0.0, ly, ny))
        for k in range(pos.shape[0]):
            pos[k, ..., 0], pos[k, ..., 1] = xs, ys
            pos[k, ..., 2] = z_of_step(xs, ys, k)
        f["position"][...] = pos


def test_keyframed_fingers_are_where_their_keyframes_put_them(tmp_path, make_run):
    make_run(tmp_path / "g.h5", nt=3)
    add_fingers(tmp_path / "g.h5")
    with read_run(tmp_path / "g.h5") as run:
        obs = contact_plot.obstacles(run)
    assert [o.shape for o in obs] == ["capsule", "capsule"]
    for t in (0.0, 0.1, 0.45, 0.7, 1.45, 2.2, 3.0):
        for k, o in enumerate(obs):
            moved = o.at(t)
            assert moved.point == pytest.approx([0.5, -0.1, finger_z(t, k)], abs=1e-15), (t, k)
            assert moved.end == pytest.approx([0.5, 1.1, finger_z(t, k)], abs=1e-15), (t, k)
    assert finger_z(0.45, 0) == pytest.approx(0.05 - 0.03745) and finger_z(3.0, 0) == pytest.approx(0.0601)


def test_side_view_draws_the_fingers_where_they_are(tmp_path, make_run):
    """--view side on the x-z plane of a cloth hanging along +x (gravity +x):
    x points down (the vertical axis reversed), and each finger's outline
    is a circle of its radius about its axis at the panel's time."""
    make_run(tmp_path / "g.h5", nt=4, dt=0.5)                       # t = 0, 0.5, 1.0, 1.5
    add_fingers(tmp_path / "g.h5")
    set_positions(tmp_path / "g.h5", lambda x, y, k: 0.0 * x)
    run = read_run(tmp_path / "g.h5")
    fig, sec = contact_plot.build_side_figure(run, [0, 1, 3], "m", plane="xz")
    for ax, k in zip(plotting.panels(fig), [0, 1, 3]):
        lo, hi = ax.get_ylim()
        assert lo > hi                                   # x grows downwards: gravity is +x
        assert ax.get_xlabel() == "z [m]"
        fills = [p for p in ax.patches]                  # the two finger outlines (ax.fill)
        assert len(fills) == 2
        t = float(run.time[k])
        for finger, patch in enumerate(fills):
            xy = patch.get_xy()                          # (z, x) data coordinates
            centre = np.array([finger_z(t, finger), 0.5])
            r = np.linalg.norm(xy - centre, axis=1)
            assert r.max() == pytest.approx(0.01, rel=1e-9) and r.min() > 0.0099, (t, finger)
    out = tmp_path / "g.png"
    proc = cli(tmp_path / "g.h5", "-o", out, "--view", "side", "--plane", "xz", "--zoom", "obstacles",
               "--gif", tmp_path / "g.gif", "--frames", "3", "--size", "200")
    assert proc.returncode == 0, proc.stderr
    assert_image(out, "PNG")
    assert assert_image(tmp_path / "g.gif", "GIF") == (3, (200, 200))


def test_side_view_zooms_on_a_millimetre_gap(tmp_path, make_run):
    """A sheet resting 0.3 mm above a table (a plane, z = 0) with contact_dhat
    = 1 mm, and 5 cm above it at the first step: --zoom each frames each
    panel on the cloth and the table near it, so the 0.3 mm gap is a tenth
    of the resting panel's height or more; the table's top and the
    barrier's reach (dashed, 1 mm above it) are in the frame."""
    make_run(tmp_path / "d.h5", nt=2)
    heights = [0.05, 3e-4]
    set_positions(tmp_path / "d.h5", lambda x, y, k: 0.0 * x + heights[k])
    with h5py.File(tmp_path / "d.h5", "a") as f:
        f.attrs["units"] = "SI"
        f.require_group("config").require_group("scene").attrs["gravity"] = np.array([0.0, 0.0, -9.81])
        g = f["config"].require_group("contact")
        g.attrs["n_obstacles"] = np.int32(1)
        g.attrs["obstacle_shape"] = "plane"
        g.attrs["obstacle_point"] = np.zeros(3)
        g.attrs["obstacle_normal"] = np.array([0.0, 0.0, 1.0])
        g.attrs["contact_dhat"] = 1e-3
    run = read_run(tmp_path / "d.h5")
    fig, _ = contact_plot.build_side_figure(run, [0, 1], "m", plane="xz", zoom="each", aspect="auto")
    for ax, z in zip(plotting.panels(fig), heights):
        lo, hi = ax.get_ylim()
        assert lo < 0.0 < 1e-3 < hi and lo < z < hi          # table, reach and cloth in view
        assert z / (hi - lo) >= 0.1, (z, lo, hi)
        dashed = [ln for ln in ax.lines if ln.get_linestyle() == "--"]
        assert [ln.get_ydata()[0] for ln in dashed] == [pytest.approx(1e-3)]
    assert not (plotting.panels(fig)[1].get_ylim()[1] > 0.01)   # the resting panel: zoomed in
    # one range for all (the default): the 5 cm drop sets it
    fig, _ = contact_plot.build_side_figure(run, [0, 1], "m", plane="xz", aspect="auto")
    assert all(ax.get_ylim()[1] > 0.05 for ax in plotting.panels(fig))


def test_view_axes_and_hull():
    from postprocess import contact_section as cs
    assert cs.view_axes("xz", np.array([0.0, 0.0, -9.81])) == (0, 2, False)
    assert cs.view_axes("xz", np.array([9.81, 0.0, 0.0])) == (2, 0, True)
    assert cs.view_axes("yz", None) == (1, 2, False)
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(200, 2))
    hull = cs.convex_hull(pts)
    edges = np.roll(hull, -1, axis=0) - hull
    rel = pts[:, None, :] - hull[None, :, :]
    assert np.all(edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0] >= -1e-12)  # all inside
    # a half-plane clip of the unit square
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    part = cs.clip_halfplane(sq, np.array([0.0, 1.0]), 0.25)
    assert part[:, 1].max() == pytest.approx(0.25) and len(part) == 4


def test_box_axes_follow_obstacle_axis_and_normal(tmp_path, make_run):
    """A box turned 45 degrees about z (obstacle_axis = 1, 1, 0): its corners
    lie on its local axes (x along (1, 1)/sqrt 2), not on the world's."""
    make_run(tmp_path / "b.h5", nt=2)
    with h5py.File(tmp_path / "b.h5", "a") as f:
        g = f.require_group("config").require_group("contact")
        g.attrs["n_obstacles"] = np.int32(1)
        g.attrs["obstacle_shape"] = "box"
        g.attrs["obstacle_point"] = np.array([1.0, 2.0, 3.0])
        g.attrs["obstacle_half_size"] = np.array([2.0, 1.0, 0.5])
        g.attrs["obstacle_normal"] = np.array([0.0, 0.0, 1.0])
        g.attrs["obstacle_axis"] = np.array([1.0, 1.0, 0.0])
    with read_run(tmp_path / "b.h5") as run:
        (box,) = contact_plot.obstacles(run)
    ex, ey = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0), np.array([-1.0, 1.0, 0.0]) / np.sqrt(2.0)
    v = contact_plot.box_quads(box).reshape(-1, 3) - [1.0, 2.0, 3.0]
    local = np.abs(np.column_stack([v @ ex, v @ ey, v[:, 2]])) / [2.0, 1.0, 0.5]
    assert local.max() <= 1.0 + 1e-12 and np.allclose(local.max(axis=1), 1.0)


def test_side_options_need_the_side_view(tmp_path, make_run):
    make_run(tmp_path / "a.h5", nt=3)
    for args, message in ((("--plane", "xz"), "--plane goes with --view side"),
                          (("--view", "side", "--hlim", "1", "0"), "--hlim 1 0"),
                          (("--view", "side", "--elev", "10"), "go with --view iso")):
        proc = cli(tmp_path / "a.h5", "-o", tmp_path / "x.png", *args)
        assert proc.returncode == 1 and message in proc.stderr, (args, proc.stderr)
    assert not (tmp_path / "x.png").exists()


def test_a_real_gripper_pinch_seen_from_the_side(tmp_path):
    """input/gripper.nml on 11 x 11 nodes to t = 0.3 s (2 ranks): the real
    file's keyframes put the fingers at z = +-(0.05 - 0.03598) at 0.3 s
    (closing 0.035 m by 0.2 s, then 0.0049 m over 0.5 s), the cloth between
    them, and the section shows it."""
    from nunorun import exe, mpiexec
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(REPO / "input" / "gripper.nml"),
           "-nuno_set", "nx=11,ny=11,t_end=0.3,output_interval=0.1,output_file='g.h5'"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    run = read_run(tmp_path / "g.h5")
    k = run.step_index(0.3)
    z = 0.05 - (0.035 + 0.0049 * 0.1 / 0.5)
    fig, _ = contact_plot.build_side_figure(run, [k], "m", plane="xz", zoom="obstacles")
    (ax,) = plotting.panels(fig)
    centres = sorted(0.5 * (p.get_xy()[:, 0].min() + p.get_xy()[:, 0].max()) for p in ax.patches)
    assert centres == [pytest.approx(-z, abs=1e-4), pytest.approx(z, abs=1e-4)]
    cloth_z = np.asarray(run.position[k])[..., 2]
    assert -z + 0.01 < cloth_z.min() and cloth_z.max() < z - 0.01       # between the fingers
    zlo, zhi = ax.get_xlim()
    assert zlo < -z - 0.01 and z + 0.01 < zhi                            # both in the zoomed frame
