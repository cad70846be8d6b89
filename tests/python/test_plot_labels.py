# SPDX-License-Identifier: BSD-2-Clause
"""Figures whose labels can be read (issue 48 item 7), measured on the
figure as written: each test builds a script's figure from synthetic runs
(conftest.make_run, with the shapes that showed each defect), writes it
through plotting.save or the animation writer, and measures the drawn
boxes of the labels (matplotlib's window extents), or reads the plotted
data, against what is computed here:

- 3-D panels: the z label sits beside its own box's tick labels, not in
  the gap towards the next panel;
- GIF frames (nuno-contact-plot --gif): every axis and tick label inside
  the frame;
- no two tick labels of an axis overlap (nuno-workprecision over less than
  a decade, nuno-compare's 3-D box of a hanging sheet, thin in y);
- the y labels of the sweep time series stay inside their panel's height,
  clear of the suptitle;
- a swept key's label has its unit (e_s = 50 N/m in SI, g/s^2 in mm g s);
  the table of units is the program's own (`nuno --list-keys`);
- the centre-line panel plots the length minus the rest length, stated on
  the axis, with no offset (it drew '1e-9+9.9999999e-1').
"""
from __future__ import annotations

import subprocess

import h5py
import numpy as np
import pytest

from postprocess import cli, compare, contact_plot, plotting, snapshots, timeseries, workprecision
from postprocess.reader import read_run
from test_postprocess import write_study_run


def drawn(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def tick_boxes(axis, r):
    """Window boxes of the tick labels drawn (ticks inside the axis' limits)."""
    lo, hi = sorted(axis.get_view_interval())
    out = []
    for t in axis.get_major_ticks() + axis.get_minor_ticks():
        loc = t.get_loc()
        if loc is not None and lo - 1e-9 * (hi - lo) <= loc <= hi + 1e-9 * (hi - lo) \
                and t.label1.get_visible() and t.label1.get_text():
            out.append(t.label1.get_window_extent(r))
    return out


def piled(boxes):
    return any(a.overlaps(b) for k, a in enumerate(boxes) for b in boxes[k + 1:])


def axes_of(ax):
    return [ax.xaxis, ax.yaxis] + ([ax.zaxis] if ax.name == "3d" else [])


def write_folded(path, make_run, units_mm=True):
    """A lift_release-like sheet (100 x 100 mm, nothing moving but its last
    30 mm folded up 15 mm): a flat 3-D box, z a sixth of x."""
    make_run(path, nx=11, ny=11, nt=4, omega=0.0, velocity=(0.0, 0.0, 0.0), lx=100.0, ly=100.0,
             scene="lift_release" if units_mm else "hang")
    with h5py.File(path, "r+") as f:
        pos = f["position"][...]
        x = pos[..., 0]
        pos[..., 2] = 15.0 * np.clip((x - 70.0) / 30.0, 0.0, None)
        f["position"][...] = pos
    return path


def write_hanging(path, make_run, k=0):
    """A sheet hanging in the x-z plane (1 m, SI), y within 2 cm: a 3-D box
    thin in y."""
    make_run(path, nx=11, ny=11, nt=3, omega=0.0, velocity=(0.0, 0.0, 0.0), lx=1.0, ly=1.0,
             scene="hang", namelist_extra=f"&material e_s = {50.0 * 2 ** k} /\n")
    with h5py.File(path, "r+") as f:
        pos = f["position"][...]
        rest = f["lattice/rest_position"][...]
        pos[..., 2] = rest[None, ..., 1] - 1.0                    # rows hang down
        pos[..., 1] = 0.02 * np.sin(3.0 * rest[None, ..., 0]) * (1 + k)
        f["position"][...] = pos
    return path


# ---------------------------------------------------------------- 3-D z labels


def z_label_gaps(fig, r):
    """(gap to its own z tick labels, overlaps the next panel) of each 3-D panel's z label."""
    tops = [ax for ax in plotting.panels(fig) if ax.name == "3d"]
    out = []
    for k, ax in enumerate(tops):
        lab = ax.zaxis.label.get_window_extent(r)
        ticks = tick_boxes(ax.zaxis, r)
        right = max(b.x1 for b in ticks)
        nxt = False
        if k + 1 < len(tops):
            other = tops[k + 1]
            other.zaxis.label.set_visible(False)
            nxt = lab.overlaps(other.get_tightbbox(r))
            other.zaxis.label.set_visible(True)
        out.append((lab.x0 - right, nxt))
    return out


@pytest.mark.parametrize("script", ["snapshots", "compare"])
def test_z_label_sits_beside_its_own_box(tmp_path, make_run, script):
    """A flat box (z a sixth of x): matplotlib put the z label some 23 pt
    right of the z tick labels, half way to the next panel; now within 8 pt."""
    paths = [write_folded(tmp_path / f"f{k}.h5", make_run) for k in range(3)]
    runs = [read_run(p) for p in paths]
    if script == "snapshots":
        fig = snapshots.build_figure(runs[0], [0, 1, 2, 3], "panels", "iso")
    else:
        series = [compare.difference(runs[0], r, compare.common_interval(runs)) for r in runs[1:]]
        fig = compare.build_figure(runs, 0.3, series, "iso")
    plotting.save(fig, tmp_path / "z.png", 120)
    r = drawn(fig)
    limit = 8.0 * fig.dpi / 72.0
    for gap, into_next in z_label_gaps(fig, r):
        assert 0.0 <= gap <= limit, (gap, limit)
        assert not into_next


# ---------------------------------------------------------------- GIF frames


def capture_figures(monkeypatch):
    """The figures the scripts make through plotting.new_figure."""
    made = []
    original = plotting.new_figure

    def recording(*args, **kwargs):
        fig, axes = original(*args, **kwargs)
        made.append(fig)
        return fig, axes

    monkeypatch.setattr(plotting, "new_figure", recording)
    return made


def assert_labels_inside(fig):
    r = drawn(fig)
    w, h = fig.canvas.get_width_height()
    for ax in plotting.panels(fig):
        boxes = [lab.get_window_extent(r) for lab in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label)
                 if lab.get_text()]
        assert len(boxes) == 3
        boxes += [b for axis in axes_of(ax) for b in tick_boxes(axis, r)]
        for b in boxes:
            assert b.x0 >= -1 and b.y0 >= -1 and b.x1 <= w + 1 and b.y1 <= h + 1, (b, w, h)


