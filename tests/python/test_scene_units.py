# SPDX-License-Identifier: BSD-2-Clause
"""Every shipped input records the unit system its values are in (issue 39,
the units of the contact scenes): the root attribute `units` and the
series' `units` attributes of its output against an independent reading of
the file, the unit system its header comment names first ('SI units
m, kg, s' or 'units mm, g, s') and, where it has gravity, the magnitude of g (9.81 m/s^2 or 9810
mm/s^2). The SI scenes built on `flat` and `wave_point` (drop_table,
drape_sphere, table_edge, gripper) recorded 'mm g s', their scenes' system.
One step each."""
import re
import shutil

import f90nml
import h5py
import numpy as np
import pytest

from nunorun import ROOT, exe, mpiexec

INPUTS = sorted(p.name for p in (ROOT / "input").glob("*.nml"))
LABELS = {"SI": {"position": "m", "energy/kinetic": "J", "time": "s"},
          "mm g s": {"position": "mm", "energy/kinetic": "g mm^2/s^2", "time": "s"}}


def declared(text):
    """The unit system the file's header comment names first ('SI units'
    or 'units mm, g, s')."""
    header = []
    for line in text.splitlines():
        if not line.startswith("!"):
            break
        header.append(line.lstrip("! ").strip())
    m = re.search(r"\b(SI units|units mm, g, s)\b", " ".join(header))
    assert m, f"no unit system in the header: {header[:2]!r}"
    return "SI" if m.group(1) == "SI units" else "mm g s"


def test_every_shipped_input_is_checked():
    assert len(INPUTS) >= 11, INPUTS
    assert {"drop_table.nml", "drape_sphere.nml", "table_edge.nml", "gripper.nml", "hang.nml"} <= set(INPUTS)


@pytest.mark.parametrize("name", INPUTS)
def test_the_output_records_the_inputs_unit_system(tmp_path, name):
    import subprocess
    src = ROOT / "input" / name
    text = src.read_text()
    system = declared(text)
    g = np.linalg.norm(f90nml.reads(text)["scene"].get("gravity", [0.0, 0.0, 0.0]))
    if g > 0:
        # gravity in the declared system: 9.81 m/s^2 = 9810 mm/s^2
        assert abs(g - {"SI": 9.81, "mm g s": 9810.0}[system]) < 1e-9 * g, (name, g, system)
    shutil.copy(src, tmp_path / name)
    h5 = f90nml.reads(text)["output"]["output_file"]
    cmd = [mpiexec(), "-n", "1", "--oversubscribe", exe(), name, "-ts_max_steps", "1"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with h5py.File(tmp_path / h5, "r") as f:
        assert f.attrs["units"].decode() == system, name
        for dset, unit in LABELS[system].items():
            assert f[dset].attrs["units"].decode() == unit, (name, dset)


def test_units_key_any_case_and_a_bad_value_refused(tmp_path):
    """`units` is read in any case ('si' records 'SI'); another value is
    refused in one line naming the key and the value, on 2 ranks, and no
    output file is made."""
    from nunorun import run
    flat = dict(scene="scene='flat' gravity=0.0,0.0,-9.81 units='si'", lattice="nx=5 ny=5",
                time="t_end=0.002 dt=0.001", output="output_interval=0.001")
    _, h5 = run(tmp_path, "si", nranks=2, **flat)
    with h5py.File(h5, "r") as f:
        assert f.attrs["units"].decode() == "SI"
        assert f["config/scene"].attrs["units"].decode() == "SI"
    proc, bad = run(tmp_path, "cgs", nranks=2, check=False, timeout=120,
                    **dict(flat, scene="scene='flat' units='cgs'"))
    assert proc.returncode != 0
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1 and "&scene: units = 'cgs' is not one of" in errors[0], proc.stderr[-2000:]
    assert not bad.exists()
