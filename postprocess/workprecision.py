# SPDX-License-Identifier: BSD-2-Clause
"""Work-precision plot: wall time against error (log-log), from run files or a CSV.

    nuno-workprecision cn_*.h5 bdf_*.h5 --reference-run tight.h5 -o wp.png
    nuno-workprecision runs/*.h5 --reference-run tight.h5 --group dt
    nuno-workprecision study.csv --group-column ts_type -o wp.png

From runs: the error of a run is the distance of its positions from those
of --reference-run (a tight-tolerance or finer run of the same sheet) at
--time (default: the last common output time), on the coarsest lattice's
nodes as in nuno-compare; the largest node distance (--norm max, default)
or the root mean square (--norm rms), in the run's length unit. The work is
the run's wall time as it recorded it (/run wall_time: the time loop,
output included). Runs are grouped into series by their integrator (/run
ts_type, with adaptive or fixed steps), or by the value of a namelist key
(--group KEY). Prints ``run <file> <group> <error> <wall_s>`` per run and,
for a series of 3 runs or more, ``slope <value> <group>`` (least squares of
log time against log error).

From one CSV with a header row (the former mode): --x-column (default
error) and --y-column (default run_time), one series per --group-column;
the axes are labelled with --x-label and --y-label (default: the column
names, with units for the known ones: run_time, wall_time, time_s, dt).
"""

from __future__ import annotations

import numpy as np

from . import cli, compare, convergence, loglog, plotting


def run_wall_time(run) -> float:
    """The run's own wall time: /run wall_time, else the last output step's."""
    value = run.run_info.get("wall_time")
    if value is not None:
        return float(np.asarray(value).ravel()[0])
    if run.wall_time is not None and len(run.wall_time):
        return float(run.wall_time[-1])
    raise ValueError(f"{run.path}: no wall time recorded (/run wall_time)")


def run_group(run, key: str | None) -> str:
    """A run's series: the integrator (ts_type, adaptive or fixed) or a key's value."""
    if key:
        return f"{key} = {cli.text_value(cli.run_value(run, key))}"
    ts = str(run.run_info.get("ts_type", "")).strip() or "?"
    adapt = str(run.run_info.get("ts_adapt_type", "none")).strip()
    return f"{ts}, {'adaptive' if adapt not in ('', 'none') else 'fixed steps'}"


def from_runs(runs, reference, t=None, norm: str = "max", group_key=None) -> dict:
    """{group: (errors, wall times, files)} of runs against the reference run."""
    convergence.distance(np.zeros(3), np.zeros(3), norm)   # 'unknown norm' first
    everyone = runs + [reference]
    t0, t1 = compare.common_interval(everyone)
    t = t1 if t is None else float(t)
    if not t0 - 1e-12 <= t <= t1 + 1e-12:
        raise ValueError(f"time {t:g} outside the common interval [{t0:g}, {t1:g}]")
    coarsest = min(everyone, key=lambda r: r.nx * r.ny)
    ref = compare.sampler(coarsest, reference)[0](reference.position_at(t))
    series: dict = {}
    for run in runs:
        pos = compare.sampler(coarsest, run)[0](run.position_at(t))
        err = convergence.distance(pos, ref, norm)
        if err <= 0:
            raise ValueError(f"{run.path} equals the reference run at t = {t:g}: no error to plot")
        g = series.setdefault(run_group(run, group_key), ([], [], []))
        g[0].append(err)
        g[1].append(run_wall_time(run))
        g[2].append(run.path)
    return {"series": {k: tuple(np.asarray(v) if i < 2 else v for i, v in enumerate(val))
                       for k, val in series.items()},
            "time": t, "norm": norm, "units": runs[0].units(), "scene": runs[0].scene()}


