# SPDX-License-Identifier: BSD-2-Clause
"""The obstacles of a scene with contact are in the output and open in
ParaView and pyvista beside the cloth (issue 47 item 8; postprocess/README.md,
"ParaView"): each obstacle a triangulated surface in /obstacles/obstacle_<k>
(static: vertices once; moving: at every output step, with a view a step in
/xdmf), named by the sidecar RUN-obstacles.xdmf, a temporal collection of
one grid an obstacle (Triangle topology, a cell array `obstacle` with its
number).

The scene: a 7 x 5 sheet at rest (no gravity) above six obstacles that it
never reaches, one of each shape, tilted, moving on keyframes (a capsule
translated, a sphere translated and closed along a direction), and a box
held at the offset of its one keyframe. Checked:
- the file's layout, and its vertices against the shapes and the keyframes
  as postprocess/contact_plot.py evaluates them (an independent reading of
  /config/contact): on the surface at each output time, moved by the
  keyframes' translation, a plane's patch 1.3 times the sheet;
- each of ParaView 5.11's three XDMF readers (tests/python/paraview_dump.py
  under ParaView's Python, as tests/python/test_xdmf.py runs it): the times,
  and at each one every obstacle's points, triangles and `obstacle` cell
  array equal to the file's (h5py) to the last bit; nothing printed;
- ParaView with the cloth and the obstacles opened together (the two
  sidecars, joined by Group Datasets, at the animation's times): the cloth
  and the six obstacles at every output time;
- pyvista (VTK's XDMF reader): pyvista.read of the obstacles' sidecar a
  MultiBlock of the six, every step at reader.time_values; RUN.xdmf still
  one StructuredGrid; postprocess/README.md's obstacles block runs;
- -nuno_restart: from an earlier checkpoint the obstacles are the straight
  run's bit for bit, with the views of the file's steps only; with changed
  obstacles (one moved, a moving one made static, a box made a sphere) they
  are those of the new input at every output time;
- the sidecar is nuno's own: a run without obstacles removes an earlier
  run's at its commit, and a user's file of that name is refused, before
  anything is written.
On e3c7ad0 there is no /obstacles and no sidecar: every test fails.
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec
from test_xdmf import clean_env, paraview_python

from postprocess import contact_plot
from postprocess.reader import read_run

DUMP = Path(__file__).with_name("paraview_dump.py")
READERS = ["XDMFReader", "Xdmf3ReaderS", "Xdmf3ReaderT"]
NX, NY = 7, 5
# (shape, moving) of each obstacle; vertices and triangles of each shape
OBSTACLES = [("plane", False), ("sphere", False), ("box", False), ("capsule", True), ("sphere", True), ("box", False)]
SIZES = {"plane": (4, 2), "sphere": (382, 760), "box": (8, 12), "capsule": (202, 400)}

CONTACT = """&contact
  n_obstacles = 6
  obstacle_shape(1) = 'plane', obstacle_point(:,1) = 0.0, 0.0, -0.9, obstacle_normal(:,1) = 0.0, 0.28, 0.96
  obstacle_shape(2) = 'sphere', obstacle_point(:,2) = {sphere}, obstacle_radius(2) = 0.1
  obstacle_shape(3) = 'box', obstacle_point(:,3) = 0.2, 0.3, -0.6, obstacle_half_size(:,3) = 0.1, 0.05, 0.02
  obstacle_normal(:,3) = 0.0, 0.6, 0.8, obstacle_axis(:,3) = 1.0, 0.0, 0.0
  obstacle_shape(4) = 'capsule', obstacle_point(:,4) = 0.0, 0.0, -0.4, obstacle_end(:,4) = 1.0, 0.0, -0.4
  obstacle_radius(4) = 0.02
  {capsule_keys}
  obstacle_shape(5) = 'sphere', obstacle_point(:,5) = 0.8, 0.2, -0.3, obstacle_radius(5) = 0.05
  obstacle_n_keyframes(5) = 3, obstacle_time(1:3,5) = 0.01, 0.02, 0.05
  obstacle_offset(:,2,5) = 0.1, 0.0, 0.0, obstacle_close(1:3,5) = 0.0, 0.02, 0.05
  obstacle_close_dir(:,5) = 0.0, 0.0, -2.0
  obstacle_shape(6) = '{last}', obstacle_point(:,6) = 0.5, 0.5, -0.8, obstacle_half_size(:,6) = 0.2, 0.2, 0.05
  obstacle_radius(6) = 0.05
  obstacle_n_keyframes(6) = 1, obstacle_time(1,6) = 0.0, obstacle_offset(:,1,6) = 0.05, 0.0, 0.0
