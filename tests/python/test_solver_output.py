# SPDX-License-Identifier: BSD-2-Clause
"""The output file has every dataset and attribute of docs/model.md section 9 with
the right shapes, the XDMF sidecar parses and points at existing datasets,
and a failed run leaves a file marked as failed with the steps so far."""
import re
import xml.etree.ElementTree as ET

import h5py
import numpy as np

from nunorun import read_run, run, run_and_read

NX, NY = 6, 7
GROUPS = dict(scene="scene='lift_release'", lattice=f"nx={NX} ny={NY}",  # 3 ranks need ny >= 6 (bending halo 2)
              time="t_end=0.3 dt=0.01", output="output_interval=0.1 write_velocity=.true.")


def text(a):
    return a.decode() if isinstance(a, bytes) else str(a)


def test_layout_of_section_9(tmp_path):
    proc, h5 = run(tmp_path, "layout", nranks=2, options=("-ts_type", "cn"), **GROUPS)
    nt = 4
    with h5py.File(h5, "r") as f:
        a = f.attrs
        for key in ("program_version", "nx", "ny", "n_ranks", "namelist", "petsc_options",
                    "status", "n_output_steps"):
            assert key in a, key
        assert int(a["nx"]) == NX and int(a["ny"]) == NY and int(a["n_ranks"]) == 2
        assert text(a["status"]) == "complete" and int(a["n_output_steps"]) == nt
        assert text(a["namelist"]).strip() == (tmp_path / "layout.nml").read_text().strip()
        assert "-ts_type cn" in text(a["petsc_options"])
        shapes = {
            "lattice/rest_position": (NY, NX, 3), "lattice/mass": (NY, NX), "time": (nt,),
            "position": (nt, NY, NX, 3), "velocity": (nt, NY, NX, 3),
            "diagnostics/momentum": (nt, 3), "diagnostics/angular_momentum": (nt, 3),
        }
        for name in ("kinetic", "stretch", "bend", "dissipated", "external_work"):
            shapes[f"energy/{name}"] = (nt,)
        for name in ("length", "flatness", "steps", "rejected_steps", "newton_iterations",
                     "linear_iterations"):
            shapes[f"diagnostics/{name}"] = (nt,)
        for name, shape in shapes.items():
            assert name in f, name
            assert f[name].shape == shape, (name, f[name].shape)
        for name in ("position", "velocity", "time"):
            assert f[name].maxshape[0] is None          # extendable along t
            assert f[name].chunks is not None
        assert f["position"].dtype == np.float64
        # independent values: rest lattice, masses, time, counters
        rest = f["lattice/rest_position"][:]
        assert np.allclose(rest[2, 3], [3 * 100 / (NX - 1), 2 * 100 / (NY - 1), 0])
        assert np.isclose(f["lattice/mass"][:].sum(), 1.0)
        assert np.allclose(f["time"][:], [0, 0.1, 0.2, 0.3])
        assert list(f["diagnostics/steps"][:]) == [0, 10, 20, 30]
        # the pinned edge i = 0 does not move; t = 0 is the folded start
        assert np.abs(f["position"][:, :, 0, :] - rest[:, 0, :]).max() < 1e-12
        assert f["position"][0, 0, NX - 1, 2] > 1.0

    xmf = h5.with_suffix(".xdmf")
    root = ET.parse(xmf).getroot()
    grids = [g for g in root.iter("Grid") if g.get("GridType") != "Collection"]
    assert len(grids) == nt
    with h5py.File(h5, "r") as f:
        for item in root.iter("DataItem"):
            if item.get("Format") == "HDF":
                fname, dset = item.text.strip().split(":")
                assert fname == h5.name
                assert dset.lstrip("/") in f, dset
    topo = grids[0].find("Topology")
    assert topo.get("TopologyType") == "3DSMesh"      # one layer of points (test_xdmf.py)
    assert topo.get("Dimensions").split() == ["1", str(NY), str(NX)]


def test_failed_run_keeps_output_and_is_marked(tmp_path):
    # One Newton iteration cannot solve the paper-bending step: the first step fails.
    proc, h5 = run(tmp_path, "fail", nranks=3, check=False,
                   options=("-snes_max_it", "1", "-ts_max_snes_failures", "1"), **GROUPS)
    assert proc.returncode != 0
    assert "nuno: error: time step from t =" in proc.stdout + proc.stderr
    # the closing line names the outcome by its word, not a cut-off reason
    assert re.search(r"^nuno: failed at t = ", proc.stdout, re.M), proc.stdout[-400:]
    with h5py.File(h5, "r") as f:
        assert text(f.attrs["status"]).startswith("failed: time step")
        assert int(f.attrs["n_output_steps"]) == 1
    r = read_run(str(h5))
    assert not r.complete and r.nt == 1
    assert r.position.shape == (1, NY, NX, 3)


def test_namelist_petsc_options_yield_to_the_command_line(tmp_path):
    """petsc_options in the namelist apply unless the command line sets the
    same option: steps taken to t_end tell which -ts_dt was used."""
    groups = dict(scene="scene='wave_point'", lattice="nx=5 ny=5", time="t_end=0.2 dt=0.01")
    _, r = run_and_read(tmp_path, "nml", output="output_interval=0.2 petsc_options='-ts_dt 0.02 -ts_type cn'",
                        **groups)
    assert list(r.diagnostics["steps"]) == [0, 10]
    _, r = run_and_read(tmp_path, "cmd", options=("-ts_dt", "0.05"),
                        output="output_interval=0.2 petsc_options='-ts_dt 0.02 -ts_type cn'", **groups)
    assert list(r.diagnostics["steps"]) == [0, 4]
    assert "-ts_dt 0.05" in r.petsc_options and "namelist" in r.petsc_options
