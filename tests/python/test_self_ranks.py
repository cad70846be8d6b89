# SPDX-License-Identifier: BSD-2-Clause
"""The guarantee test's scene (test_self_contact: a cloth dropped flat onto
a thin capsule, whose halves swing under it and meet) on 4 and 8 ranks
(issue 49 item 2; docs/self-contact.md, "The guarantee test"), oversubscribed,
in Newton mode: no node crosses the cloth (tests/python/crossings.py, on
every step), every accepted state's smallest gap is > 0, the halves met,
and the positions agree with one rank's to the solver's tolerance (Newton's
-snes_rtol 1e-8 of the cloth's size). 8 ranks need at least 2 rows each
(the bending stencil's halo), so the lattice is 17 x 17 (the test scene's
15 x 15 has 15 rows); the step is 2 ms (the halves still meet, at about
1 m/s, 2 mm a step against a spacing of 31 mm) to keep the 8-rank run
near a minute on the shared 2-core machine. Self-contact off, the same
check finds the crossings on this lattice and step (it can fail here)."""
import h5py
import numpy as np
import pytest

from crossings import crossings
from test_self_contact import GROUPS, L, T_END, drop

N = 17
NEAR = 0.5 * L / (N - 1)      # the crossing check's reach: half a lattice spacing [m]
RANK_GROUPS = dict(GROUPS, lattice=f"nx={N} ny={N} lx={L} ly={L} total_mass=0.05 mass_distribution='area'",
                   time=f"t_end={T_END} dt=2.0e-3", output="output_interval=2.0e-3 write_velocity=.false.")


@pytest.fixture(autouse=True)
def _scene(monkeypatch):
    """drop() runs test_self_contact's groups: these, for this file's tests."""
    import test_self_contact
    monkeypatch.setattr(test_self_contact, "GROUPS", RANK_GROUPS)


@pytest.mark.parametrize("nranks", [4, 8])
def test_many_ranks_agree_with_one_without_crossings(tmp_path, nranks):
    off, _ = drop(tmp_path, "off", False)
    assert len(crossings(off, NEAR)) > 10            # the check fails where the cloth crosses itself

    on = {}
    for n in (1, nranks):
        on[n], h5 = drop(tmp_path, f"on_{n}", True, nranks=n)
        found = crossings(on[n], NEAR)
        assert not found, (n, found[:5])
        with h5py.File(h5, "r") as f:
            assert (f["self_contact/min_gap"][:] > 0).all()
            assert f["self_contact/active"][:].max() > 0      # the halves did meet
            if n > 1:
                assert f["self_contact/rows_fetched"][:].max() > 0   # rows came from other ranks
    size = np.ptp(on[1].reshape(-1, 3), axis=0).max()
    assert np.abs(on[nranks] - on[1]).max() <= 1e-8 * size
