# SPDX-License-Identifier: BSD-2-Clause
"""The output opens in the common Python readers, and they read the numbers
that h5py (an independent reader) reads from the file, to the last bit.

- pyvista (VTK's vtkXdmfReader, picked by the extension of RUN.xdmf):
  pyvista.read gives the lattice, pyvista.get_reader every output step at
  the file's times, with the points and the point arrays velocity,
  rest_position and mass of the file.
- xarray with engine h5netcdf (netCDF-4 semantics: HDF5 dimension scales):
  the root opens with the dimensions time, j, i, xyz (none anonymous,
  phony_dim_*), time is a coordinate, every array has its `units` in the
  scene's unit system (SI for hang, mm g s for lift_release), and the
  groups energy, diagnostics and lattice open the same way.

Small runs: hang 11 x 9 (not square, so that a transposed axis shows) on 1
and 2 ranks, 5 output steps; lift_release 7 x 5 for the other unit system.
pyvista, xarray and h5netcdf come from PyPI (tools/install.sh); a test
is skipped, saying which, only when one is not installed.
"""
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from nunorun import run

NX, NY = 11, 9
HANG = dict(scene="scene='hang'", lattice=f"nx={NX} ny={NY}", time="t_end=0.04 dt=0.002",
            output="output_interval=0.01")
UNITS = {  # docs: postprocess/README.md, "xarray"
    "SI": {"time": "s", "position": "m", "velocity": "m/s", "wall_time": "s",
           "energy/kinetic": "J", "diagnostics/momentum": "kg m/s", "diagnostics/angular_momentum": "kg m^2/s",
           "diagnostics/steps": "1", "lattice/rest_position": "m", "lattice/mass": "kg"},
    "mm g s": {"time": "s", "position": "mm", "velocity": "mm/s", "wall_time": "s",
               "energy/kinetic": "g mm^2/s^2", "diagnostics/momentum": "g mm/s",
               "diagnostics/angular_momentum": "g mm^2/s", "diagnostics/steps": "1",
               "lattice/rest_position": "mm", "lattice/mass": "g"},
}


def need(module):
    return pytest.importorskip(module, reason=f"{module} is not installed (pip install {module}; tools/install.sh)")


@pytest.fixture(scope="module", params=[1, 2], ids=["np1", "np2"])
def hang(request, tmp_path_factory):
    _, h5 = run(tmp_path_factory.mktemp(f"readers{request.param}"), "hang", nranks=request.param, **HANG)
    return h5


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    _, h5 = run(tmp_path_factory.mktemp("readers_mm"), "lift", nranks=2, scene="scene='lift_release'",
                lattice="nx=7 ny=5", time="t_end=0.02 dt=0.01", output="output_interval=0.01")
    return h5


