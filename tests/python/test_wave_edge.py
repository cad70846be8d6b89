# SPDX-License-Identifier: BSD-2-Clause
"""wave_point with wave_nodes = 'edge': every node of edge i = 0 follows the
keyframe path (z to -10 at t = 0.5, +15 at t = 1.0), so the wave travels
along +x; a bad value of the key is rejected."""
import numpy as np
import pytest

from nunorun import run, run_and_read


@pytest.mark.parametrize("nranks", [1, 3])
def test_edge_nodes_follow_keyframes(tmp_path, nranks):
    _, r = run_and_read(tmp_path, f"wave_edge_{nranks}", nranks=nranks,
                        scene="scene='wave_point' wave_nodes='edge'",
                        lattice="nx=7 ny=6", time="t_end=1.2")
    assert r.complete, r.status_line()
    rest = r.rest_position[:, 0, :]                       # [ny][3], edge i = 0
    for t, dz in ((0.5, -10.0), (1.0, 15.0)):
        k = r.step_index(t)
        assert abs(r.time[k] - t) < 1e-9
        edge = r.position[k][:, 0, :]                     # [ny][3]
        assert edge.shape[0] == 6
        np.testing.assert_allclose(edge[:, 2], rest[:, 2] + dz, rtol=0, atol=1e-9)
        np.testing.assert_allclose(edge[:, :2], rest[:, :2], rtol=0, atol=1e-9)
    # The rest of the cloth moved (the wave started), not only the edge.
    k = r.step_index(1.0)
    assert np.max(np.abs(r.position[k][:, 1:, 2] - r.rest_position[:, 1:, 2])) > 1e-3


@pytest.mark.parametrize("nranks", [1, 3])
def test_edge_follows_a_path_in_three_dimensions(tmp_path, nranks):
    """keyframe_dx, keyframe_dy move the driven nodes in x and y as keyframe_dz
    does in z: at the keyframes the edge sits at rest + (dx, dy, dz), halfway
    between two keyframes at the mean of their offsets."""
    off = np.array([[0.0, 0.0, 0.0], [3.0, -2.0, -10.0], [-4.0, 5.0, 15.0]])   # [keyframe][x, y, z]
    scene = ("scene='wave_point' wave_nodes='edge' keyframe_time=0,0.5,1.0 "
             + " ".join(f"keyframe_d{c}={','.join(str(v) for v in off[:, n])}" for n, c in enumerate("xyz")))
    _, r = run_and_read(tmp_path, f"wave_xyz_{nranks}", nranks=nranks, scene=scene,
                        lattice="nx=7 ny=6", time="t_end=1.2 dt=0.01", output="output_interval=0.25")
    assert r.complete, r.status_line()
    rest = r.rest_position[:, 0, :]
    for t, expect in ((0.25, 0.5 * (off[0] + off[1])), (0.5, off[1]), (0.75, 0.5 * (off[1] + off[2])),
                      (1.0, off[2])):
        k = r.step_index(t)
        assert abs(r.time[k] - t) < 1e-9
        np.testing.assert_allclose(r.position[k][:, 0, :], rest + expect, rtol=0, atol=1e-9)


def test_bad_wave_nodes_rejected(tmp_path):
    proc, h5 = run(tmp_path, "wave_bad", nranks=1, check=False,
                   scene="scene='wave_point' wave_nodes='middle'", lattice="nx=7 ny=6")
    assert proc.returncode != 0
    assert "wave_nodes" in proc.stderr + proc.stdout
    assert not h5.exists()
