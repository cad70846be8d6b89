# SPDX-License-Identifier: BSD-2-Clause
"""The XDMF sidecar opens in every one of ParaView's XDMF readers: loaded with
each, every output step has the lattice's points and the point arrays
velocity (when written), rest_position and mass, equal to the HDF5 file's
values (read with h5py) to the last bit, at the file's times; the legacy
reader also gives displacement (position - rest), the Xdmf3 readers give it
through the Calculator "coords - rest_position" (postprocess/README.md,
"ParaView").

Reader: ParaView 5.11 from Debian (python3-paraview, installed by
tools/install.sh; run as pvpython, or Debian's python3, by paraview_dump.py
in a subprocess since it is not the tests' Python): its legacy "XDMF
Reader" (paraview.simple.XDMFReader, VTK's vtkXdmfReader on Xdmf2) and its
two Xdmf3 readers (Xdmf3ReaderS/T; OpenDataFile picks S). Every array is a
plain HDF DataItem of a virtual dataset in /xdmf (a view of step k of
/position, /velocity, or of /lattice: no data copied); displacement is an
XDMF Function, which the Xdmf3 readers skip with one line per step and
nothing else.

The lattice is not square (nx = 7, ny = 5) so that a transposed layout or
topology fails; the runs use 2 ranks, with and without /velocity. Also: a
copy of the first run with /position and /velocity one step longer than
n_output_steps and that step's views (a run killed while writing a step),
which must read the same; a run continued by -nuno_restart from an earlier
checkpoint to an earlier t_end, whose views of the steps it no longer has
must be gone; and the same restart of a file without /xdmf (as an earlier
version wrote it), whose views must be made.
"""
import json
import os
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from nunorun import run

NX, NY = 7, 5
SCENE = dict(scene="scene='lift_release'", lattice=f"nx={NX} ny={NY}", time="t_end=0.03 dt=0.01")
DUMP = Path(__file__).with_name("paraview_dump.py")
# The one line an Xdmf3 reader prints per step: it skips the Function item (displacement).
XDMF3_SKIP = "Skipping unrecognized array type [None]"
CALCULATOR = "displacement=coords - rest_position"
XDMF3 = ["Xdmf3ReaderS", "Xdmf3ReaderT"]
FILES = ("vel", "novel", "killed", "restarted", "restarted_old")


def paraview_python():
    """ParaView's Python: $NUNO_PVPYTHON, else pvpython, else a python3 with paraview."""
    given = os.environ.get("NUNO_PVPYTHON")
    if given:
        return given
    if shutil.which("pvpython"):
        return shutil.which("pvpython")
    for py in ("/usr/bin/python3", shutil.which("python3")):
        if py and subprocess.run([py, "-c", "import paraview"], capture_output=True,
                                 env=clean_env()).returncode == 0:
            return py
    pytest.fail("ParaView's Python not found: install python3-paraview (bash tools/install.sh) "
                "or set NUNO_PVPYTHON")


def clean_env():
    # The tests' own Python must not leak into ParaView's (another version).
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def dump(reader, paths, out, calculator=None):
    """What reader loads from each path: {path: {times, steps}}, and its output."""
    extra = ["--calculator", calculator] if calculator else []
    # Absolute paths: the Xdmf3 readers resolve the HDF5 file name wrongly
    # for a bare file name without a directory ("RUN.xdmfRUN.h5").
    proc = subprocess.run([paraview_python(), str(DUMP), reader, str(out), *extra,
                           *(str(Path(p).resolve()) for p in paths)],
                          capture_output=True, text=True, timeout=300, env=clean_env())
    text = proc.stdout + proc.stderr
    if proc.returncode != 0 or not Path(out).is_file():
        return None, text
    loaded = json.loads(Path(out).read_text())
    return {Path(p): loaded[str(Path(p).resolve())] for p in paths}, text


