# SPDX-License-Identifier: BSD-2-Clause
"""The scenes of issue 47 item 9 (input/lift.nml, input/box_on_table.nml,
input/gripper_lift.nml), each as shipped but coarse (11 x 11) and short,
on 2 ranks. Expectations from the input file (read here with f90nml, not
by nuno) and from mechanics, never from nuno's output:

- every run completes with no retried step and no accepted state at or
  inside an obstacle (/contact/min_gap_run > 0);
- lift (a 0.5 m cloth, the bar under its middle): the line of nodes over
  the bar rides on it, within contact_dhat of its top, at every output
  while it rises (so at its 0.5 m/s); the cloth leaves the table, and from
  then on its centre of mass stays below the bar's top and at most L/4
  below it (each half, of length L/2, hangs from the bar), so over the
  lifted time T it rises at the bar's speed to within L / (4 T);
- box_on_table: at every step the cloth's momentum balance of backward
  Euler, m (v_cm(n) - v_cm(n-1)) / dt = F_contact(n) - m g e_z (the
  internal forces sum to zero), holds to the Newton solve's tolerance
  (1e-6 m g); the cloth comes to rest (kinetic energy below 1e-4 of m g
  times the drop to the table), and its weight is carried by the contact
  force, |F_z - m g| <= m |a_cm| <= 1 % m g over the last 0.1 s, by the box
  (nodes within reach of its top) and by the table (nodes within reach of
  it); no node is inside the box or below the table at any output
  (distances computed here from the namelist's box);
- gripper_lift (a 0.5 m cloth): from the fingers' closing on, the pinched
  line of nodes stays between the fingers (their poses from the
  keyframes), so it rises with them at 0.5 m/s; by the end every node is
  off the table (above its reach).

Without the friction's slip limit (docs/contact.md, "Friction"), the box
run retried a step at t = 0.216 s. About a minute on an idle 2-core
machine."""
import subprocess

import f90nml
import numpy as np

from nunorun import ROOT, exe, mpiexec, read_run

G = 9.81


def contact_keys(scene):
    """The scene's &contact group (f90nml) and a getter of obstacle k's
    value of key (an array's k-th column, whatever its start index)."""
    c = f90nml.read(str(ROOT / "input" / f"{scene}.nml"))["contact"]

    def of(key, k, default=None):
        val = c.get(key, default)
        start = (c.start_index.get(key) or [None])[-1] or 1
        if not isinstance(val, list):
            return val
        if k - start < 0 or k - start >= len(val):
            return default
        return val[k - start]
    return c, of


def keyframed(c, of, k, t):
    """Obstacle k's translation along z and its closing distance at times t
    [s], piecewise linear between its keyframes (input/README.md,
    &contact: the values of keyframes not given are zero)."""
    n = of("obstacle_n_keyframes", k, 1) or 1
    times = np.asarray(of("obstacle_time", k)[:n], float)
    dz = np.zeros(n)
    given = of("obstacle_offset", k) or []
    first = (c.start_index.get("obstacle_offset") or [None, 1])[1] or 1    # its first keyframe's index
    for i, d in enumerate(given):
        if d is not None and d[2] is not None:
            dz[first - 1 + i] = d[2]
    closes = of("obstacle_close", k) or []
    close = np.array([float(closes[i]) if i < len(closes) and closes[i] is not None else 0.0
                      for i in range(n)])
    return np.interp(t, times, dz), np.interp(t, times, close)


