# SPDX-License-Identifier: BSD-2-Clause
"""Convergence study: error against lattice spacing or time step, log-log, observed order.

    nuno-convergence run17.h5 run33.h5 run65.h5 --time 0.05 -o conv.png
    nuno-convergence cn_dt1.h5 cn_dt2.h5 cn_dt3.h5 --reference-run tight.h5
    nuno-convergence study.csv --x-column dt -o convergence.png

From runs: the runs differ in the lattice (nx, ny; spacing h from the rest
lattice) or in the fixed time step (dt: the run's own record of the step it
took, /run, else /config/time, else the echoed namelist), not both; which one
is detected. Positions at --time (default: the last common output time) are
compared on the nodes of the coarsest lattice (the common nodes of nested
lattices N, 2N-1, 4N-3, else bilinear interpolation, as in compare); the
distance of two runs is the largest node distance (--norm max, default) or
the root mean square over the nodes (--norm rms).

The order needs no exact solution: the differences of successive runs
d_k = |u_k - u_k+1| fall as h^p, so log(d_k / d_k+1) / log(h_k / h_k+1) is
the observed order (3 runs or more). The error of each run is measured
against a reference: by default (--reference richardson, 3 runs or more) the
Richardson estimate u_f + (u_f - u_f-1) / (r^p - 1) from the two finest runs
and the order p of the differences; --reference finest measures against the
finest run (left out itself; its errors shrink towards the finest run, which
biases their order upwards); --reference-run FILE against another run (a
tighter tolerance or a finer lattice; every study run is kept, 2 runs
suffice). Two runs and no reference run give no order: refused.

The asymptotic range is judged before any estimate: the orders the study
reports (those of the differences of successive runs, each from a triple of
runs; with --reference-run those of the errors) must each be > 0 (the
differences, or errors, fall) and agree within the band: the largest at most
(1 + --band) times the smallest (default 0.2). Outside it one line says
``not in the asymptotic range: orders ... (band ...)`` and no Richardson
estimate and no fitted order is given (no order p <= 0 is ever used); the
figure shows the differences with their orders and says so. With one order
(3 runs; 2 with a reference run) the range cannot be checked and a line says
that; with 3 runs the errors against the Richardson estimate follow from
the one ratio of differences that gave p: they are printed as estimates,
not drawn, and no order is fitted through them.

Prints one ``error <h> <value>`` line per run, ``orders <p1> ...`` (the
order between successive errors), ``difference <h_k> <d_k>`` per pair of
successive runs, ``difference_orders ...``, ``observed_order_differences
<value>`` (least-squares slope of the differences: their one ratio for 3
runs), ``order <value>`` (least-squares slope of the errors, only through 3
points or more: two points are one ratio, not a fit), the line about the
asymptotic range and one ``using ...`` line that says which reference the
errors are against. The figure shows the errors and the differences with
their orders, slope guides and, in the title, the study's name (--name;
default: the files' common name, e.g. ``drop_table_dt-*.h5``), what varies,
the norm and the time.
From one CSV: the former mode, prints ``slope <value>``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from . import cli, compare, loglog, plotting


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


MIN_FIT_POINTS = 3   # a least-squares order through 2 points is one ratio, not a fit
BAND = 0.2           # orders agree when the largest is at most (1 + BAND) times the smallest


def judge_orders(orders, band: float = BAND) -> dict:
    """Whether successive orders say the runs are in the asymptotic range.

    In range: every order finite and > 0 (the differences, or errors, fall)
    and, with two orders or more, max / min <= 1 + band. One order is
    'unchecked' (nothing to agree with) when it is > 0. Returns
    {'state': 'in' | 'out' | 'unchecked', 'orders': array, 'band': band}."""
    ps = np.asarray(orders, float)
    if len(ps) == 0:
        state = "unchecked"
    elif not np.all(np.isfinite(ps)) or np.any(ps <= 0):
        state = "out"
    elif len(ps) == 1:
        state = "unchecked"
    else:
        state = "in" if ps.max() <= (1.0 + band) * ps.min() else "out"
    return {"state": state, "orders": ps, "band": float(band)}


def band_text(band: float) -> str:
    return f"band: each > 0, largest <= {1.0 + band:g} x smallest"


def study(runs, t=None, reference: str = "richardson", norm: str = "max", reference_run=None,
          band: float = BAND) -> dict:
    """h, errors, differences and orders of a study; see the module docstring.

    reference_run: a Run to measure every run against (reference 'run');
    it may be of another time step or a finer lattice of the same sheet.
    Outside the asymptotic range (judge_orders on the difference orders,
    or with a reference run on the error orders) 'order' and 'observed' are
    None and, against Richardson, there are no errors ('h', 'errors' empty).
    """
    if reference_run is not None:
        reference = "run"
    if reference not in ("finest", "richardson", "run"):
        raise ValueError(f"unknown reference {reference!r} (finest, richardson or a run)")
    if not band > 0:
        raise ValueError(f"--band {band:g}: must be > 0")
    need = {"finest": 3, "richardson": 3, "run": 2}[reference]
    kind = detect(runs) if len(runs) >= 2 else None   # what varies, before counting
    if len(runs) < need:
        hint = ("; or give --reference-run FILE (a tighter or finer run)"
                if reference != "run" else "")
        raise ValueError(f"{len(runs)} runs: a study against the {reference} reference needs "
                         f"at least {need} runs (two runs give one difference, no order){hint}")
    distance(np.zeros(3), np.zeros(3), norm)  # 'unknown norm' before any work
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
    with np.errstate(divide="ignore", invalid="ignore"):
        d_orders = successive_orders(h[:-1], diffs) if len(diffs) >= 2 else np.array([])
    d_range = judge_orders(d_orders, band)
    if reference == "richardson" and np.any(diffs <= 0):
        raise ValueError("successive runs agree exactly: no order to observe")
    # the least-squares order of the differences: only inside the range
    observed = None
    if len(runs) >= 3 and np.all(diffs > 0) and d_range["state"] != "out":
        observed, _ = loglog.fit_slope(h[:-1], diffs)
    one_ratio = False
    if reference == "finest":
        ref = u[len(runs) - 1]
        hs, errors = h[:-1], np.array([dist(v, ref) for v in u[:len(runs) - 1]])
    elif reference == "run":
        ref = u[-1]
        hs, errors = h, np.array([dist(v, ref) for v in u[:-1]])
    elif observed is not None and observed > 0:
        r = h[-2] / h[-1]
        ref = u[-1] + (u[-1] - u[-2]) / (r ** observed - 1.0)
        hs, errors = h, np.array([dist(v, ref) for v in u])
        one_ratio = len(runs) == 3
    else:                                  # no Richardson estimate outside the range
        hs, errors = h[:0], np.array([])
    if np.any(errors <= 0):
        raise ValueError("a run equals the reference exactly: no order to fit")
    with np.errstate(divide="ignore", invalid="ignore"):
        e_orders = successive_orders(hs, errors) if len(hs) >= 2 else np.array([])
    judged = "errors" if reference == "run" else "differences"
    rng = judge_orders(e_orders, band) if judged == "errors" else d_range
    order = icpt = None
    if len(hs) >= MIN_FIT_POINTS and rng["state"] != "out" and not one_ratio:
        order, icpt = loglog.fit_slope(hs, errors)
    return {"kind": kind, "h": hs, "errors": errors, "order": order, "intercept": icpt,
            "orders": e_orders, "differences": diffs, "h_differences": h[:-1],
            "difference_orders": d_orders,
            "h_all": h, "time": t, "reference": reference, "observed": observed, "norm": norm,
            "units": runs[0].units(), "scene": runs[0].scene(), "name": files_name(runs),
            "lattices": [(r.nx, r.ny) for r in runs], "range": rng["state"],
            "judged": judged, "judged_orders": rng["orders"], "band": band,
            "one_ratio": one_ratio}


def files_name(runs) -> str:
    """What the runs' files are called together: their common stem with a
    wildcard for the swept part (drop_table_dt-*.h5), else the names."""
    names = [Path(str(r.path)).name for r in runs]
    stems = [Path(n).stem for n in names]
    if len(set(stems)) == 1:
        return names[0]
    prefix = re.sub(r"[0-9.]+$", "", os.path.commonprefix(stems))
    if len(prefix.strip("-_.")) >= 2:
        return f"{prefix}*{Path(names[0]).suffix}"
    return ", ".join(names) if len(names) <= 3 else f"{names[0]} .. {names[-1]}"


REFERENCE_NAMES = {"finest": "the finest run", "richardson": "the Richardson estimate",
                   "run": "the reference run"}


def _orders_text(ps) -> str:
    return ", ".join(f"{p:.2f}" for p in ps)


def slope_guides(ax, h, anchor: float, orders=(1, 2), color="0.5") -> None:
    """Dotted / dashed lines of slope p through (h[0], anchor) for each p:
    the eye reads an order off the data against them."""
    h = np.asarray(h, float)
    styles = [(0, (1, 3)), (0, (5, 3)), (0, (3, 2, 1, 2)), (0, (8, 2)), (0, (1, 1))]
    for k, p in enumerate(orders):
        ax.loglog(h, anchor * (h / h[0]) ** p, color=color, ls=styles[k % len(styles)], lw=1,
                  label=f"slope {p:g}")


def guide_orders(observed) -> tuple:
    """Slopes 1 and 2, plus the integer nearest an observed order above 2."""
    out = [1, 2]
    if observed is not None and np.isfinite(observed) and round(observed) > 2:
        out.append(int(round(observed)))
    return tuple(out)


def draw_study(ax, h, errors, h_diff, diffs, norm: str, reference: str, color="C0",
               order=None, show_label_norm: bool = True) -> None:
    """Errors (filled, solid) and differences of successive runs (open, dashed)
    on log-log axes, each labelled with its successive orders and, through 3
    points or more, its least-squares order. Shared with bench/convergence.py."""
    tag = f"{norm} " if show_label_norm else ""
    if len(errors):
        err_orders = successive_orders(h, errors) if len(h) >= 2 else []
        label = f"{tag}distance from {REFERENCE_NAMES.get(reference, reference)}"
        if len(err_orders):
            label += f": orders {_orders_text(err_orders)}"
        if order is not None:
            label += f", fit {order:.2f}"
        ax.loglog(h, errors, "o-", color=color, label=label)
    if len(diffs):
        with np.errstate(divide="ignore", invalid="ignore"):
            d_orders = successive_orders(h_diff, diffs) if len(diffs) >= 2 else []
        label = f"{tag}difference of successive runs"
        if len(d_orders):
            label += f": orders {_orders_text(d_orders)}"
        ax.loglog(h_diff, diffs, "s--", color=color, mfc="none", label=label)


def title(res) -> str:
    """The study's name (the files, or --name), what varies, norm and time."""
    name = res.get("name") or res.get("scene") or "nuno"
    if res["kind"] == "nx":
        lat = res["lattices"]
        what = (f"nx = ny = {lat[0][0]} .. {lat[-1][0]}" if all(a == b for a, b in lat)
                else f"{lat[0][0]} x {lat[0][1]} .. {lat[-1][0]} x {lat[-1][1]}")
    else:
        hs = res["h_all"]
        what = f"dt = {hs[0]:g} .. {hs[-1]:g} s"
    return f"{name}: {what} ({len(res['h_all'])} runs), {res['norm']} norm, t = {res['time']:g} s"


