# SPDX-License-Identifier: BSD-2-Clause
"""bench/scipy_cloth.py --lu nopivot (SuperLU with the diagonal pivots, the
careful SciPy baseline of docs/workprecision.md) solves the same problem as
solve_ivp's own factorisation: the same steps and the same final state, on
a small hang lattice, for BDF and Radau. No nuno run: about a second."""
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))
import scipy_cloth  # noqa: E402


@pytest.mark.parametrize("method", ["BDF", "Radau"])
def test_nopivot_is_the_same_integration(method):
    cfg = scipy_cloth.read_config(ROOT / "input" / "hang.nml", {"nx": 7, "ny": 7})
    x0, info0 = scipy_cloth.Cloth(cfg).solve(0.1, method, 1e-5)
    x1, info1 = scipy_cloth.Cloth(cfg).solve(0.1, method, 1e-5, lu="nopivot")
    assert info1["steps"] == info0["steps"]
    scale = np.abs(x0).max()
    assert np.abs(x1 - x0).max() <= 1e-10 * scale
    # the patch is undone: solve_ivp's own splu again afterwards
    assert scipy_cloth._ivp_bdf.splu is scipy_cloth.splu


def test_unknown_lu_is_refused():
    cfg = scipy_cloth.read_config(ROOT / "input" / "hang.nml", {"nx": 5, "ny": 5})
    with pytest.raises(ValueError, match="lu"):
        scipy_cloth.Cloth(cfg).solve(0.01, "BDF", 1e-3, lu="umfpack")