def content(h5):
    with h5py.File(h5, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        c = {"nt": nt, "time": f["time"][:nt], "position": f["position"][:nt], "velocity": f["velocity"][:nt],
             "rest": f["lattice/rest_position"][()], "mass": f["lattice/mass"][()]}
    assert nt == 5
    return c


def test_pyvista_reads_every_step_of_the_sidecar(hang):
    pv = need("pyvista")
    c = content(hang)
    xdmf = hang.with_suffix(".xdmf")
    first = pv.read(xdmf)            # the first step, by the extension alone
    assert isinstance(first, pv.StructuredGrid)
    assert tuple(first.dimensions) == (NX, NY, 1)           # point j*nx + i
    np.testing.assert_array_equal(first.points, c["position"][0].reshape(-1, 3))
    reader = pv.get_reader(str(xdmf))
    np.testing.assert_array_equal(np.array(reader.time_values), c["time"])
    for k, t in enumerate(reader.time_values):
        reader.set_active_time_value(t)
        grid = reader.read()
        np.testing.assert_array_equal(grid.points, c["position"][k].reshape(-1, 3))
        np.testing.assert_array_equal(grid.point_data["velocity"], c["velocity"][k].reshape(-1, 3))
        np.testing.assert_array_equal(grid.point_data["rest_position"], c["rest"].reshape(-1, 3))
        np.testing.assert_array_equal(grid.point_data["mass"], c["mass"].reshape(-1))
    # the cloth fell: the last step is not the rest lattice
    assert np.abs(grid.points - c["rest"].reshape(-1, 3)).max() > 1e-4


def test_xarray_opens_with_named_dimensions_time_coordinate_and_units(hang):
    xr = need("xarray")
    need("h5netcdf")
    c = content(hang)
    with xr.open_dataset(hang, engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"time": c["nt"], "j": NY, "i": NX, "xyz": 3}
        assert "time" in ds.coords and ds.position.dims == ("time", "j", "i", "xyz")
        assert ds.velocity.dims == ("time", "j", "i", "xyz") and ds.wall_time.dims == ("time",)
        np.testing.assert_array_equal(ds.time.values, c["time"])
        np.testing.assert_array_equal(ds.position.values, c["position"])
        np.testing.assert_array_equal(ds.velocity.values, c["velocity"])
        # a selection by the time coordinate is the step of that time
        np.testing.assert_array_equal(ds.position.sel(time=c["time"][2]).values, c["position"][2])
        for name in ("time", "position", "velocity", "wall_time"):
            assert ds[name].attrs["units"] == UNITS["SI"][name], name
    with xr.open_dataset(hang, engine="h5netcdf", group="lattice") as lat:
        assert lat.rest_position.dims == ("j", "i", "xyz") and lat.mass.dims == ("j", "i")
        np.testing.assert_array_equal(lat.rest_position.values, c["rest"])
        np.testing.assert_array_equal(lat.mass.values, c["mass"])
    for group in ("energy", "diagnostics"):
        with xr.open_dataset(hang, engine="h5netcdf", group=group) as g, h5py.File(hang, "r") as f:
            assert set(g.sizes) <= {"time", "xyz"} and g.sizes["time"] == c["nt"], dict(g.sizes)
            for name, var in g.data_vars.items():
                np.testing.assert_array_equal(var.values, f[f"{group}/{name}"][:c["nt"]])
                assert var.dims[0] == "time" and var.attrs.get("units"), (group, name)


@pytest.mark.parametrize("which", ["hang", "lift"])
def test_units_in_the_scenes_unit_system(which, hang, lift):
    h5, system = (hang, "SI") if which == "hang" else (lift, "mm g s")
    with h5py.File(h5, "r") as f:
        assert f.attrs["units"].decode() == system
        for name, unit in UNITS[system].items():
            assert f[name].attrs["units"].decode() == unit, name
        # every series (one value per output step) has units
        missing = []
        f.visititems(lambda n, o: missing.append(n) if isinstance(o, h5py.Dataset) and o.maxshape[:1] == (None,)
                     and not n.startswith("checkpoint") and "units" not in o.attrs else None)
        assert not missing, missing


def test_xarray_names_no_phony_dimension(hang):
    """The dimension scales are in the file: h5py sees them attached (a
    reader that does not know netCDF sees them too)."""
    with h5py.File(hang, "r") as f:
        assert f["time"].is_scale
        for name, labels in (("position", ["time", "j", "i", "xyz"]), ("lattice/mass", ["j", "i"]),
                             ("diagnostics/momentum", ["time", "xyz"]), ("energy/bend", ["time"])):
            got = [f[name].dims[a][0].name.lstrip("/") for a in range(f[name].ndim)]
            assert got == labels, (name, got)


def test_the_docs_python_block_runs(hang):
    """postprocess/README.md's "pyvista and xarray" block, as written, on a
    run named hang.h5, in its directory: xyz selected by its labels x, y, z
    (which the block attaches: the file has none), and the whole file as one
    DataTree (xr.open_datatree fails on it; the block's open_groups recipe
    does not)."""
    need("pyvista")
    need("xarray")
    need("h5netcdf")
    text = (Path(__file__).resolve().parents[2] / "postprocess" / "README.md").read_text()
    section = text.split("\n## pyvista and xarray\n", 1)[1].split("\n## ", 1)[0]
    block = section.split("```python\n", 1)[1].split("```", 1)[0]
    assert "hang.xdmf" in block and 'engine="h5netcdf"' in block
    proc = subprocess.run([sys.executable, "-c", block], cwd=hang.parent, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.split("\n")
    assert lines[0] == f"({NX * NY}, 3)"                       # velocity of the last step, a vector per point
    with h5py.File(hang, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        zmean = f["position"][:nt, :, :, 2].min(axis=0).mean()
        assert lines[1] == f"{zmean} m"
        assert lines[2] == f"{float(f['energy/kinetic'][nt - 1])} J"
        # the tree of every group: the energy at the last complete time by
        # its inherited time coordinate, the lattice's components by name
        assert lines[3] == f"{float(f['energy/kinetic'][nt - 1])} ('j', 'i')"


def test_open_datatree_fails_as_the_docs_say(hang):
    """postprocess/README.md says xr.open_datatree fails on the file with a
    KeyError about /config's time: when an xarray opens it, this fails and
    the docs must say so instead."""
    xr = need("xarray")
    need("h5netcdf")
    text = (Path(__file__).resolve().parents[2] / "postprocess" / "README.md").read_text()
    assert "KeyError: 'parent config already contains a variable named time'" in " ".join(text.split())
    with pytest.raises(KeyError, match="parent config already contains a variable named time"):
        xr.open_datatree(hang, engine="h5netcdf", phony_dims="access")


def test_a_restart_adds_the_scales_to_a_file_of_an_earlier_version(tmp_path):
    """A file without dimension scales and units (as versions before them
    wrote it), continued by -nuno_restart on 2 ranks, opens in xarray with
    named dimensions, its old and new steps alike."""
    xr = need("xarray")
    need("h5netcdf")
    proc, h5 = run(tmp_path, "old", nranks=2, **HANG)
    with h5py.File(h5, "r+") as f:
        def strip(name, obj):
            if isinstance(obj, h5py.Dataset):
                for a in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "units"):
                    if a in obj.attrs:
                        del obj.attrs[a]
        f.visititems(strip)
        for name in ("j", "i", "xyz"):
            del f[name]
    with xr.open_dataset(h5, engine="h5netcdf", phony_dims="sort") as ds:
        assert any(d.startswith("phony_dim") for d in ds.sizes)        # the old layout
    proc, _ = run(tmp_path, "old", nranks=2, options=["-nuno_restart", str(h5), "-nuno_set", "t_end=0.06"], **HANG)
    with xr.open_dataset(h5, engine="h5netcdf") as ds, h5py.File(h5, "r") as f:
        nt = int(f.attrs["n_output_steps"])
        assert nt == 7 and dict(ds.sizes) == {"time": nt, "j": NY, "i": NX, "xyz": 3}
        np.testing.assert_array_equal(ds.time.values, f["time"][:nt])
        np.testing.assert_array_equal(ds.position.values, f["position"][:nt])
        assert ds.position.attrs["units"] == "m" and ds.time.attrs["units"] == "s"
