# SPDX-License-Identifier: BSD-2-Clause
"""The figures of docs/identification.md: one deformation control and the report's Fig. 3 scene identified.

    source tools/env.sh && python3 bench/identification_figures.py          # both (a few minutes here)
    python3 bench/identification_figures.py --only control --skip-run       # re-plot from runs/identification

control (docs/figures/control_wave_point.png): wave_point with the energy
bending model (k_b = 10, the Fig. 5 scene's energy variant), dt 0.02 s. The
target is nuno's own motion under a known 3-D path of the corner (lifted
and drawn in over the cloth: keyframes at 0.5, 1.0, 1.5 s, then held), its
positions and velocities at t = 2 s. The control starts from another path
(TARGET_PATH against GUESS_PATH below) and optimises all nine steps
(components xyz, max_speed 100 mm/s, velocity_weight 0.01 s^2), 100 TAO
iterations at most (-tao_max_it 100: the last digits come slowly, 200
iterations reach an objective of 1e-7 mm^2).

identify (docs/figures/identify_lift_release.png): lift_release (Fig. 3)
with the energy bending model, the corrected model of the report's own
discussion (k_b = 10, eta_b = 0), 0 to 1 s at dt 0.01 s, observed at every
node every 0.05 s with 1 % noise (of the RMS displacement, seed 3); the
fit of e_s, e_d, eta_s, eta_d, k_b starts 2.5 times off.

Runs (namelists, .h5, logs) go to --rundir, the figures to --outdir; the
run's own summary (the lines the program prints at the end: objective,
fitted values or keyframes, cost of a gradient) is echoed.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from postprocess import cli, control_plot, identify_plot, plotting  # noqa: E402
from postprocess.reader import read_states  # noqa: E402
from postprocess.report_figures import Case, RunError, run_case  # noqa: E402

# mm, relative to rest, at keyframe_time 0, 0.5, 1.0, 1.5 s: x, y, z rows.
TARGET_PATH = np.array([[0.0, 5.0, 20.0, 45.0], [0.0, 10.0, 30.0, 35.0], [0.0, 35.0, 35.0, 8.0]])
GUESS_PATH = np.array([[0.0, 0.0, 15.0, 30.0], [0.0, 0.0, 10.0, 20.0], [0.0, 20.0, 20.0, 0.0]])
WAVE = ("&material bending_model='energy' k_b=10 eta_b=0 /\n&time t_end=2.0 dt=0.02 /\n")

TRUE = {"e_s": 1.0, "e_d": 1.0, "eta_s": 1.0, "eta_d": 1.0, "k_b": 10.0}
GUESS = {"e_s": 2.5, "e_d": 0.4, "eta_s": 2.5, "eta_d": 0.4, "k_b": 25.0}
LIFT = "&scene scene='lift_release' /\n&time t_end=1.0 dt=0.01 /\n"
NOISE, SEED = 0.01, 3


def wave_scene(path):
    keys = " ".join(f"keyframe_d{c}={','.join(f'{v:g}' for v in path[n])}" for n, c in enumerate("xyz"))
    return f"&scene scene='wave_point' n_keyframes=4 keyframe_time=0,0.5,1.0,1.5 {keys} /\n"


def lift_material(values):
    return ("&material bending_model='energy' eta_b=0 "
            + " ".join(f"{k}={v:g}" for k, v in values.items()) + " /\n")


def output(name, interval, velocity=False):
    v = " write_velocity=.true." if velocity else ""
    return f"&output output_file='{name}.h5' output_interval={interval:g}{v} /\n"


def run(name, text, args):
    """Run one namelist in the run directory; its .h5, and the summary lines."""
    t0 = time.perf_counter()
    print(f"{name} ...", end=" ", flush=True)
    h5 = run_case(Case(name, "", name), text, Path(args.rundir), str(Path(args.exe).resolve()), args.nranks,
                  shlex.split(args.mpiexec))
    print(f"{time.perf_counter() - t0:.1f} s", flush=True)
    log = (Path(args.rundir) / f"{name}.log").read_text(errors="replace").splitlines()
    for line in log:
        if line.startswith(("control: objective", "control: keyframe", "control: TAO", "control: cost",
                            "identify: objective", "identify: fitted", "identify: TAO", "identify: cost")):
            print("   ", line)
    return h5


def control(args):
    rd = Path(args.rundir)
    if not args.skip_run:
        run("control_target", wave_scene(TARGET_PATH) + WAVE + output("control_target", 2.0, True), args)
        run("control_initial", wave_scene(GUESS_PATH) + WAVE + output("control_initial", 0.1), args)
        run("control", wave_scene(GUESS_PATH) + WAVE
            + "&output output_file='control.h5' output_interval=0.1 petsc_options='-tao_max_it 100' /\n"
            + "&control target_file='control_target.h5' components='xyz' max_speed=100 velocity_weight=0.01 /\n",
            args)
    fig = control_plot.build_figure(cli.load_run(rd / "control.h5"),
                                    read_states(rd / "control_target.h5"),
                                    cli.load_run(rd / "control_initial.h5"), TARGET_PATH.T)
    return fig, "control_wave_point.png"


def identify(args):
    rd = Path(args.rundir)
    if not args.skip_run:
        clean = run("identify_truth", LIFT + lift_material(TRUE) + output("identify_truth", 0.05), args)
        with h5py.File(clean, "r") as f:
            t, x = f["time"][()], f["position"][()]
        rng = np.random.default_rng(SEED)
        scale = NOISE * np.sqrt(np.mean((x[1:] - x[0]) ** 2))
        with h5py.File(rd / "identify_observed.h5", "w") as f:
            f["time"] = t
            f["position"] = x + scale * rng.standard_normal(x.shape)
        print(f"    observed: {len(t)} times, noise {scale:.3g} mm (1 % of the RMS displacement)")
        run("identify_initial", LIFT + lift_material(GUESS) + output("identify_initial", 0.02), args)
        run("identify", LIFT + lift_material(GUESS) + output("identify", 0.02)
            + "&identify observed_file='identify_observed.h5' fit='e_s,e_d,eta_s,eta_d,k_b' /\n", args)
    fig = identify_plot.build_figure(cli.load_run(rd / "identify.h5"),
                                     read_states(rd / "identify_observed.h5"),
                                     cli.load_run(rd / "identify_initial.h5"), TRUE)
    return fig, "identify_lift_release.png"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", choices=("control", "identify"), default=None, help="one of the two figures")
    p.add_argument("--skip-run", action="store_true", help="re-plot the runs already in --rundir")
    p.add_argument("--rundir", default=str(ROOT / "runs" / "identification"))
    p.add_argument("--outdir", default=str(ROOT / "docs" / "figures"))
    p.add_argument("--nranks", type=int, default=1, help="MPI ranks per run (default 1)")
    p.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    p.add_argument("--mpiexec", default="mpiexec")
    p.add_argument("--dpi", type=int, default=100)
    args = p.parse_args(argv)
    Path(args.rundir).mkdir(parents=True, exist_ok=True)
    Path(args.outdir).mkdir(parents=True, exist_ok=True)
    for name, build in (("control", control), ("identify", identify)):
        if args.only not in (None, name):
            continue
        try:
            fig, png = build(args)
        except (RunError, FileNotFoundError, ValueError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
        out = Path(args.outdir) / png
        plotting.save(fig, out, args.dpi)
        print(f"wrote {out}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
