# SPDX-License-Identifier: BSD-2-Clause
"""Run the real nuno program from a test: write a namelist, launch it under
mpiexec on N ranks with a time bound, and read the result through the users'
reader (postprocess.reader)."""
import os
import re
import subprocess
import sys
from pathlib import Path

import f90nml
import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from postprocess.reader import read_run  # noqa: E402


def exe():
    """Path of the nuno executable (set by CTest), or skip."""
    path = os.environ.get("NUNO_EXE")
    if not path:
        pytest.skip("NUNO_EXE is not set (run through ctest)")
    if not Path(path).exists():
        pytest.fail(f"NUNO_EXE={path} does not exist")
    return path


def mpiexec():
    return os.environ.get("NUNO_MPIEXEC", "mpiexec")


def namelist(output_file, **groups):
    """Namelist text from {group: 'key=value ...'} plus the output file.

    The groups are read and written by f90nml (a Fortran namelist parser),
    so what a test passes is a namelist, not a string pasted together. A
    fragment f90nml cannot read is kept as written: the bad-input tests
    hand the program malformed text on purpose."""
    out = groups.pop("output", "")
    raw = [f"&{g} {body} /" for g, body in groups.items()]
    raw.append(f"&output output_file='{output_file}' {out} /")
    text = "\n".join(raw) + "\n"
    try:
        parsed = f90nml.reads(text)
    except Exception:  # f90nml raises several types on bad input
        return text
    if set(parsed.keys()) != {g.lower() for g in (*groups, "output")}:
        return text
    return str(parsed) + "\n"


def run(tmp_path, name, nranks=1, options=(), timeout=300, check=True, **groups):
    """Run nuno on a namelist built from groups; return (CompletedProcess, h5 path)."""
    tmp_path = Path(tmp_path)
    h5 = tmp_path / f"{name}.h5"
    nml = tmp_path / f"{name}.nml"
    nml.write_text(namelist(h5.name, **groups))
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(nml), *options]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"nuno failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return proc, h5


def slide_acceleration(t, x, min_speed):
    """The acceleration of a slide x(t) (output times, a coordinate of the
    centre of mass): twice the leading coefficient of a parabola fitted from
    the first output where the speed (finite difference) exceeds min_speed
    (far above friction's smoothing speed); at least 20 outputs after it."""
    speed = np.diff(x) / np.diff(t)
    k0 = int(np.argmax(speed > min_speed))
    assert speed[k0] > min_speed and len(t) - k0 > 20, (k0, speed[:5])
    return 2.0 * np.polyfit(t[k0:], x[k0:], 2)[0]


def signal_env(**extra):
    """The environment of a run that a test stops with SIGTERM sent to
    mpiexec: Open MPI's mpirun forwards the signal to the ranks after
    odls_base_sigkill_timeout seconds and SIGKILLs them as long after that
    (1 s by default; input/README.md tells users to raise it): on a loaded
    machine 1 s was sometimes too short for the ranks to end their step and
    write the checkpoint, and the run died without its 'interrupted' line.
    5 s, as a user's batch script would set it; the signal then reaches the
    ranks 5 s late, so only for runs that last that much longer (a shorter
    one ends before and exits 0 or without its line)."""
    return dict(os.environ, OMPI_MCA_odls_base_sigkill_timeout="5", **extra)


def start_running(tmp_path, name, nranks=2, lines=3, env=None, **groups):
    """Launch nuno in the background and return (Popen, h5 path) once it has
    printed `lines` progress lines ('t = ...'): the time loop is running.
    env: the run's environment (signal_env() for a run long enough to go on
    for its seconds after a SIGTERM to mpiexec), else this process's."""
    import time
    tmp_path = Path(tmp_path)
    h5 = tmp_path / f"{name}.h5"
    nml = tmp_path / f"{name}.nml"
    nml.write_text(namelist(h5.name, **groups))
    proc = subprocess.Popen([mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), str(nml)], cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = 0
    deadline = time.time() + 120
    while seen < lines and time.time() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        seen += line.startswith("t =")
    if seen < lines:
        proc.kill()
        raise AssertionError("the run did not get going")
    return proc, h5


def run_and_read(tmp_path, name, **kw):
    proc, h5 = run(tmp_path, name, **kw)
    return proc, read_run(str(h5))


