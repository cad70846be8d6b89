# SPDX-License-Identifier: BSD-2-Clause
"""Run the report's three scenes and draw its Figs. 3-5 (paper and energy models side by side).

    nuno-report-figures                 # run all scenes, then plot
    nuno-report-figures --skip-run      # re-plot runs/report/*.h5
    nuno-report-figures --quick --outdir /tmp/f --rundir /tmp/r

Each scene runs from its namelist in input/ (the paper model, our reading of
the report, and the `_energy` variant with the corrected bending model); a
copy of the namelist with the output file and any overrides (--quick, --set)
goes into --rundir beside the run's .h5 and .log. Figures: side views (x-z,
equal scales, mm) of the cloth at several times coloured by time for Figs. 3
and 4, 3-D wireframes per time for Fig. 5, plus the diagnostics that the
report's discussion (its section 5) is about.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import time as clock
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import cli, namelist, plotting
from .snapshots import choose_steps

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Case:
    """One run: input/<name>.nml, written to <rundir>/<name>.h5."""

    name: str
    scene: str
    label: str


PAPER, ENERGY, NONE = "paper model (report)", "energy model", "no bending (report)"
FIGURES = {
    "fig3_lift_release": (Case("lift_release", "lift_release", PAPER),
                          Case("lift_release_energy", "lift_release", ENERGY)),
    "fig4_bend_release": (Case("bend_release", "bend_release", PAPER),
                          Case("bend_release_energy", "bend_release", ENERGY)),
    "fig5_wave_point": (Case("wave_point", "wave_point", NONE),
                        Case("wave_point_energy", "wave_point", ENERGY)),
}
# Times shown [s] (the nearest output step; clipped to the run's last time).
TIMES = {
    "fig3_lift_release": (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0),
    "fig4_bend_release": (0.0, 0.2, 0.4, 0.6, 1.2),
    "fig5_wave_point": (0.5, 0.8, 1.0, 1.5, 3.0),
}
# --quick: 7 x 7 lattices, dt 5 ms and short runs (tests, a first look).
QUICK = {"nx": "7", "ny": "7", "dt": "5.0e-3"}
QUICK_T_END = {"lift_release": "0.4", "bend_release": "0.4", "wave_point": "1.2"}
# Keys whose change alters the link length ax that the energy k_b is scaled by.
_AX_KEYS = ("nx", "lx")


class RunError(RuntimeError):
    """A solver run that failed (message names the run and its log)."""


# ------------------------------------------------------------------ namelists


def set_key(text: str, key: str, value: str) -> str:
    """The namelist text with key's value replaced (key must be in the file; f90nml)."""
    try:
        return namelist.set_key(text, key, value)
    except ValueError as exc:
        raise ValueError(f"--set {exc} (only keys written in the input file can be set)") from None


def drop_key(text: str, key: str) -> str:
    """The namelist text without key (if it is there; f90nml)."""
    return namelist.drop_key(text, key)


def parse_sets(items) -> dict:
    """--set KEY=VALUE items as an ordered dict."""
    out = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or not re.fullmatch(r"[A-Za-z_]\w*(\(\d+\))?", key.strip()) or not value.strip():
            raise ValueError(f"--set {item!r}: expected KEY=VALUE, e.g. nx=7")
        out[key.strip()] = value.strip()
    return out


def case_namelist(case: Case, overrides: dict, quick: bool) -> str:
    """input/<case>.nml with the output file, --quick and --set applied."""
    text = (REPO / "input" / f"{case.name}.nml").read_text()
    keys = dict(QUICK, t_end=QUICK_T_END[case.scene]) if quick else {}
    keys.update(overrides)
    drop = ()
    if any(k.lower() in _AX_KEYS for k in keys) and "k_b" not in keys:
        # The energy files set k_b = 1 * ax for 11 x 11; let the program's
        # default conversion (input/README.md) rescale it for the new ax.
        drop = ("k_b",)
    keys["output_file"] = f"'{case.name}.h5'"
    try:
        return namelist.edit(text, keys, drop)
    except ValueError as exc:
        raise ValueError(f"--set {exc} (only keys written in the input file can be set)") from None


# ------------------------------------------------------------------ runs


