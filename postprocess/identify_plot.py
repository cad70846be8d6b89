# SPDX-License-Identifier: BSD-2-Clause
"""Identification: observed against identified motion, the fitted values and the objective per iteration.

    nuno-identify-plot FIT.h5 --observed OBS.h5 [--initial INIT.h5]
                                         [--true e_s=1,k_b=10] [-o FILE.png]

FIT.h5 is the output file of an &identify run (its /identify group: names,
fitted values, uncertainty, initial guess, history, and the motion of the
fitted model itself); OBS.h5 the observed file it was given (nuno's output
or a plain file with /time and /position); INIT.h5, optional, a run with the
initial guess; --true, optional, the values the observation was made with
(a synthetic observation). Top left: side views (x-z) at three observed
times, observed nodes as dots, the fitted model as lines. Top right: the
height of the free edge (i = nx-1, middle row) against time. Bottom: the
fitted values' error relative to the true ones with their 1-sigma
uncertainty (without --true: the relative uncertainty alone), the values and
the initial guess under each, and the objective per iteration.
"""

from __future__ import annotations

import numpy as np

from . import cli, plotting
from .reader import read_states


def parse_true(text):
    """--true 'e_s=1,k_b=10' as {name: value}."""
    out = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise ValueError(f"--true {text!r}: expected NAME=VALUE[,NAME=VALUE...], e.g. e_s=1,k_b=10")
    return out


def identify_data(run):
    """The /identify group of a run, or ValueError naming the file."""
    g = run.identify
    for key in ("names", "values", "uncertainty", "initial", "history"):
        if key not in g:
            raise ValueError(f"{run.path}: not the output of an &identify run (no /identify/{key})")
    return g


def edge_height(pos):
    """z of node (nx-1, (ny-1)//2) in positions [..][ny][nx][3]."""
    pos = np.asarray(pos)
    return pos[..., (pos.shape[-3] - 1) // 2, -1, 2]


def build_figure(fit, observed, initial=None, true=None):
    """The figure: fit an identification run (reader.Run), observed (times, positions), initial a Run or None."""
    g = identify_data(fit)
    t_obs, x_obs = observed
    units = fit.units()
    fig = plotting.blank_figure((12.4, 8.6))

    # Side views at three observed times.
    ax = fig.add_subplot(2, 2, 1)
    pick = np.unique(np.linspace(1, len(t_obs) - 1, 3).round().astype(int))
    colour, mappable = plotting.time_colormap(float(t_obs[pick[0]]), float(t_obs[pick[-1]]))
    for k in pick:
        t = float(t_obs[k])
        plotting.draw_lattice_side(ax, fit.position[fit.step_index(t)], color=colour(t), linewidth=0.8)
        ax.plot(x_obs[k][..., 0].ravel(), x_obs[k][..., 2].ravel(), ".", color=colour(t), ms=3)
    lo, hi = plotting.bounds(*(x_obs[k] for k in pick))
    pad = 0.05 * (hi - lo)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[2] - pad[2], hi[2] + pad[2])
    ax.set_xlabel(plotting.length_label("x", units))
    ax.set_ylabel(plotting.length_label("z", units))
    ax.set_title("side view (z stretched): observed nodes (dots), fitted model (lines)", fontsize="medium")
    fig.colorbar(mappable, ax=ax, label="t [s]")

    # The free edge's height against time.
    ax = fig.add_subplot(2, 2, 2)
    ax.plot(t_obs, edge_height(x_obs), "o", color="0.3", ms=4, label="observed")
    ax.plot(fit.time, edge_height(np.asarray(fit.position)), "-", color="C0", label="fitted model")
    if initial is not None:
        ax.plot(initial.time, edge_height(np.asarray(initial.position)), "--", color="C1", label="initial guess")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(plotting.length_label("z of the free edge (middle row)", units))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")

    # Fitted values: their error relative to the true ones when given (else
    # their own relative uncertainty), with 1 sigma, in percent.
    ax = fig.add_subplot(2, 2, 3)
    names = list(g["names"])
    values, unc, init = (np.asarray(g[k], float) for k in ("values", "uncertainty", "initial"))
    true = true or {}
    unknown = [n for n in true if n not in names]
    if unknown:
        raise ValueError(f"--true {unknown[0]}: not a fitted parameter (fitted: {', '.join(names)})")
    ref = np.array([true.get(n, v) for n, v in zip(names, values)])
    x = np.arange(len(names))
    ax.errorbar(x, 100.0 * (values / ref - 1.0), yerr=100.0 * unc / ref, fmt="o", color="C0", capsize=4,
                label="fitted $\\pm 1\\sigma$")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set_xticks(x, [f"{n}\n{v:.4g} $\\pm$ {u:.2g}\n(start {i:.3g})" for n, v, u, i in zip(names, values, unc, init)],
                  fontsize="small")
    ax.set_ylabel("fitted / true - 1 [%]" if true else "uncertainty relative to the value [%]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title("fitted values" + (" against the true ones" if true else ""), fontsize="medium")

    plotting.objective_panel(fig.add_subplot(2, 2, 4), np.asarray(g["history"], float)[:, 0], units,
                             "objective per iteration")
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "identify_plot")
    p.add_argument("run", help="output file of an &identify run (.h5)")
    p.add_argument("--observed", required=True, help="the observed file of that run (.h5)")
    p.add_argument("--initial", default=None, help="a run of the scene with the initial guess (.h5)")
    p.add_argument("--true", default=None, help="the true values of a synthetic observation, e.g. e_s=1,k_b=10")
    cli.add_output(p, "identify")
    return p


def _body(args):
    fit = cli.load_run(args.run)
    initial = cli.load_run(args.initial) if args.initial else None
    fig = build_figure(fit, read_states(args.observed), initial, parse_true(args.true))
    plotting.save(fig, args.output or cli.default_output(args.run, "identify"), args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
