#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Identification and control pinned: two nuno builds must write the same
/identify and /control groups and positions, bit for bit.

    source tools/env.sh
    python3 bench/pinned_identify.py OLD/build/nuno build/nuno

Short cases of tests/python/test_identify.py and test_control.py: the
observation or target is made once by OLD; each build then runs a short fit
(-tao_max_it 3, so the TAO driver, the objective, the adjoint gradient, the
uncertainty and the results all run) and a -identify_check_gradient /
-control_check_gradient run, on 1 and 3 ranks. Every dataset of /identify and
/control, /position and /time, and the printed gradient-check lines are
compared (the check runs write no file: their lines only; root attributes
naming the build or the time, IGNORED, are skipped): the exit status is 1 when anything differs, 2 when a run fails. --new-options changes the NEW runs
only: a check that the comparison can fail (e.g. --new-options
"-ksp_rtol 1e-11" must give a non-zero exit).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

LIFT = "&scene scene='lift_release' /\n&time t_end=0.2 dt=0.01 /\n"
TRUE_MAT = "&material e_s=1 e_d=1 eta_s=1 eta_d=1 k_b=1 /\n"
START_MAT = "&material e_s=2 e_d=1 eta_s=3 eta_d=1 k_b=4 /\n"
WAVE_T = "scene='wave_point' keyframe_time=0,0.3,0.6"
WAVE_TRUE = WAVE_T + " keyframe_dx=0,5,-3 keyframe_dy=0,2,4 keyframe_dz=0,-10,15"
WAVE_GUESS = WAVE_T + " keyframe_dx=0,3,-1 keyframe_dy=0,1,2 keyframe_dz=0,-5,10"
WAVE_TIME = "&time t_end=0.6 dt=0.02 /\n"

# name: (reference groups, reference output keys, run groups (with {ref}), options)
CASES = {
    "identify_fit": (LIFT + TRUE_MAT, "output_interval=0.05",
                     LIFT + START_MAT + "&identify observed_file='{ref}' fit='e_s,eta_s,k_b' /\n",
                     ["-tao_max_it", "3"]),
    "identify_grad": (LIFT + TRUE_MAT, "output_interval=0.05",
                      LIFT + START_MAT + "&identify observed_file='{ref}' fit='e_s,e_d,eta_s,eta_d,k_b,total_mass' /\n",
                      ["-identify_check_gradient"]),
    "control_fit": (f"&scene {WAVE_TRUE} /\n" + WAVE_TIME, "output_interval=0.2 write_velocity=.true.",
                    f"&scene {WAVE_GUESS} /\n" + WAVE_TIME +
                    "&control target_file='{ref}' components='xyz' velocity_weight=0.3 keyframe_tikhonov=0.5"
                    " max_speed=100 /\n", ["-tao_max_it", "3"]),
    "control_grad": (f"&scene {WAVE_TRUE} /\n&material bending_model='paper' /\n" + WAVE_TIME,
                     "output_interval=0.3 write_velocity=.true.",
                     f"&scene {WAVE_GUESS} /\n&material bending_model='paper' /\n" + WAVE_TIME +
                     "&control target_file='{ref}' components='xz' /\n", ["-control_check_gradient"]),
}
RANKS = (1, 3)
# Root attributes that name the build or the moment of the run, not its results.
IGNORED = {"@program_version"}


def nuno(exe, workdir, name, text, nranks, options=()):
    nml = workdir / f"{name}.nml"
    nml.write_text(text)
    proc = subprocess.run(["mpiexec", "-n", str(nranks), "--oversubscribe", exe, nml.name, *options],
                          cwd=workdir, capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        print(proc.stdout[-2000:], proc.stderr[-2000:])
        print(f"{name}: {exe} failed ({proc.returncode})", file=sys.stderr)
        sys.exit(2)
    return proc.stdout, workdir / f"{name}.h5"


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.split("/")[0] in ("identify", "control", "position", "time"):
                out[name] = obj[()]
        f.visititems(visit)
        for k, v in f.attrs.items():
            out["@" + k] = v
    return out


def same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind in "fc" and b.dtype.kind in "fc":
        return a.shape == b.shape and a.tobytes() == b.tobytes()
    return a.shape == b.shape and bool(np.all(a == b))


def checks(text):
    """The gradient-check lines, and the objective lines of the TAO monitor."""
    return [l for l in text.splitlines() if re.search(r"(identify|control): (gradient|it|objective)", l)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--new-options", default="",
                    help="PETSc options of the NEW runs only: a check that the comparison can fail")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated subset of " + ", ".join(CASES))
    args = ap.parse_args()
    old, new = str(Path(args.old).resolve()), str(Path(args.new).resolve())
    bad = 0
    with tempfile.TemporaryDirectory(prefix="pinned_identify_") as tmp:
        for case in args.cases.split(","):
            refg, refout, rung, opts = CASES[case]
            for nranks in RANKS:
                d = Path(tmp) / f"{case}.{nranks}"
                d.mkdir()
                nuno(old, d, "ref", refg + f"&output output_file='ref.h5' {refout} /\n", 1)
                res = {}
                for tag, exe in (("old", old), ("new", new)):
                    # the same file names in each build's own directory (the
                    # input text is stored in the output)
                    sub = d / tag
                    sub.mkdir()
                    shutil.copy(d / "ref.h5", sub / "ref.h5")
                    text = rung.format(ref="ref.h5") + "&output output_file='run.h5' /\n"
                    extra = args.new_options.split() if tag == "new" else []
                    out, h5 = nuno(exe, sub, "run", text, nranks, opts + extra)
                    res[tag] = (datasets(h5) if h5.exists() else {}, checks(out))
                (do, lo), (dn, ln) = res["old"], res["new"]
                diff = sorted(k for k in set(do) | set(dn)
                              if k not in IGNORED and (k not in do or k not in dn or not same(do[k], dn[k])))
                grad = "-identify_check_gradient" in opts or "-control_check_gradient" in opts
                if not grad and not any(k.startswith(("identify", "control")) for k in dn):
                    diff.append("(no /identify or /control group)")
                if grad and not any("gradient" in l for l in ln):
                    diff.append("(no gradient lines)")
                if lo != ln:
                    diff.append("(printed lines)")
                status = "bitwise" if not diff else "DIFFERS: " + ", ".join(diff)
                print(f"{case:14s} np={nranks}  {len(dn):3d} datasets, {len(ln):2d} lines  {status}", flush=True)
                bad |= bool(diff)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