def run_case(case: Case, nml_text: str, rundir: Path, exe: str, nranks: int,
             mpiexec: list) -> Path:
    """Run one case in rundir; the .h5 path, or RunError with the log's tail."""
    nml = rundir / f"{case.name}.nml"
    log = rundir / f"{case.name}.log"
    h5 = rundir / f"{case.name}.h5"
    nml.write_text(nml_text)
    h5.unlink(missing_ok=True)
    cmd = mpiexec + ["-n", str(nranks), "--oversubscribe", exe, nml.name]
    with log.open("w") as out:
        out.write("$ " + shlex.join(cmd) + "\n")
        out.flush()
        proc = subprocess.run(cmd, cwd=rundir, stdout=out, stderr=subprocess.STDOUT)
    if proc.returncode != 0 or not h5.is_file():
        lines = log.read_text(errors="replace").splitlines()
        # The program's own messages say why; the launcher's backtraces do not.
        said = list(dict.fromkeys(ln for ln in lines if "error" in ln.lower()
                                  and not ln.startswith(("#", "$", "Error termination"))))
        why = "\n".join(said[:5] or lines[-8:])
        raise RunError(f"run {case.name} failed (exit {proc.returncode}); "
                       f"see {log}:\n{why}")
    return h5


def load(path: Path):
    """A finished run (RunError if it did not finish)."""
    run = cli.load_run(path, min_steps=1)
    if not run.complete:
        raise RunError(f"{path}: run did not finish (status={run.status})")
    return run


# ------------------------------------------------------------------ figures


def _steps(run, times, unique: bool = True) -> list[int]:
    """Output steps nearest to times, clipped to the run (order kept)."""
    last = float(run.time[-1])
    steps = choose_steps(run, [min(float(t), last) for t in times])
    return list(dict.fromkeys(steps)) if unique else steps


def _centroid_fixed(run, k):
    """Position at step k shifted so the centroid stays where it was at t = 0."""
    c0 = run.position[0].reshape(-1, 3).mean(axis=0)
    ck = run.position[k].reshape(-1, 3).mean(axis=0)
    return run.position[k] - (ck - c0)


def _side_panels(fig, runs, labels, times, shift_centroid=False):
    """Top row: one x-z side view per run, states coloured by time.

    Each panel has its own limits (x and z on one scale): the paper model's
    excursions would otherwise flatten the energy model's shapes to a line.
    The panels are the same size: the limits grow to fill each box
    (adjustable="datalim") instead of the box shrinking to the data.
    """
    steps = [_steps(run, times) for run in runs]
    shapes = [[(_centroid_fixed(run, k) if shift_centroid else run.position[k], run.time[k])
               for k in ks] for run, ks in zip(runs, steps)]
    t_all = [t for s in shapes for _, t in s]
    color, mappable = plotting.time_colormap(min(t_all), max(t_all))
    axes = []
    n = len(runs)
    # One box shape for all panels (the tallest data ratio, within [0.3, 1]):
    # each panel's limits are widened around its shapes to that ratio.
    boxes = []
    for shape in shapes:
        lo, hi = plotting.bounds(*(p for p, _ in shape))
        pad = 0.04 * max(hi[0] - lo[0], hi[2] - lo[2])
        boxes.append((lo[0] - pad, hi[0] + pad, lo[2] - pad, hi[2] + pad))
    ratio = min(1.0, max(0.3, max((z1 - z0) / (x1 - x0) for x0, x1, z0, z1 in boxes)))
    for col, (run, label, shape) in enumerate(zip(runs, labels, shapes)):
        ax = fig.add_subplot(2, n, col + 1)
        for pos, t in shape:
            plotting.draw_lattice_side(ax, pos, color=color(t), linewidth=0.7)
        x0, x1, z0, z1 = boxes[col]
        w, h = x1 - x0, z1 - z0
        if h < ratio * w:
            zc, h = 0.5 * (z0 + z1), ratio * w
            z0, z1 = zc - 0.5 * h, zc + 0.5 * h
        else:
            xc, w = 0.5 * (x0 + x1), h / ratio
            x0, x1 = xc - 0.5 * w, xc + 0.5 * w
        ax.set_xlim(x0, x1)
        ax.set_ylim(z0, z1)
        ax.set_aspect("equal")
        ax.set_xlabel(plotting.length_label("x", run.units()))
        ax.set_ylabel(plotting.length_label("z", run.units()))
        ax.set_title(label)
        ax.grid(True, alpha=0.3)
        axes.append(ax)
    fig.colorbar(mappable, ax=axes, label="t [s]", shrink=0.9, pad=0.02)
    return axes, steps


