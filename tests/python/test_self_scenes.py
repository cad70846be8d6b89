# SPDX-License-Identifier: BSD-2-Clause
"""The self-contact scenes of input/ (issue 49 item 4; docs/self-contact.md,
"The scenes"), each run on a coarser lattice (11 x 11: spacing 5 or 10
cm) with output every 10 ms (10 steps; a node moves at most about 1 cm
between outputs, well inside the check's reach of half a spacing; output
at every step cost minutes of HDF5 writes) and checked on every output
step by tests/python/crossings.py (numpy of its own, not nuno's kernels):
between consecutive output steps no node changes the side of a nearby
triangle it lies over. Each run must also have had pairs in the
barrier (/self_contact/active > 0: the layers did meet) and a smallest gap
> 0 at every accepted state.

- fold_table_self (11 x 11, 1 rank, to t = 3 s): the folded edge laid on
  the lower layer;
- heap_table (11 x 11, 2 ranks, to t = 1.3 s): the hanging part laid over
  the part on the table;
- drape_small_sphere (21 x 21: the bars, 2 cm thick, slip through a
  coarser lattice; 2 ranks, to t = 1.45 s): the hanging sides pushed
  together under the sphere.
That the check fails where a cloth does cross itself is shown by
test_self_contact.py (its scene with self_contact off: 90 crossings); at
11 x 11 the fold without self-contact has its upper layer come down onto
the table through the lower one without a node passing inside a
triangle within half a spacing by t = 2.6 s, so it is not a second such
case. About 30, 40 and 145 s on the shared 2-core machine at load average 11
(the drape: 21 x 21 to t = 1.45 s)."""
import subprocess
from pathlib import Path

import f90nml
import h5py
import numpy as np

from crossings import crossings
from nunorun import ROOT, exe, mpiexec
from postprocess.reader import read_run

N = 11                         # nodes a side on the tests' lattice
OUT = 10                       # output every OUT steps


def run_scene(tmp_path, scene, t_end, nranks=1, self_contact=True, nx=N):
    """input/<scene>.nml on an nx x nx lattice, output every OUT steps; the
    positions [nt][ny][nx][3], the file and the lattice spacing."""
    nml = f90nml.read(ROOT / "input" / f"{scene}.nml")
    dt = nml["time"]["dt"]
    lx = nml["lattice"]["lx"]
    name = f"{scene}_{nranks}_{'on' if self_contact else 'off'}"
    patch = {"lattice": {"nx": nx, "ny": nx},
             "contact": {"self_contact": self_contact},
             "time": {"t_end": t_end},
             "output": {"output_interval": OUT * dt, "output_file": f"{name}.h5"}}
    path = Path(tmp_path) / f"{name}.nml"
    f90nml.patch(str(ROOT / "input" / f"{scene}.nml"), patch, str(path))
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(path)]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    h5 = Path(tmp_path) / f"{name}.h5"
    r = read_run(str(h5))
    assert r.complete
    return np.asarray(r.position), h5, lx / (nx - 1)


def assert_no_crossing(position, h5, spacing):
    found = crossings(position, 0.5 * spacing)
    assert not found, found[:5]
    with h5py.File(h5, "r") as f:
        assert (f["self_contact/min_gap"][:] > 0).all()
        assert f["self_contact/active"][:].max() > 0          # the layers did meet


def test_fold_table_self_lays_the_edge_on_the_lower_layer_without_a_crossing(tmp_path):
    on, h5, spacing = run_scene(tmp_path, "fold_table_self", 3.0)
    assert_no_crossing(on, h5, spacing)
    # the edge laid on the lower layer: its column and the next lie within
    # a few mm of the table, over the lower layer (x > 0.9)
    assert on[-1, :, :2, 2].max() < 0.005 and on[-1, :, :2, 0].min() > 0.9


def test_heap_table_piles_layers_without_a_crossing_on_two_ranks(tmp_path):
    on, h5, spacing = run_scene(tmp_path, "heap_table", 1.3, nranks=2)
    assert_no_crossing(on, h5, spacing)


def test_drape_small_sphere_sides_touch_without_a_crossing_on_two_ranks(tmp_path):
    on, h5, spacing = run_scene(tmp_path, "drape_small_sphere", 1.45, nranks=2, nx=21)
    assert_no_crossing(on, h5, spacing)
