# SPDX-License-Identifier: BSD-2-Clause
"""The one reader of nuno output files (HDF5 layout of docs/model.md section 9).

    from nuno.reader import read_run
    run = read_run("run.h5")
    run.position        # [nt][ny][nx][3], float64, read lazily (Steps)
    run.position[k]     # one step [ny][nx][3]: reads only that step
    run.energy_balance()
    run.contact         # /contact of a scene with obstacles ({} without)

Positions and velocities stay in the file: ``run.position`` is a ``Steps``
view of the open HDF5 dataset, and indexing it reads only the steps asked
for, so a 1025 x 1025 run of hundreds of steps can be plotted step by step in
bounded memory. ``np.asarray(run.position)`` (and arithmetic or numpy
functions on it) read every step: fine for small files. The file stays open
until ``run.close()`` (or the end of a ``with read_run(...) as run:`` block).
Time, energies and diagnostics (one number per step) are read at once.

Arrays are C order as stored: /position[t] is [ny][nx][3] (node (i, j) is
position[t, j, i]). A run that was killed may leave datasets longer than the
steps it completed: only the first ``n_output_steps`` steps are read (root
attribute, updated after each step is completely written); without that
attribute, the shortest length over the time-dependent datasets.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import h5py
import numpy as np
from numpy.lib.mixins import NDArrayOperatorsMixin

ENERGY_NAMES = ("kinetic", "stretch", "bend", "dissipated", "external_work")
# Energies of a scene with obstacles only (docs/model.md section 10): the
# barrier energy of the nodes and, with an obstacle other than a plane, of
# the cloth's triangles and edges, potential energies of the balance.
CONTACT_ENERGY_NAMES = ("barrier", "barrier_faces")
# /contact: scenes with obstacles only.
CONTACT_NAMES = ("active", "force", "normal_force", "friction_work", "barrier_energy",
                 "min_gap", "min_gap_run", "states_checked")
DIAGNOSTIC_NAMES = ("momentum", "angular_momentum", "length", "flatness",
                    "steps", "rejected_steps", "newton_iterations",
                    "linear_iterations")
# Files written before the root attribute ``units`` existed: the report
# scenes (and flat) are in mm, g, s (docs/model.md section 7), hang in SI.
MM_SCENES = ("lift_release", "bend_release", "wave_point", "flat")
# Length unit of each unit system the program writes (root attribute units).
UNIT_SYSTEM_LENGTH = {"mm g s": "mm", "si": "m"}
_REQUIRED_ATTRS = ("nx", "ny")
_REQUIRED_DATASETS = ("time", "position", "lattice/rest_position")


def _text(value) -> str:
    """An attribute as str: h5py gives str, bytes, numpy bytes or 1-element arrays."""
    if value is None:
        return ""
    if isinstance(value, np.ndarray):
        if value.size == 0:
            return ""
        value = value.ravel()[0] if value.size == 1 else b"".join(
            v if isinstance(v, bytes) else str(v).encode() for v in value.ravel())
    if isinstance(value, (bytes, np.bytes_)):
        value = bytes(value).decode("utf-8", errors="replace")
    # Fortran fixed-length strings are padded with blanks or NULs.
    return str(value).rstrip("\x00 ")


def _attrs(obj) -> dict:
    """Attributes of a group as str, Python scalars or 1-D arrays."""
    out = {}
    for key, value in obj.attrs.items():
        if isinstance(value, (bytes, np.bytes_, str)):
            out[key] = _text(value)
        elif np.ndim(value) == 0:
            out[key] = np.asarray(value).item()
        else:
            out[key] = np.asarray(value)
    return out


def _small_group(f, name: str) -> dict:
    """A group of small datasets (/identify, /control) read at once, with its
    attributes: {name: array or list of str}; {} when absent."""
    if name not in f:
        return {}
    out = _attrs(f[name])
    for key, ds in f[name].items():
        value = ds[()]
        if ds.dtype.kind in "SO":
            value = [_text(v) for v in np.ravel(value)]
        out[key] = value
    return out


def _int(value) -> int:
    """An integer attribute (scalar or 1-element array, as Fortran may write)."""
    return int(np.asarray(value).ravel()[0])


class Steps(NDArrayOperatorsMixin):
    """The first ``nt`` steps of a time-dependent dataset, read on demand.

    Indexing reads only what is asked for: ``steps[k]`` one step, ``steps[a:b]``
    a range, ``steps[k, j, i]`` one node. ``len``, ``shape``, ``ndim`` and
    ``dtype`` cost nothing; ``np.asarray(steps)``, iteration over whole-array
    arithmetic and numpy functions read every step (float64).
    """

    def __init__(self, dataset, nt: int):
        self._ds = dataset
        self._nt = int(nt)
        self.shape = (self._nt,) + tuple(dataset.shape[1:])
        self.ndim = len(self.shape)
        self.dtype = np.dtype(np.float64)
        self.reads = 0  # number of h5py reads so far (tests count them)

    def __len__(self) -> int:
        return self._nt

    def _read(self, key):
        self.reads += 1
        return np.asarray(self._ds[key], dtype=np.float64)

    def __getitem__(self, key):
        head, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        if head is Ellipsis:
            if not rest:
                return self._read(slice(0, self._nt))
            head, rest = slice(None), (Ellipsis,) + rest
        if isinstance(head, (int, np.integer)):
            k = int(head)
            if not -self._nt <= k < self._nt:
                raise IndexError(f"step {k} out of range for {self._nt} steps")
            return self._read((k % self._nt,) + rest)
        if isinstance(head, slice):
            start, stop, step = head.indices(self._nt)
            if step == 1:
                return self._read((slice(start, max(start, stop)),) + rest)
            head = np.arange(start, stop, step)
        idx = np.asarray(head)
        if idx.dtype == bool:
            idx = np.nonzero(idx)[0]
        idx = idx.astype(np.int64).ravel()
        if idx.size and (idx.min() < -self._nt or idx.max() >= self._nt):
            raise IndexError(f"step index out of range for {self._nt} steps")
        idx %= max(self._nt, 1)
        # h5py wants increasing unique indices: read those, then reorder.
        uniq, inverse = np.unique(idx, return_inverse=True)
        block = (np.stack([self._read((int(k),) + rest) for k in uniq])
                 if uniq.size else self._read((slice(0, 0),) + rest))
        out = block[inverse]
        return out.reshape(np.asarray(head).shape + out.shape[1:]) if np.ndim(head) > 1 else out

    def __iter__(self):
        for k in range(self._nt):
            yield self[k]

    def __array__(self, dtype=None, copy=None):
        a = self._read(slice(0, self._nt))
        return a if dtype is None else a.astype(dtype, copy=False)

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        inputs = tuple(np.asarray(x) if isinstance(x, Steps) else x for x in inputs)
        return getattr(ufunc, method)(*inputs, **kwargs)

    def __repr__(self) -> str:
        return f"Steps(shape={self.shape}, dataset={self._ds.name!r})"


@dataclass
class Run:
    """One nuno run, truncated to its completely written output steps."""

    path: str
    nx: int
    ny: int
    n_ranks: int | None
    program_version: str
    namelist: str
    petsc_options: str
    status: str
    complete: bool
    time: np.ndarray                 # [nt]
    position: Steps                  # [nt][ny][nx][3], read on demand
    velocity: Steps | None           # [nt][ny][nx][3] or None
    rest_position: np.ndarray        # [ny][nx][3]
    mass: np.ndarray | None          # [ny][nx]
    energy: dict = field(default_factory=dict)       # name -> [nt]
    diagnostics: dict = field(default_factory=dict)  # name -> [nt] or [nt][3]
    n_stored: int = 0                # longest stored length (>= nt if killed)
    unit_system: str = ""            # root attribute units ('mm g s', 'SI'); '' in old files
    run_info: dict = field(default_factory=dict)   # attributes of /run (provenance)
    wall_time: np.ndarray | None = None            # [nt] wall seconds at each output step
    config: dict = field(default_factory=dict)     # /config: {group: {key: value}}, the resolved keys
    identify: dict = field(default_factory=dict)   # /identify of an identification run: {dataset: array}, names as str
    control: dict = field(default_factory=dict)    # /control of a control run: {dataset: array} + its attributes
    contact: dict = field(default_factory=dict)    # /contact of a scene with obstacles: name -> [nt] or [nt][3]; {} without
    file: h5py.File | None = field(default=None, repr=False)  # kept open for Steps

    def close(self) -> None:
        """Close the HDF5 file (position and velocity can no longer be read)."""
        if self.file is not None:
            self.file.close()
            self.file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @property
    def nt(self) -> int:
        """Number of complete output steps."""
        return int(self.time.shape[0])

    def status_line(self) -> str | None:
        """The one-line notice for a run that did not finish, else None."""
        if self.complete:
            return None
        return (f"run did not finish: status={self.status}; "
                f"using {self.nt} complete output steps")

    def energy_balance(self) -> np.ndarray:
        """E_kin + E_stretch + E_bend (+ E_barrier) + E_dissipated - W_external
        per step. With obstacles the barrier energy (the nodes' and the
        faces' and edges') is a potential energy and the friction work is
        part of E_dissipated (docs/model.md section 10)."""
        missing = [n for n in ENERGY_NAMES if n not in self.energy]
        if missing:
            raise ValueError(f"{self.path}: energy datasets missing: {', '.join(missing)}")
        e = self.energy
        b = (e["kinetic"] + e["stretch"] + e["bend"] + e["dissipated"]
             - e["external_work"])
        for n in CONTACT_ENERGY_NAMES:
            if n in e:
                b = b + e[n]
        return b

    def scene(self) -> str | None:
        """The scene named in the echoed namelist (``scene = '...'``), if any."""
        m = re.search(r"\bscene\s*=\s*['\"]\s*([A-Za-z0-9_]+)", self.namelist,
                      re.IGNORECASE)
        return m.group(1).lower() if m else None

    def units(self) -> str:
        """Length unit for labels, from the unit system the program recorded
        (root attribute ``units``: 'mm g s' -> 'mm', 'SI' -> 'm').

        Files without that attribute (older versions, synthetic files): an
        explicit ``units = '...'`` entry in the namelist, else a guess from
        the scene: 'mm' for lift_release, bend_release, wave_point and flat,
        'm' for hang or anything else.
        """
        system = self.unit_system.strip().lower()
        if system in UNIT_SYSTEM_LENGTH:
            return UNIT_SYSTEM_LENGTH[system]
        if system:
            return self.unit_system.split()[0]   # a system this reader does not know: its first word
        m = re.search(r"\bunits\s*=\s*['\"]?\s*([A-Za-z]+)", self.namelist,
                      re.IGNORECASE)
        if m:
            return m.group(1).lower()
        return "mm" if self.scene() in MM_SCENES else "m"

    def step_index(self, t: float) -> int:
        """Index of the output step nearest to time t; ValueError outside the run."""
        if self.nt == 0:
            raise ValueError(f"{self.path}: no complete output steps")
        t0, t1 = float(self.time[0]), float(self.time[-1])
        slack = 1e-9 * max(1.0, abs(t0), abs(t1))
        if not (t0 - slack <= t <= t1 + slack):
            raise ValueError(f"time {t:g} outside the run's output times "
                             f"[{t0:g}, {t1:g}]")
        return int(np.argmin(np.abs(self.time - t)))

    def position_at(self, t: float) -> np.ndarray:
        """Position [ny][nx][3] at time t, linear between output steps."""
        self.step_index(t)  # range check
        k = int(np.searchsorted(self.time, t))
        if k == 0:
            return self.position[0].copy()
        if k >= self.nt:
            return self.position[-1].copy()
        ta, tb = self.time[k - 1], self.time[k]
        w = 0.0 if tb == ta else (t - ta) / (tb - ta)
        return (1.0 - w) * self.position[k - 1] + w * self.position[k]


def read_run(path, load_velocity: bool = True) -> Run:
    """Read a nuno output file; FileNotFoundError or ValueError with a message."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path}: not an HDF5 file ({exc})") from None
    try:
        missing = [a for a in _REQUIRED_ATTRS if a not in f.attrs]
        missing += [d for d in _REQUIRED_DATASETS if d not in f]
        if missing:
            raise ValueError(f"{path}: not a nuno output file "
                             f"(missing {', '.join(missing)})")
        attrs = f.attrs
        nx, ny = _int(attrs["nx"]), _int(attrs["ny"])

        # Time-dependent datasets and their stored lengths.
        timed = {"time": f["time"], "position": f["position"]}
        if load_velocity and "velocity" in f:
            timed["velocity"] = f["velocity"]
        for group, names in (("energy", ENERGY_NAMES), ("diagnostics", DIAGNOSTIC_NAMES)):
            for name in names:
                key = f"{group}/{name}"
                if key in f:
                    timed[key] = f[key]
        lengths = [ds.shape[0] if ds.shape else 0 for ds in timed.values()]
        shortest, n_stored = min(lengths), max(lengths)
        if "n_output_steps" in attrs:
            nt = min(_int(attrs["n_output_steps"]), shortest)
        else:
            nt = shortest
        nt = max(nt, 0)

        # One number (or vector) per step: small, read now. Fields: lazily.
        data = {key: np.asarray(ds[:nt]) for key, ds in timed.items()
                if key not in ("position", "velocity")}
        pos = Steps(f["position"], nt)
        if pos.shape[1:] != (ny, nx, 3):
            raise ValueError(f"{path}: /position has shape {pos.shape}, "
                             f"expected [nt][{ny}][{nx}][3]")
        vel = Steps(timed["velocity"], nt) if "velocity" in timed else None
        rest = np.asarray(f["lattice/rest_position"][()], dtype=np.float64)
        if rest.shape != (ny, nx, 3):
            raise ValueError(f"{path}: /lattice/rest_position has shape "
                             f"{rest.shape}, expected [{ny}][{nx}][3]")
        mass = np.asarray(f["lattice/mass"][()]) if "lattice/mass" in f else None
        run_info = _attrs(f["run"]) if "run" in f else {}
        config = {g: _attrs(f["config"][g]) for g in f["config"]} if "config" in f else {}
        identify = _small_group(f, "identify")
        control = _small_group(f, "control")
        # Contact series (scenes with obstacles): their first nt steps. A
        # file continued from a version without them holds NaN (counts: -1)
        # for the steps before the restart.
        contact = {n: np.asarray(f[f"contact/{n}"][:nt]) for n in CONTACT_NAMES
                   if f"contact/{n}" in f}
        energy = {n: data[f"energy/{n}"] for n in ENERGY_NAMES if f"energy/{n}" in data}
        energy.update({n: np.asarray(f[f"energy/{n}"][:nt]) for n in CONTACT_ENERGY_NAMES
                       if f"energy/{n}" in f})
        wall_time = None
        if "wall_time" in f:
            wall_time = np.asarray(f["wall_time"][:nt], dtype=np.float64)

        status = _text(attrs.get("status")) or "unknown"
        return Run(
            path=path, nx=nx, ny=ny,
            n_ranks=_int(attrs["n_ranks"]) if "n_ranks" in attrs else None,
            program_version=_text(attrs.get("program_version")),
            namelist=_text(attrs.get("namelist")),
            petsc_options=_text(attrs.get("petsc_options")),
            status=status,
            complete=status.strip().lower() == "complete",
            time=data["time"].astype(np.float64, copy=False),
            position=pos,
            velocity=vel,
            rest_position=rest,
            mass=mass,
            energy=energy,
            diagnostics={n: data[f"diagnostics/{n}"] for n in DIAGNOSTIC_NAMES
                         if f"diagnostics/{n}" in data},
            n_stored=n_stored,
            unit_system=_text(attrs.get("units")),
            run_info=run_info,
            wall_time=wall_time,
            config=config,
            identify=identify,
            control=control,
            contact=contact,
            file=f,
        )
    except BaseException:
        f.close()
        raise


def read_states(path) -> tuple[np.ndarray, np.ndarray]:
    """(time [nt], position [nt][ny][nx][3]) of an observed or target file
    (&identify observed_file, &control target_file): a nuno output file or
    a plain HDF5 file with /time and /position."""
    try:
        run = read_run(path, load_velocity=False)
    except ValueError:
        with h5py.File(path, "r") as f:
            if "time" not in f or "position" not in f:
                raise ValueError(f"{path}: an observed or target file needs /time and /position") from None
            return np.asarray(f["time"][()], float), np.asarray(f["position"][()], float)
    with run:
        return np.asarray(run.time, float), np.asarray(run.position)