def h5_content(h5):
    with h5py.File(h5, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        return {"nt": nt, "time": f["time"][:nt], "position": f["position"][:nt],
                "velocity": f["velocity"][:nt] if "velocity" in f else None,
                "rest": f["lattice/rest_position"][:], "mass": f["lattice/mass"][:]}


def restart_run(work, name, drop_xdmf):
    """7 x 5 on 2 ranks to t_end = 0.06, checkpoints at t = 0.02, 0.04 and
    the end; the end one made invalid (and /xdmf deleted, as in a file of an
    earlier version, when drop_xdmf); continued from t = 0.04 to t_end = 0.05:
    6 of the 7 output steps remain. Returns the file and the names in /xdmf
    before the restart."""
    groups = dict(SCENE, time="t_end=0.06 dt=0.01",
                  output="output_interval=0.01 write_velocity=.true. checkpoint_interval=0.02")
    _, h5 = run(work, name, nranks=2, **groups)
    with h5py.File(h5, "r+") as f:
        assert int(f.attrs["n_output_steps"]) == 7
        before = set(f["xdmf"]) if "xdmf" in f else set()
        for g in f["checkpoint"].values():
            if g.attrs["reason"] == b"end":
                g.attrs["sequence"] = np.int32(0)
        if drop_xdmf and "xdmf" in f:
            del f["xdmf"]
    proc, _ = run(work, name, nranks=2, options=["-nuno_restart", str(h5)], **dict(groups, time="t_end=0.05 dt=0.01"))
    assert "restart from checkpoint 2 at t = 4.00000E-02" in proc.stdout, proc.stdout
    return h5, before


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    work = tmp_path_factory.mktemp("xdmf")
    _, vel = run(work, "vel", nranks=2, output="output_interval=0.01 write_velocity=.true.", **SCENE)
    _, novel = run(work, "novel", nranks=2, output="output_interval=0.01 write_velocity=.false.", **SCENE)
    # A killed run: the time series and the views one step longer than n_output_steps says.
    killed_dir = work / "killed"
    killed_dir.mkdir()
    killed = killed_dir / "vel.h5"
    shutil.copy(vel, killed)
    shutil.copy(vel.with_suffix(".xdmf"), killed.with_suffix(".xdmf"))
    with h5py.File(killed, "r+") as f:
        nt = int(f.attrs["n_output_steps"])
        for name in ("position", "velocity"):
            f[name].resize(nt + 1, axis=0)
            f[name][-1] = np.nan
            if "xdmf" in f:
                layout = h5py.VirtualLayout(shape=(1, NY, NX, 3), dtype="f8")
                layout[0] = h5py.VirtualSource(".", f"/{name}", shape=(nt + 1, NY, NX, 3))[nt]
                f["xdmf"].create_virtual_dataset(f"{name}_{nt}", layout)
    restarted, before = restart_run(work, "restarted", drop_xdmf=False)
    restarted_old, before_old = restart_run(work, "restarted_old", drop_xdmf=True)
    return {"vel": vel, "novel": novel, "killed": killed, "restarted": restarted, "restarted_old": restarted_old,
            "views_before": {"restarted": before, "restarted_old": before_old}}


def load_all(runs, reader, tmp_path_factory, calculator=None):
    out = tmp_path_factory.mktemp("dump") / f"{reader}.json"
    paths = [runs[k].with_suffix(".xdmf") for k in FILES]
    loaded, text = dump(reader, paths, out, calculator)
    assert loaded is not None, f"ParaView's {reader} failed:\n{text[-4000:]}"
    return {k: loaded[p] for k, p in zip(FILES, paths)}, text


@pytest.fixture(scope="module")
def legacy(runs, tmp_path_factory):
    return load_all(runs, "XDMFReader", tmp_path_factory)


@pytest.fixture(scope="module", params=XDMF3)
def xdmf3(runs, tmp_path_factory, request):
    return load_all(runs, request.param, tmp_path_factory)


@pytest.fixture(scope="module", params=XDMF3)
def xdmf3_calculator(runs, tmp_path_factory, request):
    return load_all(runs, request.param, tmp_path_factory, CALCULATOR)


def arrays_of(name, displacement):
    names = {"rest_position", "mass"} | ({"displacement"} if displacement else set())
    return names if name == "novel" else names | {"velocity"}


def check_against_h5(loaded, h5, arrays):
    c = h5_content(h5)
    assert c["nt"] >= 3
    assert len(loaded["times"]) == c["nt"]
    assert np.array_equal(np.array(loaded["times"]), c["time"])
    assert len(loaded["steps"]) == c["nt"]
    for k, step in enumerate(loaded["steps"]):
        assert step["n_points"] == NX * NY, k
        assert step["dims"] == [NX, NY, 1], k          # point j*nx + i, i fastest
        assert np.array_equal(np.array(step["points"]), c["position"][k].reshape(-1, 3)), k
        assert set(step["arrays"]) == set(arrays), (k, sorted(step["arrays"]))
        a = {name: np.array(v) for name, v in step["arrays"].items()}
        assert np.array_equal(a["rest_position"], c["rest"].reshape(-1, 3)), k
        assert np.array_equal(a["mass"], c["mass"].reshape(-1)), k
        if "displacement" in arrays:
            assert np.array_equal(a["displacement"], (c["position"][k] - c["rest"]).reshape(-1, 3)), k
        if "velocity" in arrays:
            assert np.array_equal(a["velocity"], c["velocity"][k].reshape(-1, 3)), k
    # the run moved: the last step is not the rest lattice
    assert np.abs(np.array(loaded["steps"][-1]["points"]) - c["rest"].reshape(-1, 3)).max() > 1e-3


@pytest.mark.parametrize("name", FILES)
def test_legacy_reader_points_times_and_arrays(legacy, runs, name):
    loaded, _ = legacy
    check_against_h5(loaded[name], runs[name], arrays_of(name, displacement=True))


def test_legacy_reader_prints_nothing(legacy):
    """No HDF5 error stack, XDMF error or VTK warning: no line at all."""
    _, text = legacy
    bad = [line for line in text.splitlines() if line.strip()]
    assert not bad, "\n".join(bad[:20])


@pytest.mark.parametrize("name", FILES)
def test_xdmf3_readers_points_times_and_arrays(xdmf3, runs, name):
    loaded, _ = xdmf3
    check_against_h5(loaded[name], runs[name], arrays_of(name, displacement=False))


def test_xdmf3_readers_skip_only_the_function(xdmf3, runs):
    """One line per step of each file (the displacement Function), nothing else."""
    _, text = xdmf3
    steps = sum(h5_content(runs[k])["nt"] for k in FILES)
    lines = [line for line in text.splitlines() if line.strip()]
    assert sum(line.strip() == XDMF3_SKIP for line in lines) == steps, text[-4000:]
    bad = [line for line in lines if line.strip() != XDMF3_SKIP]
    assert not bad, "\n".join(bad[:20])


@pytest.mark.parametrize("name", ("vel", "novel", "restarted"))
def test_xdmf3_displacement_by_calculator(xdmf3_calculator, runs, name):
    loaded, _ = xdmf3_calculator
    check_against_h5(loaded[name], runs[name], arrays_of(name, displacement=True))


@pytest.mark.parametrize("name", FILES)
def test_views_are_virtual_and_map_their_step(runs, name):
    """/xdmf holds a view per complete step (the killed run: one more),
    virtual, of the same file, equal to the step; nothing stored twice."""
    c = h5_content(runs[name])
    nt = c["nt"]
    fields = ("position",) if name == "novel" else ("position", "velocity")
    extra = 1 if name == "killed" else 0
    with h5py.File(runs[name], "r") as f:
        expect = {"rest_position", "mass"} | {f"{fld}_{k}" for fld in fields for k in range(nt + extra)}
        assert set(f["xdmf"]) == expect
        for v in f["xdmf"].values():
            assert v.is_virtual and v.dtype == np.float64, v.name
            assert all(m.file_name == "." for m in v.virtual_sources()), v.name
        assert f["xdmf/rest_position"].shape == (1, NY, NX, 3)
        assert np.array_equal(f["xdmf/rest_position"][0], c["rest"])
        assert f["xdmf/mass"].shape == (1, NY, NX)
        assert np.array_equal(f["xdmf/mass"][0], c["mass"])
        for fld in fields:
            for k in range(nt):
                v = f[f"xdmf/{fld}_{k}"]
                assert v.shape == (1, NY, NX, 3)
                assert np.array_equal(v[0], c[fld][k]), (fld, k)
    # The restarted files were cut back from 7 steps to 5, then continued by
    # one: the views of step 6 are gone; those of a file without /xdmf made.
    if name.startswith("restarted"):
        assert np.allclose(c["time"], [0, 0.01, 0.02, 0.03, 0.04, 0.05])
        assert {"position_6", "velocity_6"} <= runs["views_before"]["restarted"]