def range_line(res) -> str:
    """The one line about the asymptotic range (see the module docstring)."""
    what = ("of the errors against the reference run" if res["judged"] == "errors"
            else "of the differences of successive runs")
    ps = _orders_text(res["judged_orders"])
    band = band_text(res["band"])
    if res["range"] == "out":
        gone = ("no fitted order" if res["reference"] != "richardson"
                else "no Richardson estimate and no fitted order")
        return f"not in the asymptotic range: orders {ps} {what} ({band}): {gone}"
    if res["range"] == "in":
        return f"asymptotic range: orders {ps} {what} agree ({band})"
    n = len(res["h_all"])
    if res["one_ratio"]:
        return (f"asymptotic range not checked: {n} runs give one order ({ps}); the errors "
                "against the Richardson estimate follow from that one ratio of differences: "
                "estimates, not separate evidence (not drawn, no order fitted); "
                "4 runs give two orders to compare")
    return (f"asymptotic range not checked: one order ({ps}) {what}; "
            f"{n + 1} runs give two orders to compare")


def build_figure(res):
    fig, (ax,) = plotting.new_figure(1, ncols=1, panel_size=(6.5, 5.0))
    units = res["units"]
    show_errors = not res["one_ratio"]
    draw_study(ax, res["h"] if show_errors else [], res["errors"] if show_errors else [],
               res["h_differences"], res["differences"], res["norm"], res["reference"],
               order=res["order"])
    anchor = float(res["errors"][0]) if show_errors and len(res["errors"]) else \
        float(res["differences"][0])
    h_guide = res["h_all"] if show_errors and len(res["errors"]) else res["h_differences"]
    slope_guides(ax, h_guide, anchor, guide_orders(res["observed"]))
    if res["kind"] == "nx":
        ax.set_xlabel(plotting.length_label("lattice spacing h", units))
    else:
        ax.set_xlabel("time step dt [s]")
    ax.set_ylabel(plotting.length_label(f"{res['norm']} node distance", units))
    ax.set_title(title(res), fontsize="medium")
    if res["range"] != "in":
        # under the axes, where constrained layout keeps room for it (not over the data)
        import textwrap
        fig.supxlabel(textwrap.fill(range_line(res), 90), fontsize="small",
                      color="C3" if res["range"] == "out" else "0.25")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small", loc="lower right")
    return fig


