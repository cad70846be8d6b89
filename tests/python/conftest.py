# SPDX-License-Identifier: BSD-2-Clause
"""Fixtures for the post-processing tests: synthetic nuno files and a real run.

make_run writes a file with exactly the layout of docs/model.md section 9 and known
analytic content: a flat rectangular sheet that translates with velocity V and
turns about the z axis through its centroid with rate omega (a rigid motion),
so momentum = M V, the centre-line length stays lx, the sheet stays flat and
the kinetic energy is constant. The other energies are made-up ramps chosen
so that E_kin + E_stretch + E_bend + E_dissipated - W_external is constant.

solver_run runs the solver (NUNO_EXE) on a tiny lift_release case; tests that
use it are skipped only when NUNO_EXE is not set.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from nunorun import exe as nuno_exe

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))


def sheet_motion(nx, ny, times, lx=100.0, ly=80.0, velocity=(2.0, -1.0, 0.5),
                 omega=0.7, total_mass=1.0):
    """rest [ny][nx][3], mass [ny][nx], position and velocity [nt][ny][nx][3]."""
    xs, ys = np.linspace(0.0, lx, nx), np.linspace(0.0, ly, ny)
    rest = np.zeros((ny, nx, 3))
    rest[..., 0], rest[..., 1] = np.meshgrid(xs, ys)  # [j][i]
    mass = np.full((ny, nx), total_mass / (nx * ny))
    centre = rest.reshape(-1, 3).mean(axis=0)
    rel = rest - centre
    vel_t = np.asarray(velocity, float)
    pos = np.empty((len(times), ny, nx, 3))
    vel = np.empty_like(pos)
    for k, t in enumerate(times):
        c, s = np.cos(omega * t), np.sin(omega * t)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        r = rel @ rot.T
        pos[k] = centre + r + vel_t * t
        vel[k] = np.cross([0.0, 0.0, omega], r) + vel_t
    return rest, mass, pos, vel


def _diagnostics(times, mass, pos, vel):
    m = mass[None, :, :, None]
    ny = pos.shape[1]
    row = pos[:, (ny - 1) // 2]                       # [nt][nx][3]
    length = np.linalg.norm(np.diff(row, axis=1), axis=-1).sum(axis=1)
    flat = []
    for p in pos.reshape(len(times), -1, 3):
        q = p - p.mean(axis=0)
        normal = np.linalg.svd(q, full_matrices=False)[2][-1]
        flat.append(np.abs(q @ normal).max())
    steps = np.arange(len(times), dtype=np.int64) * 10
    return {
        "momentum": (m * vel).sum(axis=(1, 2)),
        "angular_momentum": (m * np.cross(pos, vel)).sum(axis=(1, 2)),
        "length": length,
        "flatness": np.asarray(flat),
        "steps": steps,
        "rejected_steps": steps // 7,
        "newton_iterations": 3 * steps,
        "linear_iterations": 36 * steps,
    }


def namelist_text(scene, nx, ny, extra=""):
    return (f"&scene scene='{scene}' /\n&lattice nx={nx} ny={ny} /\n"
            f"&time t_end=1.0 dt=0.01 /\n{extra}")


def make_run(path, nx=5, ny=4, nt=6, complete=True, dt=0.1, t0=0.0,
             velocity=(2.0, -1.0, 0.5), omega=0.7, lx=100.0, ly=80.0,
             scene="lift_release", namelist_extra="", extra_steps=0,
             status=None, n_output_steps=True, with_velocity=True,
             bytes_attrs=False, uneven=False):
    """Write a section-9 nuno file; returns a dict of the analytic content.

    extra_steps: rows past n_output_steps filled with garbage (a killed run).
    n_output_steps=False: no such attribute; with uneven=True the position and
    velocity datasets are then longer than the others, so the reader must fall
    back to the shortest length.
    """
    times = t0 + dt * np.arange(nt)
    rest, mass, pos, vel = sheet_motion(nx, ny, times, lx, ly, velocity, omega)
    kinetic = 0.5 * (mass[None, :, :, None] * vel**2).sum(axis=(1, 2, 3))
    energy = {
        "kinetic": kinetic,
        "stretch": 0.3 * times,
        "bend": 0.05 * times**2,
        "dissipated": 0.2 * times,
        "external_work": 0.5 * times + 0.05 * times**2,
    }
    diag = _diagnostics(times, mass, pos, vel)
    if status is None:
        status = "complete" if complete else "running"

    def padded(a, extra):
        if extra == 0:
            return a
        junk = np.full((extra,) + a.shape[1:], 12345 if a.dtype.kind == "i" else np.nan,
                       dtype=a.dtype)
        return np.concatenate([a, junk])

    def text(s):
        # Fortran writes fixed-length, blank-padded strings.
        return np.bytes_((s + "    ").encode()) if bytes_attrs else s

    with h5py.File(path, "w") as f:
        f.attrs["program_version"] = text("nuno 0.0.0-test")
        f.attrs["nx"] = np.int32(nx)
        f.attrs["ny"] = np.int32(ny)
        f.attrs["n_ranks"] = np.int32(2)
        f.attrs["namelist"] = text(namelist_text(scene, nx, ny, namelist_extra))
        f.attrs["petsc_options"] = text("-ts_type beuler")
        if n_output_steps:
            f.attrs["n_output_steps"] = np.int32(nt)
        f.create_dataset("lattice/rest_position", data=rest)
        f.create_dataset("lattice/mass", data=mass)

        def timed(name, a, extra=extra_steps):
            a = padded(np.asarray(a), extra)
            f.create_dataset(name, data=a, maxshape=(None,) + a.shape[1:],
                             chunks=(1,) + a.shape[1:])

        long_extra = extra_steps + (2 if uneven else 0)
        timed("time", times)
        timed("position", pos, long_extra)
        if with_velocity:
            timed("velocity", vel, long_extra)
        for name, a in energy.items():
            timed(f"energy/{name}", a)
        for name, a in diag.items():
            timed(f"diagnostics/{name}", a)
        f.attrs["status"] = text(status)  # written last, as the solver does
    return {"time": times, "rest": rest, "mass": mass, "position": pos,
            "velocity": vel, "energy": energy, "diagnostics": diag,
            "velocity_translation": np.asarray(velocity, float), "lx": lx}


@pytest.fixture(name="make_run")
def make_run_fixture():
    """The make_run writer (call it with a path under tmp_path)."""
    return make_run


SOLVER_NAMELIST = """&scene scene='lift_release' /
&lattice nx=5 ny=5 /
&time t_end=0.05 dt=0.01 /
&output output_interval=0.01 output_file='{out}' /
"""


@pytest.fixture(scope="session")
def solver_run(tmp_path_factory):
    """Path of a real solver output (2 ranks, 5 x 5 lift_release, t_end 0.05)."""
    exe = nuno_exe()          # skips without NUNO_EXE, fails if it is missing
    work = tmp_path_factory.mktemp("solver")
    out = work / "run.h5"
    nml = work / "case.nml"
    nml.write_text(SOLVER_NAMELIST.format(out=out))
    mpiexec = shlex.split(os.environ.get("NUNO_MPIEXEC") or "mpiexec")
    env = dict(os.environ)
    for key in ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
                "OMPI_MCA_rmaps_base_oversubscribe"):
        env.setdefault(key, "1")
    cmd = mpiexec + ["-n", "2", exe, str(nml)]
    proc = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True,
                          timeout=600)
    if proc.returncode != 0 or not out.is_file():
        pytest.fail(f"solver run failed (exit {proc.returncode}): {' '.join(cmd)}\n"
                    f"stdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-3000:]}")
    return out


@pytest.fixture(params=["synthetic", "solver"])
def run_file(request, tmp_path):
    """A nuno file: the synthetic sheet, and the real solver's when NUNO_EXE is set."""
    if request.param == "solver":
        return request.getfixturevalue("solver_run")
    path = tmp_path / "sheet.h5"
    make_run(path, nx=6, ny=5, nt=7)
    return path
