# SPDX-License-Identifier: BSD-2-Clause
"""Bad contact input gets one clear line before the run, and nothing is
lost (issue 47 item 7; input/README.md, "&contact"). Each case on 2 ranks:
a non-zero exit, one error line that names the key, the obstacle or the
node, and no output file (or, for a restart, the file byte for byte as it
was). Each of these ran on main (e3c7ad0): a cloth inside an obstacle
stopped with a PETSc error after the start-up summary, prescribed nodes
driven into an obstacle completed silently, a restart into a moved
obstacle aborted and left the file marked running, obstacles beyond
n_obstacles were ignored, absurd barrier and friction parameters passed
the checks, and obstacle_shape(9) gave the reader's "Index 1 out of
range". drop_table's cloth on a 7 x 7 lattice (spacing 1/6 m)."""
import h5py

from nunorun import contact_sheet, plane_below, run


def one_error(proc):
    """The run failed with exactly one error line; that line."""
    assert proc.returncode != 0, proc.stdout[-2000:]
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1, proc.stderr[-3000:]
    return errors[0]


def nothing_written(tmp_path):
    left = sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".nml"))
    assert left == [], left


def refused(tmp_path, contact, scene=None, t_end=0.01, **extra):
    g = contact_sheet(contact, t_end, t_end, units="SI")
    if scene is not None:
        g["scene"] = scene
    g.update(extra)
    proc, _ = run(tmp_path, "bad", nranks=2, check=False, timeout=120, **g)
    line = one_error(proc)
    nothing_written(tmp_path)
    return line


def test_cloth_starting_inside_an_obstacle_is_refused(tmp_path):
    """The plane 1 cm above the flat sheet: every node inside it."""
    line = refused(tmp_path, plane_below(-0.01))
    assert "the initial state: 49 nodes lie inside obstacle 1 ('plane')" in line, line
    assert "the first node (0, 0)" in line, line


def test_cloth_starting_within_the_thickness_is_refused(tmp_path):
    """A sphere under the sheet's middle, its surface 5 mm below it, with
    contact_thickness 1 cm: one node within the thickness."""
    contact = ("n_obstacles=1 obstacle_shape(1)='sphere' obstacle_point(:,1)=0.5,0.5,-0.105 obstacle_radius(1)=0.1 "
               "contact_thickness=0.01")
    line = refused(tmp_path, contact)
    assert "1 nodes lie inside obstacle 1 ('sphere') or within its contact_thickness" in line, line
    assert "the first node (3, 3)" in line, line


def test_prescribed_path_into_an_obstacle_is_refused(tmp_path):
    """The sheet's edge i = 0 on keyframes down through a plane 5 cm below
    it (10 cm at t = 0.5 s): refused before the run, naming the plane, the
    7 nodes, the first of them and when it gets there (t = 0.25 s)."""
    scene = ("scene='wave_point' wave_nodes='edge' gravity=0.0,0.0,-9.81 units='SI' n_keyframes=2 "
             "keyframe_time=0.0,0.5 keyframe_dx=0.0,0.0 keyframe_dy=0.0,0.0 keyframe_dz=0.0,-0.1")
    line = refused(tmp_path, plane_below(0.05), scene=scene, t_end=1.0)
    assert "7 prescribed nodes' paths (pinned or on keyframes) enter obstacle 1 ('plane')" in line, line
    assert "the first node (0, 0) at t = 2.50000E-01" in line, line


def test_restart_into_a_moved_obstacle_is_refused(tmp_path):
    """A sheet falls 0.1 s (5 cm) over a plane 1 m below; the restart's
    plane, 3 cm below the start, contains the checkpoint's sheet (not the
    initial one): refused before the file changes."""
    g = contact_sheet(plane_below(1.0), 0.1, 0.05, units="SI")
    run(tmp_path, "fall", nranks=2, **g)
    h5 = tmp_path / "fall.h5"
    data = h5.read_bytes()
    g = contact_sheet(plane_below(0.03), 0.2, 0.05, units="SI")
    proc, _ = run(tmp_path, "fall", nranks=2, options=["-nuno_restart", str(h5)], check=False, timeout=120, **g)
    line = one_error(proc)
    assert "-nuno_restart: &contact: the checkpoint's state at t =" in line, line
    assert "49 nodes lie inside obstacle 1 ('plane')" in line, line
    assert h5.read_bytes() == data
    with h5py.File(h5, "r") as f:
        assert f.attrs["status"].decode() == "complete"


def test_obstacle_beyond_n_obstacles_is_refused(tmp_path):
    contact = plane_below(1.0) + " obstacle_shape(2)='sphere' obstacle_point(:,2)=0.5,0.5,0.5 obstacle_radius(2)=0.1"
    line = refused(tmp_path, contact)
    assert "obstacle_shape(2) = 'sphere' describes obstacle 2, beyond n_obstacles = 1" in line, line


def test_obstacle_index_beyond_8_is_named(tmp_path):
    """In the namelist file and in -nuno_set alike."""
    line = refused(tmp_path, plane_below(1.0) + " obstacle_radius(9)=0.1")
    assert "obstacle_radius(9)" in line and "obstacle 9 is beyond the last one nuno takes, obstacle 8" in line, line
    g = contact_sheet(plane_below(1.0), 0.01, 0.01, units="SI")
    proc, _ = run(tmp_path, "set", nranks=2, options=["-nuno_set", "obstacle_shape(9)='sphere'"], check=False,
                  timeout=120, **g)
    line = one_error(proc)
    assert "-nuno_set" in line and "obstacle 9 is beyond the last one nuno takes, obstacle 8" in line, line
    nothing_written(tmp_path)


def test_barrier_and_friction_outside_their_ranges_are_refused(tmp_path):
    """contact_dhat beyond the lattice spacing (1/6 m) and far below it,
    contact_stiffness beyond 100 m/dt^2 and too soft to hold a node's
    weight, friction_eps_v far below 1e-7 a/dt and beyond a/dt."""
    cases = [("contact_dhat", dict(dhat=10.0), "times the lattice spacing"),
             ("contact_dhat", dict(dhat=1e-9), "times the lattice spacing"),
             ("contact_stiffness", dict(kappa=1e12), "must be at most 100 m/dt^2"),
             ("contact_stiffness", dict(kappa=1e-9), "must hold the heaviest node's weight"),
             ("friction_eps_v", dict(eps_v=1e-15), "times a/dt"),
             ("friction_eps_v", dict(eps_v=1000.0), "times a/dt")]
    for n, (key, value, says) in enumerate(cases):
        d = tmp_path / f"case{n}"
        d.mkdir()
        line = refused(d, plane_below(1.0, mu=0.3, **value))
        assert f"input: &contact: {key} = " in line and says in line, line
        assert 'input/README.md, "&contact"' in line, line
