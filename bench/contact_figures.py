#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""The figures and animations of docs/contact.md: each contact scene of
input/ (drop_table, drape_sphere, table_edge, gripper, fold_table) run as
shipped on 2 ranks into runs/contact/, then drawn by
postprocess.contact_plot: docs/figures/contact-<scene>.png (four times)
and contact-<scene>.gif (at most 60 frames, 400 px; 40 for the gripper
and the fold, slow motions: each GIF below 0.5 MB).

    source tools/env.sh
    python3 bench/contact_figures.py                 # a few minutes
    python3 bench/contact_figures.py --skip-run      # re-draw from runs/contact/
    python3 bench/contact_figures.py --scenes drop_table --outdir /tmp/fig
"""
import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from postprocess import contact_plot  # noqa: E402

# scene: (times drawn [s], extra arguments of contact_plot)
SCENES = {
    "drop_table": ((0.0, 0.1, 0.2, 0.5), ("--elev", "20")),
    "drape_sphere": ((0.0, 0.3, 0.6, 1.0), ("--elev", "20")),
    # the cloth lies on the box's top: the box drawn first (contact_plot --solids-first)
    "table_edge": ((0.0, 0.3, 0.8, 1.5), ("--elev", "25", "--azim", "-60", "--solids-first")),
    # from below the fingers' line: the pinched line pulled 5 cm out of the cloth's plane
    "gripper": ((0.0, 0.7, 1.5, 2.5), ("--elev", "20", "--azim", "-125", "--frames", "40")),
    # along the fold line, from the far half's side
    "fold_table": ((0.0, 0.9, 1.6, 2.2), ("--elev", "20", "--azim", "-105", "--frames", "40")),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--scenes", nargs="+", default=None, choices=sorted(SCENES),
                    help="default: every one of them that input/ has")
    ap.add_argument("--rundir", default=str(ROOT / "runs" / "contact"))
    ap.add_argument("--outdir", default=str(ROOT / "docs" / "figures"))
    ap.add_argument("--skip-run", action="store_true", help="draw the runs already in --rundir")
    a = ap.parse_args(argv)
    scenes = a.scenes or [s for s in SCENES if (ROOT / "input" / f"{s}.nml").is_file()]
    rundir, outdir = Path(a.rundir), Path(a.outdir)
    rundir.mkdir(parents=True, exist_ok=True)
    outdir.mkdir(parents=True, exist_ok=True)
    for scene in scenes:
        h5 = rundir / f"{scene}.h5"
        if not a.skip_run:
            cmd = [a.mpiexec, "-n", "2", "--oversubscribe", a.exe, str(ROOT / "input" / f"{scene}.nml"),
                   "-nuno_set", f"output_file='{h5.name}'"]
            p = subprocess.run(cmd, cwd=rundir, capture_output=True, text=True)
            if p.returncode != 0:
                print((p.stdout + p.stderr)[-2000:], file=sys.stderr)
                print(f"contact_figures.py: {scene} failed", file=sys.stderr)
                return 1
        times, extra = SCENES[scene]
        # the labels' unit: the file's (the scenes say &scene units = 'SI')
        args = [str(h5), "-o", str(outdir / f"contact-{scene}.png"), "--gif", str(outdir / f"contact-{scene}.gif"),
                "--dpi", "100", *extra]
        if times:
            args += ["--times", *map(str, times)]
        if contact_plot.main(args) != 0:
            return 1
        for ext in ("png", "gif"):
            f = outdir / f"contact-{scene}.{ext}"
            print(f"{f.relative_to(ROOT) if f.is_relative_to(ROOT) else f}: {f.stat().st_size / 1024:.0f} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