def _series_panel(ax, runs, labels, values, ylabel, steps=None, log=False):
    """A diagnostic against time for each run; dots at the times drawn above."""
    for i, (run, label, y) in enumerate(zip(runs, labels, values)):
        ax.plot(run.time, y, color=f"C{i}", label=label)
        if steps is not None:
            ks = steps[i]
            ax.plot(run.time[ks], np.asarray(y)[ks], "o", color=f"C{i}", ms=3)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")


def _positive(y):
    """y for a log axis: values below 1e-6 of the largest left out (NaN)."""
    y = np.asarray(y, dtype=float)
    return np.where(y > 1e-6 * np.nanmax(y), y, np.nan)


def build_fig3(runs, labels, times=TIMES["fig3_lift_release"]):
    """Fig. 3 (lift_release): side views per model; centre-line length; E_kin."""
    n = len(runs)
    fig = plotting.blank_figure((5.2 * n, 7.0))
    _, steps = _side_panels(fig, runs, labels, times)
    units = runs[0].units()
    bottom = fig.add_subplot(2, 2, 3), fig.add_subplot(2, 2, 4)
    _series_panel(bottom[0], runs, labels, [r.diagnostics["length"] for r in runs],
                  plotting.length_label("centre-line length", units), steps)
    _series_panel(bottom[1], runs, labels,
                  [_positive(r.energy["kinetic"]) for r in runs],
                  "kinetic " + plotting.quantity_label("energy", units), steps, log=True)
    fig.suptitle("Fig. 3 scene: one edge lifted 15 mm, then released "
                 "(edge x = 0 pinned; side view, dots: times drawn)")
    return fig


def build_fig4(runs, labels, times=TIMES["fig4_bend_release"]):
    """Fig. 4 (bend_release): side views (centroid drift removed); flatness; centroid z."""
    n = len(runs)
    fig = plotting.blank_figure((5.2 * n, 7.0))
    _, steps = _side_panels(fig, runs, labels, times, shift_centroid=True)
    units = runs[0].units()
    bottom = fig.add_subplot(2, 2, 3), fig.add_subplot(2, 2, 4)
    _series_panel(bottom[0], runs, labels, [r.diagnostics["flatness"] for r in runs],
                  plotting.length_label("flatness", units), steps)
    _series_panel(bottom[1], runs, labels,
                  [r.position[..., 2].mean(axis=(1, 2)) for r in runs],
                  plotting.length_label("centroid z", units), steps)
    fig.suptitle("Fig. 4 scene: bent into a 30° arc, released, nothing held "
                 "(side view, shapes shifted to the t = 0 centroid)")
    return fig


def build_fig5(runs, labels, times=TIMES["fig5_wave_point"]):
    """Fig. 5 (wave_point): 3-D wireframes, one row per run, one column per time."""
    ncols, nrows = len(times), len(runs)
    fig = plotting.blank_figure((3.0 * ncols, 2.8 * nrows + 0.4))
    steps = [_steps(run, times, unique=False) for run in runs]
    lo, hi = plotting.bounds(*(run.position[k] for run, ks in zip(runs, steps) for k in ks))
    for row, (run, label, ks) in enumerate(zip(runs, labels, steps)):
        for col, k in enumerate(ks):
            ax = fig.add_subplot(nrows, ncols, row * ncols + col + 1, projection="3d")
            pos = run.position[k]
            plotting.draw_lattice(ax, pos, color=f"C{row}", linewidth=0.6)
            ax.plot(*pos[0, 0], "o", color="C3", ms=4)  # the driven corner (0,0)
            plotting.setup_3d(ax, lo, hi, run.units(), "iso",
                              title=f"{label}\nT = {run.time[k]:g} s")
            plotting.shrink_3d_box(ax)
    fig.suptitle("Fig. 5 scene: corner (red) to z = -10 mm at 0.5 s, "
                 "to +15 mm at 1.0 s, then held")
    plotting.room_for_3d_labels(fig)
    return fig