def test_contact_gif_frames_keep_their_labels(tmp_path, make_run, monkeypatch):
    """drop_table's shape (a 1 m sheet over a plane, flat box) in the GIF's
    400 px square: the z label was cut off at the right edge."""
    path = tmp_path / "drop.h5"
    make_run(path, nx=11, ny=11, nt=4, omega=0.0, velocity=(0.0, 0.0, -0.01), lx=1.0, ly=1.0,
             scene="hang")
    with h5py.File(path, "a") as f:
        g = f.require_group("config").require_group("contact")
        g.attrs["n_obstacles"] = np.int32(1)
        g.attrs["obstacle_shape"] = "plane"
        g.attrs["obstacle_point"] = np.array([0.0, 0.0, -0.05])
        g.attrs["obstacle_normal"] = np.array([0.0, 0.0, 1.0])
        g.attrs["contact_dhat"] = 1e-3
    made = capture_figures(monkeypatch)
    with read_run(path) as run:
        contact_plot.write_animation(run, str(tmp_path / "d.gif"), "m", frames=4)
    (fig,) = made
    assert fig.canvas.get_width_height() == (400, 400)
    assert_labels_inside(fig)


# ---------------------------------------------------------------- tick labels


@pytest.mark.parametrize("errors, walls", [
    ([1.2e-4, 1.5e-4, 1.9e-4], [0.31, 0.35, 0.42]),     # less than a decade of error
    ([1e-3, 2e-3, 4e-3], [0.5, 2.0, 11.0]),             # wall times over 22x: minor labels
])
def test_workprecision_tick_labels_do_not_pile(tmp_path, errors, walls):
    paths = [write_study_run(tmp_path / f"r{k}.h5", 11, dt=0.01 * (k + 1), err=e, run_attrs={
        "dt": 0.01 * (k + 1), "ts_type": "cn", "ts_adapt_type": "none", "wall_time": w})
        for k, (e, w) in enumerate(zip(errors, walls))]
    ref = write_study_run(tmp_path / "ref.h5", 11, dt=1e-4, err=0.0)
    res = workprecision.from_runs([read_run(p) for p in paths], read_run(ref))
    fig, _ = workprecision.build_figure(res)
    plotting.save(fig, tmp_path / "wp.png", 120)
    r = drawn(fig)
    ax = plotting.panels(fig)[0]
    for axis in (ax.xaxis, ax.yaxis):
        boxes = tick_boxes(axis, r)
        assert len(boxes) >= 2, axis.axis_name          # still labelled
        assert not piled(boxes), (axis.axis_name, [t.get_text() for t in axis.get_ticklabels()])


def test_compare_tick_labels_do_not_pile_on_a_thin_box(tmp_path, make_run):
    """Three hanging sheets, y within 2-6 cm of 1 m: the y tick labels of
    the thin 3-D axis lay on each other; and nothing of a 3-D panel reaches
    into the difference panel below it."""
    paths = [write_hanging(tmp_path / f"h{k}.h5", make_run, k) for k in range(3)]
    runs = [read_run(p) for p in paths]
    series = [compare.difference(runs[0], r, compare.common_interval(runs)) for r in runs[1:]]
    fig = compare.build_figure(runs, 0.2, series, "iso")
    plotting.save(fig, tmp_path / "c.png", 120)
    r = drawn(fig)
    *tops, bottom = plotting.panels(fig)
    floor = bottom.get_window_extent(r)
    for ax in tops + [bottom]:
        for axis in axes_of(ax):
            assert not piled(tick_boxes(axis, r)), axis.axis_name
    for ax in tops:
        for lab in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label):
            assert not lab.get_window_extent(r).overlaps(floor), lab.get_text()