/
"""
MOVING_CAPSULE = ("obstacle_n_keyframes(4) = 2, obstacle_time(1:2,4) = 0.0, 0.04, "
                  "obstacle_offset(:,2,4) = 0.0, 0.5, 0.1")
SCENE = (f"&scene scene='flat' units='SI' /\n&lattice nx={NX} ny={NY} lx=1.0 ly=1.0 total_mass=0.1 /\n"
         "&time t_end={t_end} dt=0.01 /\n"
         "&output output_interval=0.01 checkpoint_interval=0.02 output_file='{name}.h5' /\n")


def write_input(work, name, t_end=0.05, sphere="0.5, 0.5, -0.5", capsule_keys=MOVING_CAPSULE, last="box",
                obstacles=True):
    text = SCENE.format(t_end=t_end, name=name)
    if obstacles:
        text += CONTACT.format(sphere=sphere, capsule_keys=capsule_keys, last=last)
    (work / f"{name}.nml").write_text(text)
    return work / f"{name}.nml"


def launch(work, args, nranks=2, check=True):
    env = dict(os.environ, OMPI_MCA_orte_execute_quiet="1")
    proc = subprocess.run([mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), *map(str, args)], cwd=work,
                          capture_output=True, text=True, timeout=300, env=env)
    if check:
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def run(work, name, nranks=2, **kw):
    nml = write_input(work, name, **kw)
    launch(work, [nml], nranks)
    return work / f"{name}.h5"


def restart(work, name, from_time, **kw):
    """name.h5 continued by -nuno_restart from its checkpoint at from_time
    (the later ones made invalid), with the input of kw."""
    h5 = work / f"{name}.h5"
    with h5py.File(h5, "r+") as f:
        for g in f["checkpoint"].values():
            if float(g.attrs["time"]) > from_time + 1e-12:
                g.attrs["sequence"] = np.int32(0)
    nml = write_input(work, name, **kw)
    proc = launch(work, [nml, "-nuno_restart", h5])
    assert f"at t = {from_time:.5E}" in proc.stdout, proc.stdout[-2000:]
    return h5


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("obstacles")


@pytest.fixture(scope="module")
def obs(work):
    return run(work, "obs")


def content(h5):
    """{nt, time, position, obstacles: [{shape, moving, number, triangles, numbers, vertices}]} by h5py."""
    with h5py.File(h5, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        c = {"nt": nt, "time": f["time"][:nt], "position": f["position"][:nt], "obstacles": []}
        if "obstacles" in f:
            for k in range(1, int(f["obstacles"].attrs["n_obstacles"]) + 1):
                g = f[f"obstacles/obstacle_{k}"]
                v = g["vertices"]
                c["obstacles"].append({
                    "shape": g.attrs["shape"].decode(), "moving": bool(g.attrs["moving"]), "number": int(g.attrs["number"]),
                    "triangles": g["triangles"][()], "numbers": g["number"][()], "dtype": g["triangles"].dtype,
                    "units": v.attrs["units"].decode(),
                    "vertices": v[:nt] if v.ndim == 3 else v[()], "extent": v.shape[0] if v.ndim == 3 else None})
    return c


def vertices_at(ob, k):
    """Obstacle ob's vertices at output step k."""
    return ob["vertices"][k] if ob["moving"] else ob["vertices"]


# ------------------------------------------------------------------ the file

def test_the_file_has_each_obstacle_as_triangles(obs):
    c = content(obs)
    assert c["nt"] == 6
    assert [(o["shape"], o["moving"]) for o in c["obstacles"]] == OBSTACLES
    for k, o in enumerate(c["obstacles"], start=1):
        nv, nf = SIZES[o["shape"]]
        assert o["number"] == k and o["units"] == "m"
        assert o["triangles"].shape == (nf, 3) and o["dtype"] == np.int32
        assert o["triangles"].min() == 0 and o["triangles"].max() == nv - 1
        np.testing.assert_array_equal(o["numbers"], np.full(nf, k))
        assert o["vertices"].shape == ((c["nt"], nv, 3) if o["moving"] else (nv, 3))
    with h5py.File(obs, "r") as f:
        views = sorted(n for n in f["xdmf"] if n.startswith("obstacle_"))
    assert views == sorted(f"obstacle_{k}_vertices_{t}" for k in (4, 5) for t in range(6))