def build_figure(res):
    fig, (ax,) = plotting.new_figure(1, ncols=1, panel_size=(6.5, 5.0))
    slopes = {}
    for k, (name, (err, wall, _)) in enumerate(res["series"].items()):
        order = np.argsort(err)
        err, wall = err[order], wall[order]
        label = name
        if len(err) >= convergence.MIN_FIT_POINTS and np.ptp(np.log(err)) > 0:
            slope, _ = loglog.fit_slope(err, wall)
            slopes[name] = slope
            label += f" (slope {slope:.2f})"
        ax.loglog(err, wall, "o-", color=f"C{k}", label=label)
    ax.set_xlabel(plotting.length_label(
        f"{res['norm']} node distance from the reference run at t = {res['time']:g} s",
        res["units"]))
    ax.set_ylabel("wall time [s]")
    # seconds as plain numbers (1, 2, 5), not 2 x 10^0, on a range of a decade or two
    from matplotlib.ticker import FuncFormatter
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    lo, hi = ax.get_ylim()
    if hi / lo < 30:             # over more decades the minor labels would pile
        ax.yaxis.set_major_formatter(plain)
        ax.yaxis.set_minor_formatter(plain)
    ax.set_title(f"{res['scene'] or 'nuno'}: work against precision", fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return fig, slopes


COLUMN_LABELS = {"run_time": "run time [s]", "wall_time": "wall time [s]",
                 "time_s": "wall time [s]", "cpu_time": "CPU time [s]", "dt": "time step dt [s]"}


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "workprecision")
    p.add_argument("inputs", nargs="+", help="nuno output files (.h5), or one CSV with a header row")
    p.add_argument("--reference-run", default=None, metavar="FILE",
                   help="runs: the errors are distances from this run (needed with runs)")
    p.add_argument("--time", type=float, default=None,
                   help="runs: time compared (default: the last common output time)")
    p.add_argument("--norm", choices=convergence.NORMS, default="max",
                   help="runs: largest node distance (default) or root mean square")
    p.add_argument("--group", default=None, metavar="KEY",
                   help="runs: one series a value of this namelist key (default: the integrator)")
    p.add_argument("--x-column", default="error", help="CSV: x column (default error)")
    p.add_argument("--y-column", default="run_time", help="CSV: y column (default run_time)")
    p.add_argument("--group-column", default=None,
                   help="CSV: column whose values split the rows into series")
    p.add_argument("--fit-min", type=float, default=None, help="CSV: fit only x >= this")
    p.add_argument("--fit-max", type=float, default=None, help="CSV: fit only x <= this")
    p.add_argument("--x-label", default=None, help="CSV: x axis label, with its unit")
    p.add_argument("--y-label", default=None, help="CSV: y axis label, with its unit")
    p.add_argument("-o", "--output", default="workprecision.png",
                   help="output file (default workprecision.png)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")
    return p


def _csv(args):
    series = loglog.read_columns(args.inputs[0], args.x_column, args.y_column, args.group_column)
    fig, slopes = loglog.build_figure(
        series, args.x_column, args.y_column, (args.fit_min, args.fit_max),
        xlabel=args.x_label or COLUMN_LABELS.get(args.x_column),
        ylabel=args.y_label or COLUMN_LABELS.get(args.y_column))
    for name, slope in slopes.items():
        print(f"slope {slope:.10g}" + (f" {name}" if name else ""))
    plotting.save(fig, args.output, args.dpi)


def _body(args):
    if len(args.inputs) == 1 and not args.inputs[0].lower().endswith((".h5", ".hdf5")):
        _csv(args)
        return
    if not args.reference_run:
        raise cli.UsageError("runs need --reference-run FILE (the errors are distances from it)")
    runs = [cli.load_run(path) for path in args.inputs]
    ref = cli.load_run(args.reference_run)
    res = from_runs(runs, ref, args.time, args.norm, args.group)
    fig, slopes = build_figure(res)
    for name, (err, wall, files) in res["series"].items():
        for e, w, f in zip(err, wall, files):
            print(f"run {f} {name.replace(' ', '_')} {e:.10g} {w:.10g}")
    for name, slope in slopes.items():
        print(f"slope {slope:.10g} {name.replace(' ', '_')}")
    plotting.save(fig, args.output, args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
