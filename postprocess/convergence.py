"""Convergence study: error against lattice spacing or time step, log-log, fitted order.

    python3 -m postprocess.convergence run11.h5 run21.h5 run41.h5 --time 0.1 -o conv.png
    python3 -m postprocess.convergence study.csv --x-column dt -o convergence.png

From runs: the runs differ in the lattice (nx, ny; spacing h from the rest
lattice) or in the fixed time step (dt: the run's own record of the step it
took, /run, else /config/time, else the echoed namelist), not both; which one
is detected. Positions at --time (default: the last common output time) are
compared on the nodes of the coarsest lattice (the common nodes of nested
lattices N, 2N-1, 4N-3, else bilinear interpolation, as in compare). The
error of a run is the distance of its nodes from the reference, the largest
(--norm max, default) or the root mean square over the nodes (--norm rms):
the reference is the finest run (--reference finest; the finest run itself is
then left out), a Richardson estimate from the two finest runs and the order
observed in the differences of successive runs (--reference richardson, needs
3 runs), or another run given with --reference-run (a tighter one: every
study run is then kept). Prints one ``error <h> <value>`` line per run,
``orders <p1> <p2> ...`` (the order between each pair of successive runs,
log(e1/e2)/log(h1/h2)), ``observed_order_differences <value>`` (the slope of
the differences of successive runs, which needs no reference; 3 runs or
more) and ``order <value>`` (least-squares slope of log error against log h).
From one CSV: the former mode, prints ``slope <value>``.
"""

from __future__ import annotations

import re

import numpy as np

from postprocess import cli, compare, loglog, plotting


def namelist_dt(run) -> float | None:
    """The dt of the echoed namelist (``dt = ...``, the file's own key), if any."""
    m = re.search(r"(?<![A-Za-z0-9_%])dt\s*=\s*([-+0-9.eEdD]+)", run.namelist)
    if not m:
        return None
    try:
        return float(m.group(1).replace("d", "e").replace("D", "e"))
    except ValueError:
        return None


def run_dt(run) -> float | None:
    """The time step a run took: /run's dt (after -ts_dt and -nuno_set), else
    /config/time's, else the echoed namelist's (older and synthetic files).
    ValueError for an adaptive run: its dt is only the first step."""
    adapt = str(run.run_info.get("ts_adapt_type", "none")).strip()
    if adapt not in ("", "none"):
        raise ValueError(f"{run.path}: adaptive steps (-ts_adapt_type {adapt}): no fixed dt "
                         "for a time-step study")
    for value in (run.run_info.get("dt"), run.config.get("time", {}).get("dt")):
        if value is not None:
            return float(np.asarray(value).ravel()[0])
    return namelist_dt(run)


def spacing(run) -> float:
    """Lattice spacing along x from the rest lattice."""
    xs, _ = compare._axes(run)
    return float(xs[-1] - xs[0]) / (run.nx - 1)


def _fixed_dt(run) -> float | None:
    """run_dt, or None for an adaptive run."""
    try:
        return run_dt(run)
    except ValueError:
        return None


def detect(runs) -> str:
    """'nx' when the lattices differ, 'dt' when only the time steps do."""
    lattices = {(r.nx, r.ny) for r in runs}
    if len(lattices) == len(runs):
        dts = [_fixed_dt(r) for r in runs]
        if None not in dts and len(set(dts)) > 1:
            raise ValueError("both the lattice and dt vary: a study varies one of them")
        return "nx"
    if len(lattices) == 1:
        dts = [run_dt(r) for r in runs]
        if None in dts:
            raise ValueError("runs of one lattice, but dt is not in every run")
        if len(set(dts)) != len(runs):
            raise ValueError("runs of one lattice need distinct dt values")
        return "dt"
    raise ValueError("runs must all differ in the lattice or all share it")


NORMS = ("max", "rms")


def distance(a, b, norm: str = "max") -> float:
    """Largest (max) or root-mean-square (rms) node distance of two [..][3] arrays."""
    d = np.linalg.norm(np.asarray(a) - np.asarray(b), axis=-1)
    if norm == "max":
        return float(d.max())
    if norm == "rms":
        return float(np.sqrt(np.mean(d**2)))
    raise ValueError(f"unknown norm {norm!r} (one of {', '.join(NORMS)})")


def successive_orders(h, e) -> np.ndarray:
    """log(e_k / e_k+1) / log(h_k / h_k+1) for each pair of successive points."""
    h, e = np.asarray(h, float), np.asarray(e, float)
    return np.log(e[:-1] / e[1:]) / np.log(h[:-1] / h[1:])