BUILDERS = {"fig3_lift_release": build_fig3, "fig4_bend_release": build_fig4,
            "fig5_wave_point": build_fig5}


# ------------------------------------------------------------------ command line


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "report_figures")
    # Under runs/ (ignored): a tool run never overwrites the tracked docs/figures
    # unless told to (--outdir docs/figures).
    p.add_argument("--outdir", default="runs/figures",
                   help="where the PNGs go (default runs/figures; --outdir docs/figures "
                        "updates the documentation's)")
    p.add_argument("--rundir", default="runs/report",
                   help="where the runs' namelists, .h5 and logs go (default runs/report)")
    p.add_argument("--nranks", type=int, default=2, help="MPI ranks per run (default 2)")
    p.add_argument("--exe", default="build/nuno", help="the nuno executable (default build/nuno)")
    p.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC") or "mpiexec",
                   help="MPI launcher, may hold options (default $NUNO_MPIEXEC or mpiexec)")
    p.add_argument("--skip-run", action="store_true",
                   help="do not run; re-plot the complete .h5 files already in --rundir (a figure whose runs are all missing is skipped)")
    p.add_argument("--quick", action="store_true",
                   help="7 x 7 lattices, dt 5 ms, t_end 0.4 s (lift, bend) and 1.2 s (wave)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", default=[],
                   help="override a namelist key in every run (repeatable; after --quick)")
    p.add_argument("--no-wave-energy", action="store_true",
                   help="Fig. 5 with the report's no-bending run only")
    p.add_argument("--dpi", type=int, default=100, help="resolution (default 100)")
    return p


def _body(args):
    if args.nranks < 1:
        raise cli.UsageError(f"--nranks {args.nranks}: must be >= 1")
    overrides = parse_sets(args.set)
    rundir, outdir = Path(args.rundir), Path(args.outdir)
    figures = {name: cases[:1] if (args.no_wave_energy and name.startswith("fig5")) else cases
               for name, cases in FIGURES.items()}
    cases = [c for cs in figures.values() for c in cs]
    paths = {c.name: rundir / f"{c.name}.h5" for c in cases}
    if args.skip_run:
        # Whatever complete runs exist: a figure is drawn from the runs of
        # it that finished, and skipped (with a line on stderr) when none did.
        usable = {}
        for c in cases:
            p = paths[c.name]
            if not p.is_file():
                print(f"skip: {p}: no such file", file=sys.stderr)
                continue
            try:
                load(p)
            except (RunError, ValueError, OSError) as e:
                print(f"skip: {e}", file=sys.stderr)
                continue
            usable[c.name] = True
        figures = {name: [c for c in cs if c.name in usable] for name, cs in figures.items()}
        figures = {name: cs for name, cs in figures.items() if cs}
        if not figures:
            raise FileNotFoundError(f"{rundir}: no complete run to plot "
                                    "(run without --skip-run first)")
    else:
        exe = Path(args.exe).resolve()
        if not exe.is_file():
            raise FileNotFoundError(f"{args.exe}: no such executable "
                                    "(build with bash tools/build.sh, or pass --exe)")
        texts = {c.name: case_namelist(c, overrides, args.quick) for c in cases}
        rundir.mkdir(parents=True, exist_ok=True)
        for i, c in enumerate(cases, 1):
            print(f"[{i}/{len(cases)}] {c.name}: {c.label}, {args.nranks} ranks ...",
                  end=" ", flush=True)
            t0 = clock.perf_counter()
            try:
                run_case(c, texts[c.name], rundir, str(exe), args.nranks,
                         shlex.split(args.mpiexec))
            except RunError:
                print("FAILED", flush=True)
                raise
            print(f"done in {clock.perf_counter() - t0:.1f} s -> {paths[c.name]}", flush=True)
    outdir.mkdir(parents=True, exist_ok=True)
    for name, cs in figures.items():
        runs = [load(paths[c.name]) for c in cs]
        fig = BUILDERS[name](runs, [c.label for c in cs])
        out = outdir / f"{name}.png"
        plotting.save(fig, out, args.dpi)
        print(f"wrote {out}", flush=True)


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        return cli.run_main(_body, args)
    except RunError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