def run_scene(tmp_path, scene, sets):
    """The shipped scene on 2 ranks with -nuno_set `sets`; the run's file."""
    cmd = [mpiexec(), "-n", "2", "--oversubscribe", exe(), str(ROOT / "input" / f"{scene}.nml"),
           "-nuno_set", f"output_file='s.h5',{sets}"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return read_run(str(tmp_path / "s.h5"))


def centre_of_mass_z(r, p):
    m = np.asarray(r.mass)
    return (p[..., 2] * m).sum(axis=(1, 2)) / m.sum()


def test_lift_carries_the_cloth_off_the_table_at_the_bar_speed(tmp_path):
    c, of = contact_keys("lift")
    L, n = 0.5, 11
    x_bar = L / 2
    r = run_scene(tmp_path, "lift", f"nx={n},ny={n},lx={L},ly={L},total_mass=0.025,"
                                    f"obstacle_point(1,2)={x_bar},obstacle_end(1,2)={x_bar},t_end=1.8")
    with r:
        assert r.run_info["retried_steps"] == 0
        assert np.asarray(r.contact["min_gap_run"])[-1] > 0.0
        t = np.asarray(r.time)
        p = np.asarray(r.position)
        zc = centre_of_mass_z(r, p)
    dhat, thick = c["contact_dhat"], c.get("contact_thickness", 0.0)
    table = of("obstacle_point", 1)[2]
    dz, _ = keyframed(c, of, 2, t)
    top = of("obstacle_point", 2)[2] + of("obstacle_radius", 2) + dz        # the bar's top [m]
    i_bar = round(x_bar / (L / (n - 1)))
    line = p[:, :, i_bar, 2]                                                 # (time, j): the nodes over the bar
    t_rise = of("obstacle_time", 2)[1:3]
    riding = (top > 0.0) & (t <= t_rise[1] + 1e-9)
    assert riding.sum() >= 10
    lift = line[riding] - top[riding, None]
    assert np.all(lift > 0.0) and np.all(lift <= thick + dhat), lift.min()  # on the bar, within reach
    off = np.array([np.all(p[k, ..., 2] > table + thick + dhat) for k in range(len(t))])
    lifted = off & (t <= t_rise[1] + 1e-9)
    k0 = int(np.argmax(lifted))
    assert lifted.any() and np.all(off[k0:]), off                            # it left the table, for good
    below = top[lifted] - zc[lifted]
    assert np.all(below > 0.0) and np.all(below <= L / 4), below
    T = t[lifted][-1] - t[lifted][0]
    v = 0.8 / (t_rise[1] - t_rise[0])
    speed = (zc[lifted][-1] - zc[lifted][0]) / T
    assert T > 0.5 and abs(speed - v) <= L / (4 * T), (speed, T)


def test_box_on_table_carries_the_cloth_weight(tmp_path):
    c, of = contact_keys("box_on_table")
    r = run_scene(tmp_path, "box_on_table", "nx=11,ny=11,t_end=0.7,output_interval=1e-3")
    with r:
        assert r.run_info["retried_steps"] == 0
        assert np.asarray(r.contact["min_gap_run"])[-1] > 0.0
        t = np.asarray(r.time)
        p = np.asarray(r.position)
        v = np.asarray(r.velocity)
        F = np.asarray(r.contact["force"])
        m_node = np.asarray(r.mass)
    m = m_node.sum()
    assert abs(m - 0.1) < 1e-12
    dt = np.diff(t)
    assert np.allclose(dt, 1e-3)                                             # an output at every step
    P = (v * m_node[None, :, :, None]).sum(axis=(1, 2))                     # momentum
    balance = F[1:] - np.diff(P, axis=0) / dt[:, None] - np.array([0.0, 0.0, m * G])
    assert np.abs(balance).max() < 1e-6 * m * G, np.abs(balance).max()
    # at rest at the end, its weight carried
    k = np.nonzero(t >= t[-1] - 0.1 - 1e-9)[0]                              # the last 0.1 s's steps
    a_cm = (P[k[1:], 2] - P[k[:-1], 2]) / (t[k[1:]] - t[k[:-1]]) / m
    assert np.abs(a_cm).max() <= 0.01 * G, np.abs(a_cm).max()
    assert np.all(np.abs(F[k[1:], 2] - m * G) <= m * np.abs(a_cm) + 1e-6 * m * G)
    thick, dhat = c["contact_thickness"], c["contact_dhat"]
    table = of("obstacle_point", 1)[2]
    centre, half = np.asarray(of("obstacle_point", 2)), np.asarray(of("obstacle_half_size", 2))
    ke = 0.5 * (m_node[..., None] * v[-1] ** 2).sum()
    assert ke < 1e-4 * m * G * (0.0 - table), ke
    # no node inside the box (grown by the thickness) or the table, at any output
    q = np.abs(p - centre) - half                                            # (time, j, i, 3)
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)
    assert outside.min() > thick, outside.min()
    assert p[..., 2].min() > table + thick
    # carried by both: nodes within reach of the box's top and of the table at the end
    z = p[-1, ..., 2]
    on_box = np.abs(z - (centre[2] + half[2] + thick)) < dhat
    on_table = z - (table + thick) < dhat
    assert on_box.sum() >= 9 and on_table.sum() >= 4, (on_box.sum(), on_table.sum())


