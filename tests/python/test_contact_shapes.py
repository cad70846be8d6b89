# SPDX-License-Identifier: BSD-2-Clause
"""Contact with boxes, capsules and moving obstacles (&contact): a cloth
dropped over a table's edge (a box) is held by the top and falls beyond
the edge, slides off without friction and sticks with it; a cloth over a
rod (a capsule) rests on the rod's top; none penetrates on any accepted
state; a plane rising on keyframes lifts the sheet on it by the keyframes'
travel, and two gripper fingers (capsules closing on keyframes) pinch a
hanging cloth and carry it by theirs; bad keys of the new shapes and of
the motion are refused on 2 ranks. Small lattices, seconds each."""
import subprocess

import numpy as np

from nunorun import contact_lines as lines, contact_sheet, exe, mpiexec, run
from postprocess.reader import read_run

G = 9.81
MASS = 0.1


def groups(contact, t_end, out_dt, n=11):
    return contact_sheet(contact + " contact_dhat=1e-3 contact_stiffness=1.0", t_end, out_dt, n=n)


def positions(h5):
    with read_run(h5) as r:
        return np.asarray(r.time), np.asarray(r.position)


def test_box_table_edge_holds_the_cloth_and_lets_the_overhang_fall(tmp_path):
    """A table (a box, edge at x = 0.75, as input/table_edge.nml's but a
    quarter of the cloth beyond it) on 11 x 11 nodes (2 ranks), a softer
    cloth (k_b = 0.01 J) for 0.3 s: no node over the table is ever below its
    top (z = -0.05 plus the 2 mm thickness) and the box carries the cloth,
    while the part beyond the edge x = 0.75 falls well below the top (a
    plane would hold it up); no accepted state penetrates."""
    box = ("n_obstacles=1 obstacle_shape(1)='box' obstacle_point(:,1)=0.25,0.5,-0.45 "
           "obstacle_half_size(:,1)=0.5,0.75,0.4 obstacle_normal(:,1)=0.0,0.0,1.0 "
           "obstacle_axis(:,1)=1.0,0.0,0.0 obstacle_mu(1)=0.5 contact_thickness=2e-3 friction_eps_v=1e-2")
    g = groups(box, 0.3, 0.05)
    g["material"] = g["material"].replace("k_b=0.1", "k_b=0.01")
    proc, h5 = run(tmp_path, "edge", nranks=2, **g)
    rows = lines(proc.stdout)
    assert rows and rows[-1][6] > 0.0, rows[-1:]                    # every accepted state outside the box
    assert max(r[4] for r in rows) > 0.5 * MASS * G                 # the table carries the cloth
    _, x = positions(h5)
    top = -0.05 + 2e-3
    over = (x[..., 0] < 0.75) & (x[..., 1] > -0.25) & (x[..., 1] < 1.25)
    assert np.all(x[..., 2][over] > top), x[..., 2][over].min()
    last = x[-1]
    beyond = last[:, :, 0] > 0.85
    assert beyond.any() and np.all(last[beyond][:, 2] < top - 0.05), last[beyond][:, 2]


def test_table_edge_slides_without_friction_and_sticks_with_it(tmp_path):
    """input/table_edge.nml's table (edge at x = 0.6, 40 % of the cloth
    beyond it) on 11 x 11 nodes for 0.6 s: without friction nothing holds
    the part on the table against the overhang's pull, and its far edge
    slides more than 10 cm towards the edge; with mu = 0.8, above the static
    limit 0.4/0.6 of the weights beyond and on the table, it sticks (less than
    3 cm, the cloth's stretch and swing)."""
    far = {}
    for mu in (0.0, 0.8):
        box = ("n_obstacles=1 obstacle_shape(1)='box' obstacle_point(:,1)=0.1,0.5,-0.45 "
               "obstacle_half_size(:,1)=0.5,0.75,0.4 obstacle_normal(:,1)=0.0,0.0,1.0 "
               f"obstacle_axis(:,1)=1.0,0.0,0.0 obstacle_mu(1)={mu} contact_thickness=2e-3 friction_eps_v=1e-2")
        g = groups(box, 0.6, 0.05)
        g["material"] = g["material"].replace("k_b=0.1", "k_b=0.01")
        (tmp_path / f"mu{mu}").mkdir()
        proc, h5 = run(tmp_path / f"mu{mu}", "slide", nranks=2, **g)
        assert lines(proc.stdout)[-1][6] > 0.0
        _, x = positions(h5)
        far[mu] = x[:, :, :, 0].min(axis=(1, 2)).max()               # the far edge's largest advance from x = 0
    assert far[0.0] > 0.1, far
    assert far[0.8] < 0.03, far