def study(runs, t=None, reference: str = "finest", norm: str = "max", reference_run=None) -> dict:
    """h, errors and fitted order of a study; see the module docstring.

    reference_run: a Run to measure every run against (reference 'run');
    it may be of another time step or a finer lattice of the same sheet.
    """
    if reference_run is not None:
        reference = "run"
    need = {"finest": 2, "richardson": 3, "run": 2}[reference]
    if len(runs) < need:
        raise ValueError(f"a study against the {reference} reference needs at least {need} runs")
    distance(np.zeros(3), np.zeros(3), norm)  # 'unknown norm' before any work
    kind = detect(runs)
    h = np.array([spacing(r) if kind == "nx" else run_dt(r) for r in runs])
    order_idx = np.argsort(-h)             # coarse first
    runs, h = [runs[k] for k in order_idx], h[order_idx]
    everyone = runs + ([reference_run] if reference_run is not None else [])
    t0, t1 = compare.common_interval(everyone)
    t = t1 if t is None else float(t)
    if not t0 - 1e-12 <= t <= t1 + 1e-12:
        raise ValueError(f"time {t:g} outside the common interval [{t0:g}, {t1:g}]")
    coarsest = min(everyone, key=lambda r: r.nx * r.ny)
    # every run's positions at the coarsest lattice's nodes, one step each
    u = [compare.sampler(coarsest, r)[0](r.position_at(t)) for r in everyone]

    def dist(a, b):
        return distance(a, b, norm)

    diffs = np.array([dist(u[k], u[k + 1]) for k in range(len(runs) - 1)])
    observed = None
    if len(runs) >= 3 and np.all(diffs > 0):
        observed, _ = loglog.fit_slope(h[:-1], diffs)
    if reference == "finest":
        ref = u[-1]
        hs, errors = h[:-1], np.array([dist(v, ref) for v in u[:-1]])
    elif reference == "run":
        ref = u[-1]
        hs, errors = h, np.array([dist(v, ref) for v in u[:-1]])
    else:
        if np.any(diffs <= 0):
            raise ValueError("successive runs agree exactly: no order to observe")
        r = h[-2] / h[-1]
        ref = u[-1] + (u[-1] - u[-2]) / (r ** observed - 1.0)
        hs, errors = h, np.array([dist(v, ref) for v in u])
    if np.any(errors <= 0):
        raise ValueError("a run equals the reference exactly: no order to fit")
    order, icpt = loglog.fit_slope(hs, errors)
    return {"kind": kind, "h": hs, "errors": errors, "order": order, "intercept": icpt,
            "orders": successive_orders(hs, errors), "differences": diffs,
            "time": t, "reference": reference, "observed": observed, "norm": norm,
            "units": runs[0].units()}


def build_figure(res):
    fig, (ax,) = plotting.new_figure(1, ncols=1, panel_size=(6.0, 4.5))
    h, e = res["h"], res["errors"]
    units = res["units"]
    ax.loglog(h, e, "o", color="C0", label="runs")
    ax.loglog(h, np.exp(res["intercept"]) * h ** res["order"], "--", color="C1",
              label=f"fit, order {res['order']:.3f}")
    if res["kind"] == "nx":
        ax.set_xlabel(plotting.length_label("lattice spacing h", units))
    else:
        ax.set_xlabel("time step dt [s]")
    ref = {"finest": "finest run", "richardson": "Richardson estimate",
           "run": "reference run"}[res["reference"]]
    what = "max" if res.get("norm", "max") == "max" else "rms"
    ax.set_ylabel(plotting.length_label(f"{what} node distance from {ref}", units))
    ax.set_title(f"t = {res['time']:g} s", fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "convergence")
    p.add_argument("inputs", nargs="+",
                   help="two or more nuno output files (.h5), or one CSV with a header row")
    p.add_argument("--time", type=float, default=None,
                   help="runs: time compared (default: the last common output time)")
    p.add_argument("--reference", choices=("finest", "richardson"), default="finest",
                   help="runs: error against the finest run or a Richardson estimate")
    p.add_argument("--reference-run", default=None, metavar="FILE",
                   help="runs: error against this run instead (e.g. a tighter tolerance); "
                        "every study run is kept")
    p.add_argument("--norm", choices=NORMS, default="max",
                   help="runs: largest node distance (max, default) or root mean square over "
                        "the nodes (rms)")
    p.add_argument("--x-column", default="parameter", help="CSV: x column (default parameter)")
    p.add_argument("--y-column", default="error", help="CSV: y column (default error)")
    p.add_argument("--group-column", default=None,
                   help="CSV: column whose values split the rows into series")
    p.add_argument("--fit-min", type=float, default=None, help="CSV: fit only x >= this")
    p.add_argument("--fit-max", type=float, default=None, help="CSV: fit only x <= this")
    p.add_argument("-o", "--output", default="convergence.png",
                   help="output file (default convergence.png)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")
    return p


def _body(args):
    if len(args.inputs) == 1 and not args.inputs[0].lower().endswith((".h5", ".hdf5")):
        args.csv = args.inputs[0]
        loglog.run(args)
        return
    runs = [cli.load_run(path) for path in args.inputs]
    ref = cli.load_run(args.reference_run) if args.reference_run else None
    res = study(runs, args.time, args.reference, args.norm, ref)
    plotting.save(build_figure(res), args.output, args.dpi)
    for h, e in zip(res["h"], res["errors"]):
        print(f"error {h:.10g} {e:.10g}")
    if len(res["orders"]):
        print("orders " + " ".join(f"{p:.10g}" for p in res["orders"]))
    if res["observed"] is not None:
        print(f"observed_order_differences {res['observed']:.10g}")
    print(f"order {res['order']:.10g}")


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