def edge_axis_gap(p, x_axis, z_axis, rad):
    """Smallest gap of the cloth's edges (x- and y-links, the quads' main
    diagonals) in positions p [..., ny, nx, 3] to a capsule along y through
    (x_axis, z_axis) of radius rad, for each leading index: in the x-z plane
    the axis is a point, and an edge's distance to it is that of its
    projection, a segment, to the point (the fingers reach beyond the
    cloth's sides)."""
    a = [p[..., :, :-1, :], p[..., :-1, :, :], p[..., :-1, :-1, :]]
    b = [p[..., :, 1:, :], p[..., 1:, :, :], p[..., 1:, 1:, :]]
    lead = p.shape[:-3]
    a = np.concatenate([e.reshape(*lead, -1, 3) for e in a], axis=-2)[..., [0, 2]]
    b = np.concatenate([e.reshape(*lead, -1, 3) for e in b], axis=-2)[..., [0, 2]]
    c = np.stack([np.full(lead, x_axis), np.asarray(z_axis)], axis=-1)[..., None, :]
    d = b - a
    s = np.clip(np.sum((c - a) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    return (np.linalg.norm(a + s[..., None] * d - c, axis=-1) - rad).min(axis=-1)


def check_gripper_lift(tmp_path, t_end, faces):
    """gripper_lift (a 0.5 m cloth) to t_end, with the faces or not: no
    step retried, no accepted state at or in an obstacle, and from the
    fingers' closing on the pinched line between the fingers (their poses
    from the keyframes); positions and times of the output and the fingers'
    axes' heights."""
    c, of = contact_keys("gripper_lift")
    L, n = 0.5, 11
    sets = f"nx={n},ny={n},lx={L},ly={L},total_mass=0.025,t_end={t_end}"
    r = run_scene(tmp_path, "gripper_lift", sets + (",contact_faces=.true." if faces else ""))
    with r:
        assert r.run_info["retried_steps"] == 0
        assert np.asarray(r.contact["min_gap_run"])[-1] > 0.0
        t = np.asarray(r.time)
        p = np.asarray(r.position)
    rad = of("obstacle_radius", 2)
    z = []
    for k in (2, 3):
        dz, close = keyframed(c, of, k, t)
        z.append(of("obstacle_point", k)[2] + of("obstacle_close_dir", k)[2] * close + dz)
    upper, lower = z
    x_f = of("obstacle_point", 2)[0]
    i_f = round(x_f / (L / (n - 1)))
    closed = t >= of("obstacle_time", 2)[2] - 1e-9
    line = p[closed][:, :, i_f, 2]
    assert np.all(line > (lower[closed] + rad)[:, None]), (line - (lower[closed] + rad)[:, None]).min()
    assert np.all(line < (upper[closed] - rad)[:, None]), ((upper[closed] - rad)[:, None] - line).min()
    return c, of, t, p, x_f, i_f, upper, lower, rad


def test_gripper_lifts_the_cloth_off_the_table(tmp_path):
    c, of, t, p, x_f, i_f, *_ = check_gripper_lift(tmp_path, 1.5, faces=False)
    assert p[-1, :, i_f, 2].min() > 0.4                                                 # risen with them
    table = of("obstacle_point", 1)[2]
    dhat = c["contact_dhat"]
    assert p[-1, ..., 2].min() > table + dhat, p[-1, ..., 2].min()           # off the table


def test_gripper_lift_with_the_faces(tmp_path):
    """contact_faces = .true. through the fingers' turn from closing to
    rising at t = 0.5 s: the lower finger, rising, carries the pinched quads
    in Newton's start, and the lift of that start (docs/contact.md, "Faces
    and edges") put them inside the upper finger, a tenth of a millimetre
    above them: every start of the step was infeasible and the run failed
    at t = 0.5004 s (9ba3bc6). Now no step is retried, no cloth edge comes
    within the acceptance floor of either finger at an output (distances
    computed here), and the pinched line rises with the fingers."""
    c, of, t, p, x_f, i_f, upper, lower, rad = check_gripper_lift(tmp_path, 0.8, faces=True)
    floor = 1e-6 * c["contact_dhat"]
    assert edge_axis_gap(p, x_f, upper, rad).min() > floor
    assert edge_axis_gap(p, x_f, lower, rad).min() > floor
    assert p[-1, :, i_f, 2].min() > 0.1                                     # risen with them (0.15 m by 0.8 s)
