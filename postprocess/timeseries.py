# SPDX-License-Identifier: BSD-2-Clause
"""Energies, energy-balance drift, momenta, length, flatness and solver counts against time.

    nuno-timeseries run.h5 -o run_timeseries.png
    nuno-timeseries sweep/*.h5 --label e_s -o sweep_timeseries.png

One run: its energies, balance, momentum and angular momentum components,
centre-line length (as its change from the rest length, stated on the
axis: no offset), flatness, step and iteration counts. Several runs (a sweep): the
same quantities overlaid, one line a run coloured in order and labelled by
the file name, by --labels, or by the value of a swept namelist key
(--label e_s): kinetic and elastic energy, balance drift, |p|, |L|,
length, flatness and the cumulative linear iterations (the cost).

A run with obstacles (a file with /contact, docs/model.md section 9) gets
four panels more: the active contacts (node-obstacle pairs with a gap below
contact_dhat), the smallest gap (log scale, contact_dhat marked), the
contact force along -g (the barrier's normal force, and with friction)
against the cloth's weight m |g| (where the cloth rests on an obstacle the
force carries it), and the friction work. Files without /contact (no
obstacles, or written before it) are drawn as before.
"""

from __future__ import annotations

import numpy as np

from . import cli, plotting

N_PANELS = 8
N_CONTACT_PANELS = 4     # with /contact: active pairs, smallest gap, force along -g, friction work
DHAT_DEFAULT = 1.0e-3    # contact_dhat's default (input/README.md, &contact), in the file's length unit


def balance_drift(run) -> np.ndarray:
    """(B(t) - B(0)) / scale, B the energy balance, scale the largest energy seen.

    The scale is max over time of E_kin + E_stretch + E_bend (+ E_barrier,
    with obstacles) + |W_external| (B(0) alone is zero for a cloth released
    at rest without stored energy).
    """
    b = run.energy_balance()
    e = run.energy
    scale = np.max(np.abs(e["kinetic"]) + np.abs(e["stretch"]) + np.abs(e["bend"])
                   + np.abs(e.get("barrier", 0.0)) + np.abs(e["external_work"]))
    scale = scale if scale > 0 else 1.0
    return (b - b[0]) / scale


