"""Convergence study: error against lattice spacing or time step, log-log, fitted order.

    python3 -m postprocess.convergence run11.h5 run21.h5 run41.h5 --time 0.1 -o conv.png
    python3 -m postprocess.convergence study.csv --x-column dt -o convergence.png

From runs: the runs differ in the lattice (nx, ny; spacing h from the rest
lattice) or in the time step (dt from the echoed namelist), not both; which
one is detected. Positions at --time (default: the last common output time)
are compared on the nodes of the coarsest lattice (the common nodes of nested
lattices N, 2N-1, 4N-3, else bilinear interpolation, as in compare). The
error of a run is its largest node distance from the reference: the finest
run (--reference finest; the finest run itself is then left out) or a
Richardson estimate from the two finest runs and the order observed in the
differences of successive runs (--reference richardson, needs 3 runs).
Prints ``order <value>`` (least-squares slope of log error against log h)
and one ``error <h> <value>`` line per run. From one CSV: the former mode,
prints ``slope <value>``.
"""

from __future__ import annotations

import re

import numpy as np

from postprocess import cli, compare, loglog, plotting


def namelist_dt(run) -> float | None:
    """The dt of the echoed namelist (``dt = ...``), if any."""
    m = re.search(r"(?<![A-Za-z0-9_%])dt\s*=\s*([-+0-9.eEdD]+)", run.namelist)
    if not m:
        return None
    try:
        return float(m.group(1).replace("d", "e").replace("D", "e"))
    except ValueError:
        return None


def spacing(run) -> float:
    """Lattice spacing along x from the rest lattice."""
    xs, _ = compare._axes(run)
    return float(xs[-1] - xs[0]) / (run.nx - 1)


def detect(runs) -> str:
    """'nx' when the lattices differ, 'dt' when only the time steps do."""
    lattices = {(r.nx, r.ny) for r in runs}
    dts = [namelist_dt(r) for r in runs]
    if len(lattices) == len(runs):
        if None not in dts and len(set(dts)) > 1:
            raise ValueError("both the lattice and dt vary: a study varies one of them")
        return "nx"
    if len(lattices) == 1:
        if None in dts:
            raise ValueError("runs of one lattice, but dt is not in every namelist")
        if len(set(dts)) != len(runs):
            raise ValueError("runs of one lattice need distinct dt values")
        return "dt"
    raise ValueError("runs must all differ in the lattice or all share it")


def study(runs, t=None, reference: str = "finest") -> dict:
    """h, errors and fitted order of a study; see the module docstring."""
    if len(runs) < 2 + (reference == "richardson"):
        raise ValueError(f"a study against the {reference} reference needs at least "
                         f"{2 + (reference == 'richardson')} runs")
    kind = detect(runs)
    h = np.array([spacing(r) if kind == "nx" else namelist_dt(r) for r in runs])
    order_idx = np.argsort(-h)             # coarse first
    runs, h = [runs[k] for k in order_idx], h[order_idx]
    t0, t1 = compare.common_interval(runs)
    t = t1 if t is None else float(t)
    if not t0 - 1e-12 <= t <= t1 + 1e-12:
        raise ValueError(f"time {t:g} outside the common interval [{t0:g}, {t1:g}]")
    coarsest = min(runs, key=lambda r: r.nx * r.ny)
    # every run's positions at the coarsest lattice's nodes, one step each
    u = [compare.sampler(coarsest, r)[0](r.position_at(t)) for r in runs]

    def dist(a, b):
        return float(np.linalg.norm(a - b, axis=-1).max())

    observed = None
    if reference == "finest":
        ref = u[-1]
        hs, errors = h[:-1], np.array([dist(v, ref) for v in u[:-1]])
    else:
        diffs = np.array([dist(u[k], u[k + 1]) for k in range(len(u) - 1)])
        if np.any(diffs <= 0):
            raise ValueError("successive runs agree exactly: no order to observe")
        observed, _ = loglog.fit_slope(h[:-1], diffs)
        r = h[-2] / h[-1]
        ref = u[-1] + (u[-1] - u[-2]) / (r ** observed - 1.0)
        hs, errors = h, np.array([dist(v, ref) for v in u])
    if np.any(errors <= 0):
        raise ValueError("a run equals the reference exactly: no order to fit")
    order, icpt = loglog.fit_slope(hs, errors)
    return {"kind": kind, "h": hs, "errors": errors, "order": order, "intercept": icpt,
            "time": t, "reference": reference, "observed": observed,
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
    ref = "finest run" if res["reference"] == "finest" else "Richardson estimate"
    ax.set_ylabel(plotting.length_label(f"max node distance from {ref}", units))
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
    res = study(runs, args.time, args.reference)
    plotting.save(build_figure(res), args.output, args.dpi)
    for h, e in zip(res["h"], res["errors"]):
        print(f"error {h:.10g} {e:.10g}")
    if res["observed"] is not None:
        print(f"observed_order_differences {res['observed']:.10g}")
    print(f"order {res['order']:.10g}")


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