def test_the_vertices_are_the_shapes_at_each_output_time(obs):
    """Against postprocess/contact_plot.py's reading of /config/contact and
    its keyframes (np.interp): each vertex on its obstacle's surface at that
    time; the triangles' normals outward; a plane's patch square, 1.3 times
    the sheet, centred at the projection of its centre."""
    c = content(obs)
    with read_run(str(obs)) as r:
        shapes = contact_plot.obstacles(r)
    assert [o.shape for o in shapes] == [s for s, _ in OBSTACLES]
    for k, time in enumerate(c["time"]):
        for ob, o in zip(shapes, c["obstacles"]):
            at = ob.at(time)
            v = vertices_at(o, k)
            tri = v[o["triangles"]]
            normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            centroid = tri.mean(axis=1)
            if ob.shape == "sphere":
                np.testing.assert_allclose(np.linalg.norm(v - at.point, axis=1), at.radius, rtol=1e-14)
                out = centroid - at.point
            elif ob.shape == "capsule":
                axis = at.end - at.point
                s = np.clip((v - at.point) @ axis / (axis @ axis), 0.0, 1.0)
                np.testing.assert_allclose(np.linalg.norm(v - at.point - s[:, None] * axis, axis=1), at.radius,
                                           rtol=1e-13)
                s = np.clip((centroid - at.point) @ axis / (axis @ axis), 0.0, 1.0)
                out = centroid - at.point - s[:, None] * axis
            elif ob.shape == "box":
                local = (v - at.point) @ at.axes
                np.testing.assert_allclose(np.abs(local), np.broadcast_to(at.half, local.shape), rtol=1e-13)
                assert len({tuple(np.sign(p)) for p in local}) == 8
                out = centroid - at.point
            else:
                np.testing.assert_allclose((v - at.point) @ at.normal, 0.0, atol=1e-15)
                centre = np.array([0.5, 0.5, 0.0])
                np.testing.assert_allclose(v.mean(axis=0), centre - ((centre - at.point) @ at.normal) * at.normal,
                                           atol=1e-15)
                np.testing.assert_allclose(np.linalg.norm(np.roll(v, -1, axis=0) - v, axis=1), 1.3, rtol=1e-14)
                out = np.broadcast_to(at.normal, normal.shape)
            assert (np.einsum("ij,ij->i", normal, out) > 0).all(), (k, ob.shape)
    # the moving ones did move; the one-keyframe box is held at its offset
    assert np.abs(c["obstacles"][3]["vertices"][-1] - c["obstacles"][3]["vertices"][0]).max() > 0.1
    np.testing.assert_allclose(c["obstacles"][5]["vertices"].mean(axis=0), [0.55, 0.5, -0.8], atol=1e-15)


# ----------------------------------------------------------------- ParaView

def dump(args, out):
    """paraview_dump.py under ParaView's Python: (its JSON, its output text)."""
    proc = subprocess.run([paraview_python(), str(DUMP), *map(str, args)], capture_output=True, text=True,
                          timeout=300, env=clean_env())
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0 and Path(out).is_file(), text[-4000:]
    return json.loads(Path(out).read_text()), text


@pytest.fixture(scope="module", params=READERS)
def paraview(obs, tmp_path_factory, request):
    out = tmp_path_factory.mktemp("pv") / f"{request.param}.json"
    sidecar = obs.with_name("obs-obstacles.xdmf").resolve()
    loaded, text = dump([request.param, out, sidecar], out)
    return request.param, loaded[str(sidecar)], text