def test_capsule_rod_carries_the_cloth(tmp_path):
    """A cloth dropped onto a rod (a capsule along y at x = 0.5, radius
    2 cm, top 3 cm below the cloth): the nodes on the rod's line rest on its
    top (but the two at the cloth's free edges, which curl up), the sides
    hang below it, the rod carries the load, and no accepted state
    penetrates."""
    rod = ("n_obstacles=1 obstacle_shape(1)='capsule' obstacle_point(:,1)=0.5,-0.2,-0.05 "
           "obstacle_end(:,1)=0.5,1.2,-0.05 obstacle_radius(1)=0.02 obstacle_mu(1)=0.3")
    proc, h5 = run(tmp_path, "rod", nranks=2, **groups(rod, 0.25, 0.05))
    rows = lines(proc.stdout)
    assert rows and rows[-1][6] > 0.0, rows[-1:]
    assert max(r[4] for r in rows) > 0.1 * MASS * G
    _, x = positions(h5)
    last = x[-1]
    ridge = last[:, 5, 2]                                           # the column i = 5 at x = 0.5, over the rod
    assert np.all(ridge > -0.03), ridge                             # above the rod's top, z = -0.05 + 0.02
    assert np.all(ridge[1:-1] - (-0.03) < 1e-3), ridge              # resting on it (the free edges' ends curl up)
    assert np.all(last[:, 0, 2] < -0.06) and np.all(last[:, 10, 2] < -0.06)


def test_rising_plane_lifts_the_sheet_by_its_travel(tmp_path):
    """A sheet resting on a plane (z = -1 mm, mu = 0) that rises 2 cm on
    keyframes between t = 0.05 and 0.35 s (speeding up, slowing down): from the state before the rise to the end, every node rises by
    the keyframes' 2 cm, within the barrier's reach of 1 mm (a node rides
    at a gap below it, which changes with the load), and no accepted state
    penetrates the moving plane."""
    rise = 0.02
    # a smoothstep 3u^2 - 2u^3 through 7 keyframes 0.05 s apart: at most
    # 0.1 mm a step, less than the gap at which the barrier carries a node
    times = [0.05 + 0.05 * k for k in range(7)]
    offsets = [rise * (3 * (k / 6) ** 2 - 2 * (k / 6) ** 3) for k in range(7)]
    plane = ("n_obstacles=1 obstacle_shape(1)='plane' obstacle_point(:,1)=0.0,0.0,-1e-3 "
             "obstacle_normal(:,1)=0.0,0.0,1.0 obstacle_n_keyframes(1)=7 "
             f"obstacle_time(1:7,1)={','.join(f'{t:.4f}' for t in times)} "
             + " ".join(f"obstacle_offset(:,{k + 1},1)=0.0,0.0,{z:.8f}" for k, z in enumerate(offsets)))
    g = groups(plane, 0.5, 0.05, n=7)
    g["contact"] = g["contact"].replace("contact_stiffness=1.0", "contact_stiffness=10.0")
    proc, h5 = run(tmp_path, "rise", nranks=2, **g)
    rows = lines(proc.stdout)
    assert rows and rows[-1][6] > 0.0, rows[-1:]
    t, x = positions(h5)
    before = x[np.argmin(np.abs(t - 0.05))]
    dz = x[-1][..., 2] - before[..., 2]
    assert np.all(np.abs(dz - rise) < 1e-3), dz
    assert np.abs(x[-1][..., :2] - before[..., :2]).max() < 1e-4    # straight up: no sliding


