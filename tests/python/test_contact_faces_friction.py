# SPDX-License-Identifier: BSD-2-Clause
"""Friction of the cloth's triangles and edges against obstacles
(contact_faces = .true.) where Newton's update turns a pair's slip
(docs/contact.md, "Faces and edges"; issue 49):

- drape_sphere with the faces, to t = 0.5 s on one rank: where the sheet
  lands on the sphere (t = 0.105 s) and lands again after bouncing off it
  (t = 0.49 s), a triangle's sliding velocity (a few mm/s, beyond
  friction_eps_v = 1 mm/s) reversed at every Newton iteration (the smoothed
  law has no stiffness along the slip while sliding) and ||F|| cycled
  through Newton's 50 iterations; the step was retried, and the line search
  bt that the run then falls back on failed 5 more steps near t = 0.49 s.
  With the guard on the update (where it turns a pair's slip from at
  least eps_v / 2 to at least eps_v the other way through the band, the
  update stops where the slip is least) no step is retried. Before the guard: 6 retried steps (on 2 ranks,
  where the strips' overlapping preconditioner solves differently, none).
- a genuine slide with the faces' friction acting: the incline of
  test_contact_friction (tan theta = 0.5, mu = 0.3, tilted gravity) on the
  top of a sphere so large (R = 1e3 m) that it is a plane to 2.5e-4 m over
  the sheet, so every triangle (the sphere's centre against it) is within
  the barrier's reach beside the nodes (72 face pairs): every pair's normal
  is the sphere's to 1e-3 rad, so the pairs' normal forces sum to the
  normal load and their friction to mu times it, and the centre of mass
  accelerates at g (sin theta - mu cos theta) as on the plane (the slope
  turns by at most 1e-3 rad over the slide: 0.5 % at most; 0.18 %
  measured). No pair's slip turns, so the guard leaves the run alone (the
  positions are those of the build before it, bit for bit). (With R =
  1e5 m the run fails at t = 4.6 ms, with and without the guard: the
  line search stalls at ||F|| ~ 1e-6.)"""
import math
import subprocess

import f90nml
import h5py
import numpy as np

from nunorun import ROOT, contact_sheet, exe, mpiexec, read_run, run, slide_acceleration

G = 9.81


def test_drape_landing_no_retried_step(tmp_path):
    nml = f90nml.read(str(ROOT / "input" / "drape_sphere.nml"))
    nml["contact"]["contact_faces"] = True
    nml["time"]["t_end"] = 0.5
    nml["output"]["output_file"] = "drape.h5"
    nml.write(str(tmp_path / "drape.nml"))
    proc = subprocess.run([mpiexec(), "-n", "1", "--oversubscribe", exe(), "drape.nml"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with read_run(str(tmp_path / "drape.h5"), load_velocity=False) as r:
        assert abs(float(r.time[-1]) - 0.5) < 1e-9
        assert r.run_info["retried_steps"] == 0, r.run_info["retried_steps"]


TAN = 0.5
THETA = math.atan(TAN)
R = 1.0e3            # the sphere's radius [m]
DHAT = 1e-3
EPS_V = 1e-3


def test_faces_slide_accelerates_at_g_sin_minus_mu_cos(tmp_path):
    mu = 0.3
    # the sheet (1 m, 7 x 7) flat at z = 0, the sphere's top 0.3 dhat below its centre
    contact = (f"n_obstacles=1 obstacle_shape(1)='sphere' obstacle_point(:,1)=0.5,0.5,{-(R + 0.3 * DHAT)!r} "
               f"obstacle_radius(1)={R!r} obstacle_mu(1)={mu} contact_dhat={DHAT} contact_stiffness=1.0 "
               f"friction_eps_v={EPS_V} contact_faces=.true.")
    groups = contact_sheet(contact, 1.0, 0.02, n=7, dt=2e-3,
                           gravity=(G * math.sin(THETA), 0.0, -G * math.cos(THETA)), masses="uniform")
    proc, h5 = run(tmp_path, "slide", **groups)
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        t = np.array(f["time"][:n])
        x = np.array(f["position"][:n, :, :, 0]).mean(axis=(1, 2))
        active = np.array(f["contact_faces/active"][:n])
        fwork = np.array(f["contact_faces/friction_work"][:n])
    assert abs(t[-1] - 1.0) < 1e-9
    # the faces carry part of the load and their friction does work
    assert active[-1] > 0 and fwork[-1] > 0.0, (active[-1], fwork[-1])
    a = slide_acceleration(t, x, 100.0 * EPS_V)
    expected = G * (math.sin(THETA) - mu * math.cos(THETA))
    assert abs(a / expected - 1.0) < 0.01, (a, expected)
