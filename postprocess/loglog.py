# SPDX-License-Identifier: BSD-2-Clause
"""Log-log plots with least-squares slopes from a CSV (convergence, work-precision)."""

from __future__ import annotations

import csv

import numpy as np

from . import cli, plotting


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_columns(path, x_col: str, y_col: str, group_col: str | None = None) -> dict:
    """{group: (x, y)} from a CSV with a header row; one group '' without group_col."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: empty CSV")
    header = [h.strip() for h in rows[0]]
    if all(_is_number(h) for h in header):
        raise ValueError(f"{path}: no header row (the first row is numbers)")
    wanted = [x_col, y_col] + ([group_col] if group_col else [])
    missing = [c for c in wanted if c not in header]
    if missing:
        raise ValueError(f"{path}: no column {', '.join(repr(c) for c in missing)} "
                         f"(columns: {', '.join(header)})")
    ix, iy = header.index(x_col), header.index(y_col)
    ig = header.index(group_col) if group_col else None
    groups: dict = {}
    for line, row in enumerate(rows[1:], start=2):
        try:
            x, y = float(row[ix]), float(row[iy])
        except (ValueError, IndexError):
            raise ValueError(f"{path}: line {line}: no numbers in columns "
                             f"{x_col!r}, {y_col!r}") from None
        key = row[ig].strip() if ig is not None else ""
        groups.setdefault(key, ([], []))
        groups[key][0].append(x)
        groups[key][1].append(y)
    out = {}
    for key, (x, y) in groups.items():
        x, y = np.asarray(x), np.asarray(y)
        if np.any(x <= 0) or np.any(y <= 0):
            raise ValueError(f"{path}: columns {x_col!r} and {y_col!r} need positive "
                             "values for a log-log plot")
        order = np.argsort(x)
        out[key] = (x[order], y[order])
    return out


def fit_slope(x, y) -> tuple[float, float]:
    """(slope, intercept) of log y = slope log x + intercept, least squares."""
    if len(x) < 2 or np.ptp(np.log(x)) == 0:
        raise ValueError("a slope needs at least two distinct points")
    slope, intercept = np.polyfit(np.log(x), np.log(y), 1)
    return float(slope), float(intercept)


def build_figure(series: dict, x_col: str, y_col: str, fit_range=(None, None),
                 xlabel=None, ylabel=None, no_fit=()):
    """One log-log panel; returns (fig, {group: slope}); the groups in no_fit
    are drawn without a fitted slope."""
    fig, (ax,) = plotting.new_figure(1, ncols=1, panel_size=(6.0, 4.5))
    lo, hi = fit_range
    slopes = {}
    for k, (name, (x, y)) in enumerate(series.items()):
        use = in_fit_range(x, lo, hi)
        tag = f"{name}: " if name else ""
        ax.loglog(x, y, "o", color=f"C{k}", label=f"{tag}{y_col}")
        if name in no_fit:
            continue
        slope, icpt = fit_slope(x[use], y[use])
        slopes[name] = slope
        xf = x[use]
        ax.loglog(xf, np.exp(icpt) * xf ** slope, "--", color=f"C{k}",
                  label=f"{tag}fit, slope {slope:.3f}")
    ax.set_xlabel(xlabel or x_col)
    ax.set_ylabel(ylabel or y_col)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return fig, slopes


def make_parser(prog: str, description: str, x_default: str, y_default: str):
    p = cli.parser(description, prog)
    p.add_argument("csv", help="CSV file with a header row (e.g. parameter,error,run_time)")
    p.add_argument("--x-column", default=x_default, help=f"x column (default {x_default})")
    p.add_argument("--y-column", default=y_default, help=f"y column (default {y_default})")
    p.add_argument("--group-column", default=None,
                   help="column whose values split the rows into series (one slope each)")
    p.add_argument("--fit-min", type=float, default=None, help="fit only points with x >= this")
    p.add_argument("--fit-max", type=float, default=None, help="fit only points with x <= this")
    p.add_argument("-o", "--output", default=f"{prog}.png", help=f"output file (default {prog}.png)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")
    return p


def in_fit_range(x, lo=None, hi=None):
    use = np.ones(len(x), bool)
    if lo is not None:
        use &= x >= lo
    if hi is not None:
        use &= x <= hi
    return use


def run(args, band: float | None = None) -> None:
    """Read, fit, print ``slope <value> [group]`` per series, save. With band
    (a convergence study): the successive orders of the points in the fit
    range are judged first (convergence.judge_orders); a series outside the
    asymptotic range gets one line saying so and no slope."""
    series = read_columns(args.csv, args.x_column, args.y_column, args.group_column)
    no_fit, lines = [], []
    if band is not None:
        from . import convergence  # noqa: the judge of the runs' studies
        for name, (x, y) in series.items():
            use = in_fit_range(x, args.fit_min, args.fit_max)
            xs, ys = x[use][::-1], y[use][::-1]          # coarse first
            with np.errstate(divide="ignore", invalid="ignore"):
                ps = convergence.successive_orders(xs, ys) if len(xs) >= 2 else []
            rng = convergence.judge_orders(ps, band)
            if rng["state"] == "out":
                no_fit.append(name)
                lines.append(f"not in the asymptotic range: orders {convergence._orders_text(ps)} "
                             f"({convergence.band_text(band)}): no fitted slope"
                             + (f" {name}" if name else ""))
    fig, slopes = build_figure(series, args.x_column, args.y_column,
                               (args.fit_min, args.fit_max), no_fit=no_fit)
    for name, slope in slopes.items():
        print(f"slope {slope:.10g}" + (f" {name}" if name else ""))
    for line in lines:
        print(line)
    plotting.save(fig, args.output, args.dpi)
