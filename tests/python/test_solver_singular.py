# SPDX-License-Identifier: BSD-2-Clause
"""A bending triple folded back to theta = pi (docs/model.md section 3) stops the
run with a clear message on every rank, never a NaN in the output: a
3-node-wide arc bent by 359.9999 degrees has its middle triple at
1 + cos(theta) < 1e-12 from the start."""
import h5py
import numpy as np
import pytest

from nunorun import run


@pytest.mark.parametrize("model", ["energy", "paper"])
def test_triple_at_pi_stops_with_a_message(tmp_path, model):
    proc, h5 = run(tmp_path, f"pi_{model}", nranks=2, check=False,
                   scene="scene='bend_release' bend_angle=359.9999", lattice="nx=3 ny=4",
                   material=f"bending_model='{model}'", time="t_end=0.1 dt=0.01",
                   output="output_interval=0.05")
    assert proc.returncode != 0
    errors = [ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.startswith("nuno: error")]
    assert len(errors) == 1 and "theta = pi" in errors[0], proc.stdout[-2000:]
    with h5py.File(h5, "r") as f:
        assert f.attrs["status"].decode().startswith("failed: singular element")
        pos = f["position"][:]
        assert pos.shape[0] == int(f.attrs["n_output_steps"]) == 1
        assert np.isfinite(pos).all()