def using_line(res) -> str:
    """The one line that says which reference and which order the study reports."""
    obs = res["observed"]
    if res["reference"] == "richardson":
        if not len(res["errors"]):
            return "using richardson: no estimate (outside the asymptotic range)"
        return (f"using richardson: errors against the Richardson estimate of the two finest "
                f"runs with the order of the differences of successive runs, {obs:.4g}")
    if res["reference"] == "finest":
        return ("using finest: errors against the finest run (biased towards higher orders: "
                "compare observed_order_differences)")
    return "using reference-run: errors against the reference run"


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "convergence")
    p.add_argument("inputs", nargs="+",
                   help="two or more nuno output files (.h5), or one CSV with a header row")
    p.add_argument("--time", type=float, default=None,
                   help="runs: time compared (default: the last common output time)")
    p.add_argument("--reference", choices=("richardson", "finest"), default="richardson",
                   help="runs: errors against a Richardson estimate (default; the order of "
                        "the differences of successive runs) or against the finest run")
    p.add_argument("--reference-run", default=None, metavar="FILE",
                   help="runs: error against this run instead (e.g. a tighter tolerance); "
                        "every study run is kept")
    p.add_argument("--norm", choices=NORMS, default="max",
                   help="runs: largest node distance (max, default) or root mean square over "
                        "the nodes (rms)")
    p.add_argument("--band", type=float, default=BAND,
                   help="the asymptotic range: successive orders, each > 0, agree when the "
                        f"largest is at most (1 + BAND) times the smallest (default {BAND:g})")
    p.add_argument("--name", default=None,
                   help="runs: what the title calls the study (default: the files' common "
                        "name, e.g. drop_table_dt-*.h5; nuno-sweep gives the namelist file)")
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
        loglog.run(args, band=args.band)
        return
    runs = [cli.load_run(path) for path in args.inputs]
    ref = cli.load_run(args.reference_run) if args.reference_run else None
    res = study(runs, args.time, args.reference, args.norm, ref, band=args.band)
    if args.name:
        res["name"] = args.name
    plotting.save(build_figure(res), args.output, args.dpi)
    for h, e in zip(res["h"], res["errors"]):
        print(f"error {h:.10g} {e:.10g}")
    if len(res["orders"]) and not res["one_ratio"]:
        print("orders " + " ".join(f"{p:.10g}" for p in res["orders"]))
    for h, d in zip(res["h_differences"], res["differences"]):
        print(f"difference {h:.10g} {d:.10g}")
    if len(res["difference_orders"]):
        print("difference_orders " + " ".join(f"{p:.10g}" for p in res["difference_orders"]))
    if res["observed"] is not None:
        print(f"observed_order_differences {res['observed']:.10g}")
    if res["order"] is not None:
        print(f"order {res['order']:.10g}")
    elif res["range"] != "out" and not res["one_ratio"]:
        print(f"no fitted order: {len(res['h'])} errors give one ratio (orders above); "
              f"a fit needs {MIN_FIT_POINTS}")
    print(range_line(res))
    print(using_line(res))


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