def rest_length(run) -> float:
    """The centre line's length on the rest lattice (row j = (ny-1)/2, as
    the diagnostic is measured: docs/model.md section 7)."""
    row = np.asarray(run.rest_position)[(run.ny - 1) // 2]
    return float(np.linalg.norm(np.diff(row, axis=0), axis=-1).sum())


def length_change(run):
    """Centre-line length minus its rest length, [nt] (None without the diagnostic).

    Plotted instead of the length itself: a length that stays within 1e-9 of
    1 m drew as an axis offset '1e-9+9.9999999e-1', unreadable."""
    length = run.diagnostics.get("length")
    return None if length is None else np.asarray(length) - rest_length(run)


def length_change_label(runs, units: str) -> str:
    """'centre-line length - 100 mm [mm]': the reference stated (the runs'
    rest length, or 'rest length' when they differ)."""
    refs = [rest_length(r) for r in runs]
    same = max(refs) - min(refs) <= 1e-12 * max(abs(max(refs)), 1e-300)
    ref = f"{refs[0]:.6g} {units}" if same else "rest length"
    return plotting.length_label(f"centre-line length \u2212 {ref}", units)


def _plain_numbers(ax) -> None:
    """y tick labels as numbers, never an offset added to them."""
    ax.ticklabel_format(axis="y", useOffset=False)


def _absent(ax, what):
    ax.text(0.5, 0.5, f"{what} not in file", ha="center", va="center",
            transform=ax.transAxes)


def _vector(ax, t, data, name, ylabel):
    if data is None:
        _absent(ax, name)
    else:
        for c, comp in enumerate("xyz"):
            ax.plot(t, data[:, c], label=f"{name} {comp}")
        ax.legend(fontsize="small")
    ax.set_ylabel(ylabel)


def _key(run, key, default=None):
    """A namelist key of the run (/config, else the echoed namelist), or default."""
    try:
        return cli.run_value(run, key)
    except KeyError:
        return default


def contact_dhat(run) -> float:
    """The barrier's reach contact_dhat [length] (its default where the file has none)."""
    value = _key(run, "contact_dhat", DHAT_DEFAULT)
    return float(np.ravel(np.asarray(value, dtype=float))[0])


def weight(run):
    """(up, m |g|): the unit vector against gravity and the cloth's weight, or
    (None, None) without gravity or node masses."""
    g = cli.gravity(run)
    if g is None or run.mass is None or not np.linalg.norm(g) > 0.0:
        return None, None
    size = float(np.linalg.norm(g))
    return -g / size, float(np.sum(run.mass)) * size


def force_up(run, name: str = "normal_force"):
    """/contact's force series `name` [nt][3] along -g (its magnitude where
    the file has no gravity), [nt]; None without it."""
    f = run.contact.get(name)
    if f is None:
        return None
    up, _ = weight(run)
    f = np.asarray(f, dtype=float)
    return f @ up if up is not None else np.linalg.norm(f, axis=-1)


def _positive(y):
    """y with values <= 0 (none in a sound file; NaN in a restart of an older one) masked for a log axis."""
    y = np.asarray(y, dtype=float)
    return np.where(y > 0.0, y, np.nan)


def contact_panels(run, axes, units: str) -> None:
    """The four contact panels of a file with /contact on axes (active pairs,
    smallest gap, force along -g against the weight, friction work). Each
    axes gets a label 'contact:<what>' (tests find the panels by it)."""
    t = run.time
    c = run.contact
    ax_act, ax_gap, ax_f, ax_fw = axes
    dhat = contact_dhat(run)
    ax_act.set_label("contact:active")
    if "active" in c:
        ax_act.step(t, c["active"], where="post", color="C0")
    else:
        _absent(ax_act, "active")
    ax_act.set_ylabel("active contacts")
    ax_act.set_title(f"node-obstacle pairs with gap < contact_dhat = {dhat:g} {units}", fontsize="small")

    ax_gap.set_label("contact:gap")
    if "min_gap" in c:
        ax_gap.semilogy(t, _positive(c["min_gap"]), color="C0", label="smallest gap")
    if "min_gap_run" in c:
        ax_gap.semilogy(t, _positive(c["min_gap_run"]), color="C1", ls=":",
                        label="smallest of every accepted state so far")
    if ax_gap.lines:
        ax_gap.axhline(dhat, color="k", ls="--", lw=0.8, label=f"contact_dhat = {dhat:g} {units}")
        ax_gap.legend(fontsize="small")
    else:
        _absent(ax_gap, "min_gap")
    ax_gap.set_ylabel(plotting.length_label("gap", units))

    ax_f.set_label("contact:force")
    up, w = weight(run)
    along = "along −g" if up is not None else "magnitude"
    normal, total = force_up(run, "normal_force"), force_up(run, "force")
    if normal is not None:
        ax_f.plot(t, normal, color="C0", label=f"normal (barrier) force, {along}")
    if total is not None:
        ax_f.plot(t, total, color="C2", ls="--", lw=0.9, label=f"with friction, {along}")
    if w is not None:
        ax_f.axhline(w, color="k", ls=":", lw=0.9, label=f"weight m |g| = {w:.4g}")
    if ax_f.lines:
        ax_f.legend(fontsize="small")
    else:
        _absent(ax_f, "normal_force")
    ax_f.set_ylabel(plotting.quantity_label("force", units).replace("force", "contact force", 1))

    ax_fw.set_label("contact:friction_work")
    if "friction_work" in c:
        ax_fw.plot(t, c["friction_work"], color="C0")
    else:
        _absent(ax_fw, "friction_work")
    ax_fw.set_ylabel(plotting.quantity_label("energy", units).replace("energy", "friction work", 1))


def build_figure(run):
    """An 8-panel figure (4 rows x 2 columns) of the run's diagnostics; 12
    panels (6 rows) for a run with obstacles (/contact)."""
    units = run.units()
    t = run.time
    d = run.diagnostics
    n_contact = N_CONTACT_PANELS if run.contact else 0
    fig, axes = plotting.new_figure(N_PANELS + n_contact, ncols=2, panel_size=(5.5, 2.8))
    ax_e, ax_b, ax_p, ax_l, ax_len, ax_flat, ax_steps, ax_it = axes[:N_PANELS]

    for name, label in (("kinetic", "kinetic"), ("stretch", "stretch"), ("bend", "bend"),
                        ("barrier", "barrier (contact)"), ("dissipated", "dissipated"),
                        ("external_work", "external work")):
        if name in run.energy:
            ax_e.plot(t, run.energy[name], label=label)
    try:
        ax_e.plot(t, run.energy_balance(), "k--", label="balance")
        ax_b.plot(t, balance_drift(run), color="C3")
    except ValueError:
        _absent(ax_b, "energies")
    ax_e.set_ylabel(plotting.quantity_label("energy", units))
    ax_e.legend(fontsize="small")
    ax_b.set_ylabel("balance drift / max energy")
    barrier = "+E_{bar}" if "barrier" in run.energy else ""
    ax_b.set_title(rf"$(E_{{kin}}+E_s+E_b{barrier}+E_{{diss}}-W_{{ext}})(t) - (\cdot)(0)$", fontsize="small")

    _vector(ax_p, t, d.get("momentum"), "p", plotting.quantity_label("momentum", units))
    _vector(ax_l, t, d.get("angular_momentum"), "L",
            plotting.quantity_label("angular momentum", units))

    change = length_change(run)
    if change is not None:
        ax_len.plot(t, change)
        _plain_numbers(ax_len)
    else:
        _absent(ax_len, "length")
    ax_len.set_ylabel(length_change_label([run], units))
    if "flatness" in d:
        ax_flat.plot(t, d["flatness"])
    else:
        _absent(ax_flat, "flatness")
    ax_flat.set_ylabel(plotting.length_label("flatness", units))

    for ax, names in ((ax_steps, ("steps", "rejected_steps")),
                      (ax_it, ("newton_iterations", "linear_iterations"))):
        for name in names:
            if name in d:
                ax.step(t, d[name], where="post", label=name.replace("_", " "))
        if ax.lines:
            ax.legend(fontsize="small")
        else:
            _absent(ax, " and ".join(names))
        ax.set_ylabel("cumulative count")
    ax_it.set_yscale("symlog", linthresh=10)
    if n_contact:
        contact_panels(run, axes[N_PANELS:], units)

    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    title = run.scene() or run.path
    fig.suptitle(title if run.complete else f"{title} ({run.status})")
    return fig


OVERLAY = (  # (panel, y label kind, function run -> [nt] or None)
    ("kinetic energy", "energy", lambda r: r.energy.get("kinetic")),
    ("elastic energy (stretch + bend)", "energy",
     lambda r: r.energy["stretch"] + r.energy["bend"]
     if "stretch" in r.energy and "bend" in r.energy else None),
    ("balance drift / max energy", None, lambda r: _drift_or_none(r)),
    ("|momentum|", "momentum", lambda r: _norm(r.diagnostics.get("momentum"))),
    ("|angular momentum|", "angular momentum",
     lambda r: _norm(r.diagnostics.get("angular_momentum"))),
    ("centre-line length", "length change", length_change),
    ("flatness", "length", lambda r: r.diagnostics.get("flatness")),
    ("linear iterations (cumulative)", None, lambda r: r.diagnostics.get("linear_iterations")),
)


# With /contact in any of the runs (the others' lines are left out there).
OVERLAY_CONTACT = (
    ("active contacts", None, lambda r: r.contact.get("active")),
    ("smallest gap", "gap", lambda r: _positive(r.contact["min_gap"]) if "min_gap" in r.contact else None),
    ("normal force along −g", "force", force_up),
    ("friction work", "energy", lambda r: r.contact.get("friction_work")),
)


def _norm(v):
    return None if v is None else np.linalg.norm(np.asarray(v), axis=-1)


def _drift_or_none(run):
    try:
        return balance_drift(run)
    except ValueError:
        return None


def build_overlay(runs, names):
    """8 panels, each a quantity of every run against time, one colour a
    run; 12 when a run has obstacles (/contact): OVERLAY_CONTACT's too."""
    from .compare import run_colors  # the same colours as nuno-compare's overlay

    units = runs[0].units()
    colors = run_colors(len(runs), overlay=True)
    table = OVERLAY + (OVERLAY_CONTACT if any(r.contact for r in runs) else ())
    fig, axes = plotting.new_figure(len(table), ncols=2, panel_size=(5.5, 2.8))
    for ax, (title, kind, fn) in zip(axes, table):
        drawn = False
        for run, name, c in zip(runs, names, colors):
            y = fn(run)
            if y is not None:
                ax.plot(run.time, y, color=c, label=name)
                drawn = True
        if not drawn:
            _absent(ax, title)
        if kind == "length change":
            ax.set_ylabel(length_change_label(runs, units))
            _plain_numbers(ax)
        elif kind == "length":
            ax.set_ylabel(plotting.length_label(title, units))
        elif kind == "gap":
            ax.set_yscale("log")
            for dhat in sorted({contact_dhat(r) for r in runs if r.contact}):
                ax.axhline(dhat, color="k", ls="--", lw=0.8)
            ax.set_ylabel(plotting.length_label(title, units))
            ax.set_title("contact_dhat dashed", fontsize="small")
        elif kind == "force":
            for w in sorted({weight(r)[1] for r in runs if r.contact} - {None}):
                ax.axhline(w, color="k", ls=":", lw=0.9)
            ax.set_ylabel(plotting.quantity_label(kind, units).replace(kind, title, 1))
            ax.set_title("weight m |g| dotted", fontsize="small")
        elif kind:
            ax.set_ylabel(plotting.quantity_label(kind, units).replace(kind, title, 1))
        else:
            ax.set_ylabel(title)
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    if any(r.diagnostics.get("linear_iterations") is not None for r in runs):
        axes[N_PANELS - 1].set_yscale("symlog", linthresh=10)    # the linear iterations (OVERLAY's last)
    handles, texts = axes[0].get_legend_handles_labels()
    fig.legend(handles, texts, loc="outside lower center", ncols=min(len(runs), 6),
               fontsize="small")
    scenes = {r.scene() for r in runs} - {None}
    fig.suptitle(f"{', '.join(sorted(scenes)) or 'nuno'}: {len(runs)} runs")
    return fig


def _parser():
    p = cli.parser(__doc__.splitlines()[0], "timeseries")
    p.add_argument("runs", nargs="+", metavar="run",
                   help="nuno output file(s) (.h5); several are overlaid")
    cli.add_label_options(p)
    cli.add_output(p, "timeseries")
    return p


def _body(args):
    runs = [cli.load_run(path) for path in args.runs]
    names = cli.run_labels(runs, args.label, args.labels)
    if args.label and not args.labels:
        # colours in the order of the swept value, whatever the shell's glob order
        try:
            keys = [float(cli.run_value(r, args.label)) for r in runs]
        except (TypeError, ValueError):
            keys = list(range(len(runs)))
        order = sorted(range(len(runs)), key=lambda k: keys[k])
        runs, names = [runs[k] for k in order], [names[k] for k in order]
    fig = build_figure(runs[0]) if len(runs) == 1 else build_overlay(runs, names)
    plotting.save(fig, args.output or cli.default_output(args.runs[0], "timeseries"), args.dpi)


def main(argv=None) -> int:
    return cli.run_main(_body, _parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