# The series a restart must continue (restart tests): the first two groups
# as the run that went through does, the states to the solver's round-off
# (a restart starts the solver's aids afresh: the Newton remainder, the
# coarse preconditioner, the inner guesses, where the run went on with
# them through its output steps), the counts exactly; the iteration counts
# may differ by those aids.
SERIES = ["time", "position", "velocity", "energy/kinetic", "energy/stretch", "energy/bend",
          "energy/dissipated", "energy/external_work", "diagnostics/momentum", "diagnostics/steps",
          "diagnostics/rejected_steps", "diagnostics/newton_iterations", "diagnostics/linear_iterations"]
EXACT = ["time", "diagnostics/steps", "diagnostics/rejected_steps"]
STATES = ["position", "velocity", "energy/kinetic", "energy/stretch", "energy/bend", "energy/dissipated",
          "energy/external_work", "diagnostics/momentum"]


def assert_same_run(a, b, rtol):
    """Series a and b (series()) of one run: the output times and step
    counts equal, every state series within rtol of its largest value."""
    assert a.keys() == b.keys()
    for k in EXACT:
        if k in a:
            assert a[k].shape == b[k].shape and np.array_equal(a[k], b[k]), k
    for k in STATES:
        if k in a:
            assert a[k].shape == b[k].shape, k
            scale = max(float(np.abs(a[k]).max()), 1e-300)
            err = float(np.abs(a[k] - b[k]).max()) / scale
            assert err <= rtol, (k, err)


def series(h5):
    """The stored output steps of SERIES in h5, and the file's status."""
    with h5py.File(h5, "r") as f:
        n = int(f.attrs["n_output_steps"])
        return {k: f[k][:n] for k in SERIES if k in f}, f.attrs["status"].decode()


def jacobian_ratios(text):
    """All ||J - Jfd||_F/||J||_F values printed by -snes_test_jacobian."""
    return [float(m) for m in re.findall(r"\|\|J - Jfd\|\|_F/\|\|J\|\|_F = ([0-9.eE+-]+)", text)]


# The line contact's check prints at each output time (module contact_model,
# its accepted hook): t, active pairs, total force (3), smallest gap now and over
# the run, states checked.
CONTACT_LINE = re.compile(r"contact: t = (\S+), active = (\d+), force = (\S+) (\S+) (\S+), min gap = (\S+), "
                          r"min gap of all accepted states = (\S+), states checked = (\d+)")


def contact_lines(stdout):
    """The contact lines of a run's stdout, each a tuple of floats in CONTACT_LINE's order."""
    return [tuple(float(v) for v in m.groups()) for m in CONTACT_LINE.finditer(stdout)]


def contact_sheet(contact, t_end, out_dt, n=7, dt=1e-3, gravity=(0.0, 0.0, -9.81), masses="area",
                  omega=None, units=None):
    """The groups of `run` for drop_table's cloth (input/drop_table.nml: 1 m x
    1 m, 0.1 kg, E = 100 N/m, energy bending) on an n x n lattice, flat at
    z = 0 and at rest (or spinning about z at omega [1/s]), with the &contact
    group `contact` (its keys as text). gravity [m/s^2]; masses: the
    mass_distribution; units: &scene units, or None for the scene's."""
    scene = "scene='flat' gravity=" + ",".join(repr(float(g)) for g in gravity)
    if omega is not None:
        scene += f" initial_omega=0.0,0.0,{omega}"
    if units is not None:
        scene += f" units='{units}'"
    return dict(
        scene=scene,
        lattice=f"nx={n} ny={n} lx=1.0 ly=1.0 total_mass=0.1 mass_distribution='{masses}'",
        material="e_s=100.0 eta_s=0.1 e_d=100.0 eta_d=0.1 bending_model='energy' k_b=0.1 eta_b=1e-4",
        contact=contact,
        time=f"t_end={t_end} dt={dt}",
        output=f"output_interval={out_dt}",
    )


def plane_below(h, mu=0.0, dhat=1e-3, kappa=1.0, eps_v=None):
    """&contact text: one plane z = -h (normal +z) with friction mu, the
    barrier's reach dhat and stiffness kappa, friction_eps_v if given."""
    text = (f"n_obstacles=1 obstacle_shape(1)='plane' obstacle_point(:,1)=0.0,0.0,{-h!r} "
            f"obstacle_normal(:,1)=0.0,0.0,1.0 obstacle_mu(1)={mu} contact_dhat={dhat} contact_stiffness={kappa}")
    return text + (f" friction_eps_v={eps_v}" if eps_v is not None else "")
