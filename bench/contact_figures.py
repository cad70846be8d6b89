#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The figures and animations of docs/contact.md: each contact scene of
input/ (drop_table, drape_sphere, table_edge, gripper, fold_table) run as
shipped on 2 ranks into runs/contact/ (drop_table with output every 5 ms,
for the instants around its impact), then drawn by postprocess.contact_plot:
docs/figures/contact-<scene>.png and contact-<scene>.gif (at most 60
frames, 400 px; 40 for the gripper and the fold, slow motions: each GIF
below 0.5 MB). drop_table and the gripper are drawn as side sections
(contact_plot --view side: a 5 cm drop onto a 1 m table and a pinch
between 1 cm fingers do not show in a 3-D box at equal scales); the
gripper also zoomed on its fingers (contact-gripper-pinch.png).

impact_energy: drop_table's energy balance across its impact
(contact-drop_table-energy.png), with output at every step: as shipped at
dt = 1, 0.5, 0.25 and 0.1 ms, and with a barrier the step resolves
(contact_dhat = 1 cm, contact_stiffness = 1.5 N/m) at dt = 1, 0.5 and 0.25
ms; prints what each run lost (docs/contact.md, "Where the impact's energy
goes").

    source tools/env.sh
    python3 bench/contact_figures.py                 # some 10 minutes
    python3 bench/contact_figures.py --skip-run      # re-draw from runs/contact/
    python3 bench/contact_figures.py --scenes drop_table impact_energy --outdir /tmp/fig
"""
import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from postprocess import contact_plot, plotting  # noqa: E402
from postprocess.reader import read_run  # noqa: E402

SIDE_XZ = ("--view", "side", "--plane", "xz")
# scene: {"set": -nuno_set beyond the output file, "figures": [(name suffix, times [s],
# contact_plot arguments)], "gif": contact_plot arguments of the animation}
SCENES = {
    # from the side, each panel zoomed on the cloth and the table under it (the vertical
    # stretched): falling, reaching the barrier, stopped, settled
    "drop_table": {"set": "output_interval=0.005",
                   "figures": [("", (0.0, 0.05, 0.095, 0.1, 0.105, 0.5),
                                (*SIDE_XZ, "--zoom", "each", "--aspect", "auto"))],
                   "gif": (*SIDE_XZ, "--aspect", "auto")},
    "drape_sphere": {"figures": [("", (0.0, 0.3, 0.6, 1.0), ("--elev", "20"))], "gif": ("--elev", "20")},
    # the cloth lies on the box's top: the box drawn first (contact_plot --solids-first)
    "table_edge": {"figures": [("", (0.0, 0.3, 0.8, 1.5), ("--elev", "25", "--azim", "-60", "--solids-first"))],
                   "gif": ("--elev", "25", "--azim", "-60", "--solids-first")},
    # along the fingers (y): the hanging cloth (gravity +x, down in the figure) and the
    # fingers' sections, before, while and after the pinch; then zoomed on the fingers
    "gripper": {"figures": [("", (0.0, 0.2, 0.7, 1.5, 2.5), SIDE_XZ),
                            ("-pinch", (0.0, 0.2, 0.7, 1.5, 2.5), (*SIDE_XZ, "--zoom", "obstacles"))],
                "gif": (*SIDE_XZ, "--aspect", "auto", "--frames", "40")},
    # along the fold line, from the far half's side
    "fold_table": {"figures": [("", (0.0, 0.9, 1.6, 2.2), ("--elev", "20", "--azim", "-105"))],
                   "gif": ("--elev", "20", "--azim", "-105", "--frames", "40")},
}
IMPACT = "impact_energy"
# (label, -nuno_set of drop_table, time steps [s], t_end [s])
SHIPPED = ("as shipped: contact_dhat = 1 mm, contact_stiffness = 1 N/m", "", (1e-3, 5e-4, 2.5e-4, 1e-4), 0.2)
RESOLVED = ("resolved barrier: contact_dhat = 1 cm, contact_stiffness = 1.5 N/m",
            "contact_dhat=1e-2,contact_stiffness=1.5", (1e-3, 5e-4, 2.5e-4), 0.3)


def run_nuno(a, rundir: Path, h5: Path, nml: Path, extra: str) -> bool:
    sets = f"output_file='{h5.name}'" + (f",{extra}" if extra else "")
    cmd = [a.mpiexec, "-n", "2", "--oversubscribe", a.exe, str(nml), "-nuno_set", sets]
    p = subprocess.run(cmd, cwd=rundir, capture_output=True, text=True)
    if p.returncode != 0:
        print((p.stdout + p.stderr)[-2000:], file=sys.stderr)
        print(f"contact_figures.py: {' '.join(cmd)} failed", file=sys.stderr)
    return p.returncode == 0


def draw_scene(a, scene: str, rundir: Path, outdir: Path) -> int:
    h5 = rundir / f"{scene}.h5"
    spec = SCENES[scene]
    if not a.skip_run and not run_nuno(a, rundir, h5, ROOT / "input" / f"{scene}.nml", spec.get("set", "")):
        return 1
    # the labels' unit: the file's (the scenes say &scene units = 'SI')
    written = []
    for suffix, times, extra in spec["figures"]:
        png = outdir / f"contact-{scene}{suffix}.png"
        if contact_plot.main([str(h5), "-o", str(png), "--dpi", "100", *extra,
                              "--times", *map(str, times)]) != 0:
            return 1
        written.append(png)
    gif = outdir / f"contact-{scene}.gif"
    with tempfile.TemporaryDirectory() as tmp:     # the script's own PNG of the animation's views: not kept
        if contact_plot.main([str(h5), "-o", str(Path(tmp) / "views.png"), "--gif", str(gif), "--dpi", "40",
                              *spec["gif"]]) != 0:
            return 1
    for f in written + [gif]:
        print(f"{f.relative_to(ROOT) if f.is_relative_to(ROOT) else f}: {f.stat().st_size / 1024:.0f} KB")
    return 0


# ---------------------------------------------------------------- the impact's energy


def impact(run) -> dict:
    """The first impact of a drop: k0, the last output step before any
    node-obstacle pair is within the barrier's reach; k1, the first step
    after it with none again (the cloth has bounced off; else 20 ms
    later); the balance residual's change over [k0, k1], the kinetic energy
    at k0, the physical dissipation (material damping and friction) and the
    friction work over it, and the highest mean height of the cloth above
    the table after k1 (its rebound); the smallest gap reached and omega dt
    there."""
    active = np.asarray(run.contact["active"])
    k0 = int(np.argmax(active > 0)) - 1
    dt = float(run.run_info["dt"])
    after = np.nonzero(active[k0 + 2:] == 0)[0]
    k1 = k0 + 2 + int(after[0]) if len(after) else min(run.nt - 1, k0 + int(round(0.02 / dt)))
    b = run.energy_balance() - run.energy_balance()[0]
    e = run.energy
    # the barrier's stiffness at the smallest gap reached, against an inner node's mass:
    # omega^2 = kappa b''(s) / m (docs/model.md section 10), and omega dt
    keys = run.config["contact"]
    kappa, dhat = float(keys["contact_stiffness"]), float(keys["contact_dhat"])
    gap = float(run.contact["min_gap_run"][k1])
    b2 = -2.0 * np.log(gap / dhat) - 4.0 * (gap - dhat) / gap + (gap - dhat) ** 2 / gap ** 2
    omega_dt = np.sqrt(kappa * b2 / float(np.max(run.mass))) * dt
    table = float(np.ravel(contact_plot.obstacles(run)[0].point)[2])
    height = np.array([run.position[k][..., 2].mean() for k in range(run.nt)]) - table
    return {"dt": dt, "k0": k0, "k1": k1, "t0": float(run.time[k0]), "t1": float(run.time[k1]),
            "kinetic": float(e["kinetic"][k0]), "loss": float(b[k0] - b[k1]),
            "dissipated": float(e["dissipated"][k1] - e["dissipated"][k0]),
            "friction": float(run.contact["friction_work"][k1] - run.contact["friction_work"][k0]),
            "drift_before": float(-b[k0]), "rebound": float(height[k1:].max()),
            "min_gap": gap, "omega_dt": float(omega_dt),
            "mgh": float(np.sum(run.mass)) * 9.81 * float(height[0]),
            "time": np.asarray(run.time), "balance": b, "height": height}


def impact_runs(a, rundir: Path):
    """{study: [(dt, run)]} of the two studies (running them unless --skip-run)."""
    out = {}
    for label, sets, dts, t_end in (SHIPPED, RESOLVED):
        runs = []
        for dt in dts:
            tag = "resolved" if sets else "shipped"
            h5 = rundir / f"impact-{tag}-dt{dt:g}.h5"
            extra = f"t_end={t_end},dt={dt},output_interval={dt},write_velocity=.false." + (f",{sets}" if sets else "")
            if not a.skip_run and not run_nuno(a, rundir, h5, ROOT / "input" / "drop_table.nml", extra):
                return None
            runs.append((dt, read_run(h5)))
        out[label] = runs
    return out


def dt_colours(n: int) -> list:
    """n colours of the perceptually uniform map, the largest dt darkest."""
    from matplotlib import colormaps
    cmap = colormaps[plotting.CMAP]
    return [cmap(0.85 * j / max(n - 1, 1)) for j in range(n)]


def impact_figure(studies):
    """Four panels: as shipped at dt = 1 ms, the energies around the impact;
    the balance residual of every dt of each study; the resolved study's
    mean height (its rebounds)."""
    fig, axes = plotting.new_figure(4, ncols=2, panel_size=(5.6, 3.4))
    ax_e, ax_s, ax_r, ax_h = axes
    shipped, resolved = studies[SHIPPED[0]], studies[RESOLVED[0]]
    dt, run = shipped[0]
    im = impact(run)
    t, e = im["time"], run.energy
    window = (t >= im["t0"] - 0.01) & (t <= im["t0"] + 0.03)
    for name, label, style in (("kinetic", "kinetic", "o-"), ("barrier", "barrier", "s-"),
                               ("dissipated", "dissipated (damping, friction)", "^-")):
        ax_e.plot(t[window], e[name][window], style, ms=3, lw=1, label=label)
    ax_e.plot(t[window], im["balance"][window], "k.-", ms=4, lw=1.2, label="balance residual B(t) \u2212 B(0)")
    ax_e.axhline(-im["kinetic"], color="C3", ls="--", lw=0.9,
                 label=f"\u2212 kinetic energy before contact ({im['kinetic']:.4f} J)")
    ax_e.set_title(f"{SHIPPED[0].split(':')[0]}, dt = {dt * 1e3:g} ms: one output a step", fontsize="small")
    ax_e.set_ylabel(plotting.quantity_label("energy", "m"))
    ax_e.legend(fontsize="x-small", loc="center right")
    for ax, runs, (label, *_) in ((ax_s, shipped, SHIPPED), (ax_r, resolved, RESOLVED)):
        for (dt, run), c in zip(runs, dt_colours(len(runs))):
            im = impact(run)
            ax.plot(im["time"], im["balance"], color=c,
                    label=f"dt = {dt * 1e3:g} ms: \u2212{im['loss']:.4f} J over the first contact")
        ax.set_title(label, fontsize="small")
        ax.set_ylabel("balance residual B(t) \u2212 B(0) [J]")
        ax.legend(fontsize="x-small", loc="center left" if runs is shipped else "lower left")
    for (dt, run), c in zip(resolved, dt_colours(len(resolved))):
        im = impact(run)
        ax_h.plot(im["time"], im["height"] * 1e3, color=c,
                  label=f"dt = {dt * 1e3:g} ms: rebounds to {im['rebound'] * 1e3:.0f} mm")
    ax_h.axhline(10.0, color="k", ls="--", lw=0.8, label="contact_dhat = 1 cm")
    ax_h.set_title("resolved barrier: the cloth's mean height above the table", fontsize="small")
    ax_h.set_ylabel("mean height [mm]")
    ax_h.legend(fontsize="x-small", loc="upper right")
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    fig.suptitle("drop_table: where the impact's energy goes (backward Euler, the only integrator with obstacles)")
    return fig


def impact_energy(a, rundir: Path, outdir: Path) -> int:
    studies = impact_runs(a, rundir)
    if studies is None:
        return 1
    for label, runs in studies.items():
        print(label)
        for dt, run in runs:
            im = impact(run)
            print(f"  dt = {dt:g} s: contact from t = {im['t0']:.5f} s; kinetic energy then {im['kinetic']:.5f} J; "
                  f"balance residual drop over [{im['t0']:.5f}, {im['t1']:.5f}] s: {im['loss']:.5f} J "
                  f"({im['loss'] / im['mgh']:.3f} m g h); physical dissipation {im['dissipated']:.2e} J "
                  f"(friction {im['friction']:.1e} J); drift before contact {im['drift_before']:.5f} J; "
                  f"whole run: {-im['balance'][-1]:.5f} J ({-im['balance'][-1] / im['mgh']:.3f} m g h); "
                  f"rebound {im['rebound'] * 1e3:.1f} mm; smallest gap {im['min_gap']:.2e} m, "
                  f"where omega dt = {im['omega_dt']:.2g}")
    fig = impact_figure(studies)
    png = outdir / "contact-drop_table-energy.png"
    plotting.save(fig, png, 100)
    print(f"{png.relative_to(ROOT) if png.is_relative_to(ROOT) else png}: {png.stat().st_size / 1024:.0f} KB")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--scenes", nargs="+", default=None, choices=sorted(SCENES) + [IMPACT],
                    help="default: every one of them that input/ has, and impact_energy")
    ap.add_argument("--rundir", default=str(ROOT / "runs" / "contact"))
    ap.add_argument("--outdir", default=str(ROOT / "docs" / "figures"))
    ap.add_argument("--skip-run", action="store_true", help="draw the runs already in --rundir")
    a = ap.parse_args(argv)
    scenes = a.scenes or [s for s in SCENES if (ROOT / "input" / f"{s}.nml").is_file()] + [IMPACT]
    rundir, outdir = Path(a.rundir), Path(a.outdir)
    rundir.mkdir(parents=True, exist_ok=True)
    outdir.mkdir(parents=True, exist_ok=True)
    for scene in scenes:
        rc = impact_energy(a, rundir, outdir) if scene == IMPACT else draw_scene(a, scene, rundir, outdir)
        if rc != 0:
            return rc
    return 0


if __name__ == "__main__":
    sys.exit(main())