def test_paraview_reads_every_obstacle_at_every_output_time(paraview, obs):
    reader, loaded, text = paraview
    c = content(obs)
    assert np.array_equal(np.array(loaded["times"]), c["time"])
    assert len(loaded["steps"]) == c["nt"]
    for k, step in enumerate(loaded["steps"]):
        blocks = step["blocks"]
        assert len(blocks) == len(OBSTACLES), (reader, k)
        for m, (b, o) in enumerate(zip(blocks, c["obstacles"]), start=1):
            assert b["class"] == "vtkUnstructuredGrid"
            if b["name"] is not None:     # the Xdmf3ReaderS names none; the others the grid (with [k] after step 0)
                assert b["name"].split("[")[0] == f"obstacle_{m}_{o['shape']}", b["name"]
            assert np.array_equal(np.array(b["points"]), vertices_at(o, k)), (reader, k, m)
            assert np.array_equal(np.array(b["cells"]), o["triangles"]), (reader, k, m)
            assert np.array_equal(np.array(b["cell_arrays"]["obstacle"]), o["numbers"]), (reader, k, m)
    # no HDF5 error stack, XDMF error or VTK warning: no line at all
    assert text.strip() == "", text[-3000:]


@pytest.mark.parametrize("reader", READERS)
def test_paraview_opens_the_cloth_and_its_obstacles_together(reader, obs, tmp_path):
    """Both sidecars opened in one session, as File > Open of the two does,
    and grouped: at each output time the cloth (a structured grid at
    /position) and the six obstacles."""
    out = tmp_path / "together.json"
    cloth, sidecar = obs.with_suffix(".xdmf").resolve(), obs.with_name("obs-obstacles.xdmf").resolve()
    loaded, _ = dump([reader, out, "--together", cloth, sidecar], out)
    c = content(obs)
    together = loaded["together"]
    assert np.array_equal(np.array(together["times"]), c["time"])
    for k, step in enumerate(together["steps"]):
        blocks = step["blocks"]
        assert [b["class"] for b in blocks] == ["vtkStructuredGrid"] + ["vtkUnstructuredGrid"] * len(OBSTACLES)
        assert np.array_equal(np.array(blocks[0]["points"]), c["position"][k].reshape(-1, 3))
        for b, o in zip(blocks[1:], c["obstacles"]):
            assert np.array_equal(np.array(b["points"]), vertices_at(o, k))


# ------------------------------------------------------------------- pyvista

def test_pyvista_reads_the_obstacles_beside_the_cloth(obs):
    pv = pytest.importorskip("pyvista", reason="pyvista is not installed (tools/install.sh)")
    c = content(obs)
    cloth = pv.read(obs.with_suffix(".xdmf"))
    assert isinstance(cloth, pv.StructuredGrid)          # the documented example holds with obstacles
    sidecar = obs.with_name("obs-obstacles.xdmf")
    first = pv.read(sidecar)
    assert isinstance(first, pv.MultiBlock) and len(first) == len(OBSTACLES)
    assert list(first.keys()) == [f"obstacle_{k}_{s}" for k, (s, _) in enumerate(OBSTACLES, start=1)]
    reader = pv.get_reader(str(sidecar))
    np.testing.assert_array_equal(np.array(reader.time_values), c["time"])
    for k, t in enumerate(reader.time_values):
        reader.set_active_time_value(t)
        blocks = reader.read()
        for b, o in zip(blocks, c["obstacles"]):
            np.testing.assert_array_equal(b.points, vertices_at(o, k))
            np.testing.assert_array_equal(b.cell_data["obstacle"], o["numbers"])
            np.testing.assert_array_equal(b.cells_dict[pv.CellType.TRIANGLE], o["triangles"])


def test_the_docs_obstacles_block_runs(obs, tmp_path):
    """postprocess/README.md's obstacles block (the second python block of
    "pyvista and xarray"), as written, on a run named drop_table.h5 with
    these obstacles: it prints each obstacle's name and triangles, and
    each one's lowest point at the last output time."""
    pytest.importorskip("pyvista", reason="pyvista is not installed (tools/install.sh)")
    text = (ROOT / "postprocess" / "README.md").read_text()
    section = text.split("\n## pyvista and xarray\n", 1)[1].split("\n## ", 1)[0]
    block = section.split("```python\n")[2].split("```", 1)[0]
    assert "drop_table-obstacles.xdmf" in block
    for suffix in (".h5", ".xdmf"):
        shutil.copy(obs.with_suffix(suffix), tmp_path / f"drop_table{suffix}")
    xdmf = obs.with_name("obs-obstacles.xdmf").read_text().replace("obs.h5:", "drop_table.h5:")
    (tmp_path / "drop_table-obstacles.xdmf").write_text(xdmf)
    proc = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    c = content(obs)
    lines = proc.stdout.splitlines()
    assert lines[:len(OBSTACLES)] == [f"obstacle_{k}_{s} {SIZES[s][1]}" for k, (s, _) in enumerate(OBSTACLES, start=1)]
    assert lines[len(OBSTACLES)] == " ".join(str(vertices_at(o, c["nt"] - 1)[:, 2].min()) for o in c["obstacles"])