def test_gripper_fingers_pinch_and_carry_the_cloth(tmp_path):
    """input/gripper.nml's fingers (two capsules closing on a cloth hanging
    in its plane, gravity along +x, edge i = 0 held) on 11 x 11 nodes,
    faster: closed by t = 0.5 s, then pulled 5 cm along +z by t = 1.2 s. The
    pinched column i = 5 ends 5 cm out (the keyframes' offset: it is held
    between the fingers) and stays between them (its x within 5 mm of where
    it was pinched, against the weight below and the pull above); no
    accepted state penetrates a finger."""
    fingers = ("n_obstacles=2 obstacle_shape(1:2)='capsule','capsule' "
               "obstacle_point(:,1)=0.5,-0.1,0.05 obstacle_end(:,1)=0.5,1.1,0.05 "
               "obstacle_point(:,2)=0.5,-0.1,-0.05 obstacle_end(:,2)=0.5,1.1,-0.05 "
               "obstacle_radius(1:2)=0.01,0.01 obstacle_mu(1:2)=0.5,0.5 "
               "obstacle_close_dir(:,1)=0.0,0.0,-1.0 obstacle_close_dir(:,2)=0.0,0.0,1.0 "
               "obstacle_n_keyframes(1:2)=4,4 obstacle_time(1:4,1)=0.0,0.2,0.5,1.2 "
               "obstacle_time(1:4,2)=0.0,0.2,0.5,1.2 obstacle_close(1:4,1)=0.0,0.035,0.0399,0.0399 "
               "obstacle_close(1:4,2)=0.0,0.035,0.0399,0.0399 obstacle_offset(:,4,1)=0.0,0.0,0.05 "
               "obstacle_offset(:,4,2)=0.0,0.0,0.05 friction_eps_v=1e-2")
    g = groups(fingers, 1.3, 0.05)
    g["scene"] = ("scene='wave_point' wave_nodes='edge' gravity=9.81,0.0,0.0 n_keyframes=1 keyframe_time=0.0 "
                  "keyframe_dx=0.0 keyframe_dy=0.0 keyframe_dz=0.0")
    g["contact"] = g["contact"].replace("contact_stiffness=1.0", "contact_stiffness=10.0")
    proc, h5 = run(tmp_path, "grip", nranks=2, **g)
    rows = lines(proc.stdout)
    assert rows and rows[-1][6] > 0.0, rows[-1:]
    t, x = positions(h5)
    pinched = x[np.argmin(np.abs(t - 0.5))][:, 5, :]
    last = x[-1][:, 5, :]
    assert np.all(np.abs(last[:, 2] - 0.05) < 1e-3), last[:, 2]
    assert np.all(np.abs(last[:, 0] - pinched[:, 0]) < 5e-3), last[:, 0] - pinched[:, 0]


def test_bad_shape_and_motion_keys_are_refused_on_two_ranks(tmp_path):
    box = "n_obstacles=1 obstacle_shape(1)='box' obstacle_half_size(:,1)=0.5,0.5,0.5"
    cases = {
        "n_obstacles=1 obstacle_shape(1)='box' obstacle_half_size(:,1)=0.5,0.0,0.1":
            ["obstacle_half_size(:, 1)", "0.5, 0.0, 0.1"],
        box + " obstacle_axis(:,1)=0.0,0.0,2.0": ["obstacle_axis(:, 1)", "0.0, 0.0, 2.0", "parallel"],
        "n_obstacles=1 obstacle_shape(1)='capsule' obstacle_end(:,1)=1.0,0.0,0.0": ["obstacle_radius(1)", "capsule"],
        "n_obstacles=1 obstacle_n_keyframes(1)=17": ["obstacle_n_keyframes(1)", "17"],
        "n_obstacles=1 obstacle_n_keyframes(1)=2 obstacle_time(1:2,1)=0.5,0.5": ["obstacle_time(2, 1)", "0.5"],
        "n_obstacles=1 obstacle_n_keyframes(1)=1 obstacle_offset(:,2,1)=0.0,0.0,0.1":
            ["obstacle_offset(:, 2, 1)", "0.0, 0.0, 0.1", "obstacle_n_keyframes(1)"],
        "n_obstacles=1 obstacle_n_keyframes(1)=2 obstacle_time(1:2,1)=0.0,1.0 obstacle_close(1:2,1)=0.0,0.01":
            ["obstacle_close_dir(:, 1)", "0.0, 0.0, 0.0"],
    }
    for text, words in cases.items():
        (tmp_path / "bad.nml").write_text(f"&contact {text} /\n&output output_file='bad.h5' /\n")
        proc = subprocess.run([mpiexec(), "-n", "2", "--oversubscribe", exe(), "bad.nml"], cwd=tmp_path,
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode != 0, text
        errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
        assert len(errors) == 1, proc.stderr
        assert all(w in errors[0] for w in words), (text, errors[0])
        assert not (tmp_path / "bad.h5").exists()