# ---------------------------------------------------------------- time series labels


def test_sweep_time_series_labels_clear_the_suptitle(tmp_path, make_run):
    """mm g s runs overlaid: 'elastic energy (stretch + bend) [g mm^2/s^2]'
    was taller than its panel and ran into the suptitle."""
    paths = []
    for k, v in enumerate((1.0, 2.0, 4.0)):
        p = tmp_path / f"m{k}.h5"
        make_run(p, nx=6, ny=5, nt=6, velocity=(0.0, 1.0 + 0.1 * k, -2.0), omega=0.0,
                 scene="lift_release", namelist_extra=f"&material e_s = {v} /\n")
        paths.append(p)
    runs = [read_run(p) for p in paths]
    fig = timeseries.build_overlay(runs, cli.run_labels(runs, "e_s"))
    plotting.save(fig, tmp_path / "ts.png", 120)
    r = drawn(fig)
    title = fig._suptitle.get_window_extent(r)
    for ax in plotting.panels(fig):
        label = ax.yaxis.label.get_window_extent(r)
        panel = ax.get_window_extent(r)
        assert not label.overlaps(title), ax.get_ylabel()
        assert label.y0 >= panel.y0 - 2 and label.y1 <= panel.y1 + 2, ax.get_ylabel()
    assert "[g mm$^2$/s$^2$]" in plotting.panels(fig)[1].get_ylabel()   # the unit kept


# ---------------------------------------------------------------- units of swept keys


def test_swept_keys_are_labelled_with_their_units(tmp_path, make_run):
    si = tmp_path / "si.h5"
    mm = tmp_path / "mm.h5"
    make_run(si, scene="hang", namelist_extra="&material e_s = 50.0, k_b = 0.1, "
             "bending_model = 'energy' /\n&time dt = 0.002 /\n")
    make_run(mm, scene="lift_release", namelist_extra="&material e_s = 2.0 /\n&scene bend_angle = 30.0 /\n")
    run_si, run_mm = read_run(si), read_run(mm)
    assert cli.run_labels([run_si], "e_s") == ["e_s = 50 N/m"]
    assert cli.run_labels([run_si], "k_b") == ["k_b = 0.1 J"]                # energy bending: an energy
    assert cli.run_labels([run_mm], "e_s") == ["e_s = 2 g/s$^2$"]
    assert cli.run_labels([run_mm], "bend_angle") == ["bend_angle = 30°"]
    assert cli.run_labels([run_si], "nx") == ["nx = 5"]                      # a count: no unit
    assert cli.run_labels([run_mm], "nx") == ["nx = 5"]
    run_si.close()
    run_mm.close()


def test_unit_table_is_the_programs(tmp_path):
    """cli.KEY_DIMENSIONS holds exactly the keys `nuno --list-keys` gives a
    unit, with that unit, and every such unit has a label in both systems."""
    import nunorun
    out = subprocess.run([nunorun.exe(), "--list-keys"], capture_output=True, text=True,
                         timeout=60, check=True).stdout
    rows = [line.split("\t") for line in out.splitlines() if line and not line.startswith("#")]
    program = {row[0]: row[3] for row in rows if len(row) > 3 and row[3]}
    assert len(program) > 20
    assert cli.KEY_DIMENSIONS == program
    for dim in set(program.values()):
        parts = [p.split(":", 1)[1].strip() for p in dim.split(";")] if ":" in dim else [dim]
        for part in parts:
            assert part in cli.DIMENSION_UNITS, part


# ---------------------------------------------------------------- centre line


@pytest.mark.parametrize("n_runs", [1, 3])
def test_centre_line_length_has_no_offset(tmp_path, make_run, n_runs):
    """A length within 1e-9 of its rest length (1 m): the panel plots the
    length minus the rest length (from the rest lattice's middle row,
    computed here), says so, and its tick labels need no offset."""
    paths = []
    for k in range(n_runs):
        p = tmp_path / f"l{k}.h5"
        make_run(p, nx=5, ny=5, nt=6, lx=1.0, ly=1.0, omega=0.0, scene="hang")
        with h5py.File(p, "r+") as f:
            t = f["time"][...]
            f["diagnostics/length"][...] = 1.0 + 1e-9 * (k + 1) * np.sin(7.0 * t)
        paths.append(p)
    runs = [read_run(p) for p in paths]
    if n_runs == 1:
        fig = timeseries.build_figure(runs[0])
        ax = plotting.panels(fig)[4]
    else:
        fig = timeseries.build_overlay(runs, cli.run_labels(runs))
        ax = plotting.panels(fig)[5]
    plotting.save(fig, tmp_path / "t.png", 120)
    drawn(fig)
    assert ax.get_ylabel() == "centre-line length \u2212 1 m [m]"
    assert "+" not in ax.yaxis.get_offset_text().get_text()
    for k, line in enumerate(ax.get_lines()):
        t = np.asarray(runs[k].time)
        np.testing.assert_allclose(line.get_ydata(), 1e-9 * (k + 1) * np.sin(7.0 * t), rtol=0, atol=1e-15)