# ------------------------------------------------------------------ restarts

def obstacle_data(h5):
    """Every dataset of /obstacles and the obstacles' views in /xdmf, by name."""
    data = {}
    with h5py.File(h5, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        f["obstacles"].visititems(lambda n, o: data.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
        for n in f["xdmf"]:
            if n.startswith("obstacle_"):
                data["xdmf/" + n] = f["xdmf"][n][()]
    return nt, data


def test_a_restart_keeps_the_obstacles_of_the_straight_run(work, obs):
    """From the checkpoint at t = 0.04: the output step after it is cut
    and written again; the obstacles (and their views, those of the cut
    steps deleted and made again) are the straight run's, bit for bit."""
    run(work, "again")
    with h5py.File(work / "again.h5", "r") as f:
        assert sorted(n for n in f["xdmf"] if n.startswith("obstacle_4")) == [f"obstacle_4_vertices_{t}" for t in range(6)]
    h5 = restart(work, "again", 0.04)
    nt, data = obstacle_data(h5)
    nt0, data0 = obstacle_data(obs)
    assert nt == nt0 == 6 and sorted(data) == sorted(data0)
    for name in data0:
        assert np.array_equal(data[name], data0[name]), name
    assert h5py.File(h5, "r")["obstacles/obstacle_4/vertices"].shape[0] == 6


def test_a_restart_with_changed_obstacles_writes_those_of_its_input(work):
    """Restarted from t = 0.04 with the sphere moved, the capsule made
    static and the last box made a sphere: the file's obstacles are those
    of a straight run of the new input, at every output time; the capsule
    has no views left."""
    changed = dict(sphere="0.4, 0.6, -0.5", capsule_keys="", last="sphere")
    run(work, "changed")
    h5 = restart(work, "changed", 0.04, **changed)
    straight = run(work, "straight", **changed)
    nt, data = obstacle_data(h5)
    nt0, data0 = obstacle_data(straight)
    assert nt == nt0 == 6 and sorted(data) == sorted(data0)
    assert not any(n.startswith("xdmf/obstacle_4") for n in data)
    for name in data0:
        assert np.array_equal(data[name], data0[name]), name
    c = content(h5)
    assert [(o["shape"], o["moving"]) for o in c["obstacles"]][3:] == [("capsule", False), ("sphere", True),
                                                                       ("sphere", False)]
    # the sidecar names them so
    text = h5.with_name("changed-obstacles.xdmf").read_text()
    assert "changed.h5:/obstacles/obstacle_4/vertices<" in text and "obstacle_6_sphere" in text


# ---------------------------------------------------------------- own files

def test_a_run_without_obstacles_removes_an_earlier_runs_sidecar(tmp_path):
    h5 = run(tmp_path, "out")
    assert (tmp_path / "out-obstacles.xdmf").is_file()
    launch(tmp_path, [write_input(tmp_path, "out", obstacles=False)])
    assert not (tmp_path / "out-obstacles.xdmf").exists()
    with h5py.File(h5, "r") as f:
        assert "obstacles" not in f and not any(n.startswith("obstacle_") for n in f["xdmf"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5", "out.nml", "out.xdmf"]


@pytest.mark.parametrize("obstacles", [True, False], ids=["with", "without"])
def test_a_user_file_named_like_the_obstacles_sidecar_is_refused(tmp_path, obstacles):
    """nuno writes (with obstacles) or removes (without) only its own
    sidecar: a user's file of its name stops the run before anything is
    written, with one line naming it."""
    user = tmp_path / "out-obstacles.xdmf"
    user.write_text("<notes>a user's file</notes>\n")
    nml = write_input(tmp_path, "out", obstacles=obstacles)
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = launch(tmp_path, [nml], check=False)
    assert proc.returncode != 0
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "out-obstacles.xdmf" in lines[0], proc.stderr[-2000:]
    assert "not an XDMF sidecar written by nuno" in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert user.read_text() == "<notes>a user's file</notes>\n"
