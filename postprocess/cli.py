# SPDX-License-Identifier: BSD-2-Clause
"""Shared command-line plumbing: error exits, run loading, common options."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .reader import Run, read_run


class UsageError(ValueError):
    """A bad argument found after parsing (reported as 'error: ...', exit 1)."""


def run_main(body, args) -> int:
    """Call body(args); turn expected errors into one stderr line and exit 1."""
    try:
        body(args)
    except (FileNotFoundError, ValueError, OSError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"error: {msg}", file=sys.stderr)
        return 1
    return 0


def load_run(path, min_steps: int = 1) -> Run:
    """read_run plus the one-line notice for unfinished runs (on stderr)."""
    run = read_run(path)
    line = run.status_line()
    if line:
        print(line, file=sys.stderr)
    if run.nt < min_steps:
        raise ValueError(f"{path}: {run.nt} complete output steps, "
                         f"need at least {min_steps}")
    return run


def parser(description: str, prog: str) -> argparse.ArgumentParser:
    """The parser of a script, its usage naming the console script (nuno-<prog>)."""
    return argparse.ArgumentParser(prog=script_name(prog), description=description)


def script_name(prog: str) -> str:
    """The console script of module prog (pyproject.toml): nuno-report-figures for report_figures."""
    return "nuno-" + prog.replace("_", "-")


def add_output(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("-o", "--output", default=None,
                   help=f"output file (default: <input stem>_{what}.png; "
                        "the format follows the extension)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")


def default_output(input_path, what: str, ext: str = ".png") -> str:
    return f"{Path(input_path).stem}_{what}{ext}"


def run_value(run, key: str):
    """The value of namelist key in a run: the resolved /config (which holds
    -nuno_set overrides), else the echoed namelist; nx, ny and dt from the
    run's own record. KeyError naming the key and the file otherwise."""
    name = key.lower().rpartition("%")[2]
    group = key.lower().rpartition("%")[0]
    if name in ("nx", "ny"):
        return getattr(run, name)
    if name == "dt" and run.run_info.get("dt") is not None:
        return float(run.run_info["dt"])
    for g, values in run.config.items():
        if (not group or g == group) and name in values:
            return values[name]
    try:
        import f90nml  # only for files without /config (older or synthetic)
        nml = f90nml.reads(run.namelist)
        for g in nml:
            if (not group or g == group) and name in nml[g]:
                return nml[g][name]
    except Exception:  # an unreadable echoed namelist: no value from it
        pass
    raise KeyError(f"{run.path}: no key {key!r} in /config or the namelist")


def gravity(run):
    """The gravity vector [3] of the run's &scene (/config, else the echoed
    namelist), or None where the file does not say."""
    try:
        value = run_value(run, "gravity")
    except KeyError:
        return None
    g = np.ravel(np.asarray(value, dtype=float))
    return g[:3] if g.size >= 3 else None


def text_value(value) -> str:
    """A namelist value as a label: numbers in %g (1000.0 -> 1000), text stripped."""
    value = value.item() if hasattr(value, "item") else value
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, float):
        return f"{value:g}"
    return str(value).strip()


# The unit of each namelist key that has one, as `nuno --list-keys` prints it
# (its 'unit' column: a dimension in the file's unit system); the test
# tests/python/test_plot_labels.py checks this table against the program's.
KEY_DIMENSIONS = {
    "lx": "length", "ly": "length", "total_mass": "mass",
    "e_s": "force/length", "eta_s": "force time/length", "e_d": "force/length",
    "eta_d": "force time/length", "k_b": "paper: force/rad; energy: energy",
    "eta_b": "energy time", "gravity": "length/time^2", "lift_length": "length",
    "lift_height": "length", "bend_angle": "degree", "keyframe_time": "time",
    "keyframe_dx": "length", "keyframe_dy": "length", "keyframe_dz": "length",
    "release_time": "time", "initial_omega": "rad/time", "t_end": "time", "dt": "time",
    "output_interval": "time", "stretch_limit": "1", "checkpoint_interval": "time",
    "fit_lower": "as the parameter", "fit_upper": "as the parameter", "tikhonov": "length^2",
    "max_speed": "length/time", "velocity_weight": "time^2", "keyframe_tikhonov": "1",
    "obstacle_point": "length", "obstacle_normal": "1", "obstacle_radius": "length",
    "obstacle_half_size": "length", "obstacle_axis": "1", "obstacle_end": "length",
    "obstacle_time": "time", "obstacle_offset": "length", "obstacle_close": "length",
    "obstacle_close_dir": "1", "obstacle_mu": "1", "contact_thickness": "length",
    "contact_dhat": "length", "contact_stiffness": "force/length",
    "friction_eps_v": "length/time", "self_mu": "1",
}
# A dimension as a unit: (mm g s, SI). '' for none.
DIMENSION_UNITS = {
    "length": ("mm", "m"), "mass": ("g", "kg"), "time": ("s", "s"),
    "force/length": ("g/s$^2$", "N/m"), "force time/length": ("g/s", "N s/m"),
    "force/rad": ("g mm/s$^2$/rad", "N/rad"), "energy": ("g mm$^2$/s$^2$", "J"),
    "energy time": ("g mm$^2$/s", "J s"), "length/time^2": ("mm/s$^2$", "m/s$^2$"),
    "length/time": ("mm/s", "m/s"), "rad/time": ("rad/s", "rad/s"), "degree": ("°", "°"),
    "length^2": ("mm$^2$", "m$^2$"), "time^2": ("s$^2$", "s$^2$"), "1": ("", ""),
    "as the parameter": ("", ""),
}


def key_unit(run, key: str) -> str:
    """The unit of namelist key in run's unit system ('' for none or unknown):
    'N/m' for e_s of an SI file, 'g/s$^2$' in mm g s; k_b's follows the
    bending model (paper: force per radian, energy: an energy)."""
    name = key.lower().rpartition("%")[2].split("(")[0]
    dim = KEY_DIMENSIONS.get(name)
    if dim is None:
        return ""
    if dim.startswith("paper:"):
        try:
            model = text_value(run_value(run, "bending_model"))
        except KeyError:
            model = "paper"
        dim = "energy" if model == "energy" else "force/rad"
    system = getattr(run, "unit_system", None)
    si = system == "SI" if system in ("SI", "mm g s") else run.units() == "m"
    return DIMENSION_UNITS.get(dim, ("", ""))[1 if si else 0]


def key_label(run, key: str) -> str:
    """'e_s = 100 N/m': a swept key's value with its unit."""
    unit = key_unit(run, key)
    value = text_value(run_value(run, key))
    return f"{key} = {value}" + (f" {unit}" if unit and unit != "°" else unit)


def run_labels(runs, label_key: str | None = None, labels=None) -> list[str]:
    """Legend labels: given ones, 'key = value unit' of a swept key, else file stems."""
    if labels:
        if len(labels) != len(runs):
            raise UsageError(f"--labels: {len(labels)} labels for {len(runs)} runs")
        return list(labels)
    if label_key:
        return [key_label(r, label_key) for r in runs]
    names = [Path(r.path).stem for r in runs]
    if len(set(names)) < len(names):
        names = [f"{k + 1}: {n}" for k, n in enumerate(names)]
    return names


def add_label_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--label", default=None, metavar="KEY",
                   help="label each run by the value of this namelist key (a swept one: "
                        "e_s, nx, dt, ...); default: the file names")
    p.add_argument("--labels", nargs="+", default=None, metavar="TEXT",
                   help="the legend's labels, one per run")
