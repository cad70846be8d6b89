#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""Behaviour pinned: two nuno builds must write the same positions, bit for bit
(or, with --tolerance, to the solver's tolerance).

    source tools/env.sh
    python3 bench/pinned.py OLD/build/nuno build/nuno
    python3 bench/pinned.py OLD/build/nuno build/nuno --intended hang.np3=1e-12
    python3 bench/pinned.py OLD/build/nuno build/nuno --tolerance 1e-6

Every scene of input/*.nml runs as a short fixed-step run (40 steps of
1 ms, output every 10) on 1 and 3 ranks with each build, plus a few cases
that take the solver's other paths (S by stencil offset for the multigrid
on 21 x 21 lattices and S in AIJ, each with each bending model; PETSc's
multigrid; Baraff-Witkin's one linear solve; the 6-dof Jacobian; the
matrix-free 6-dof product of a backtracking line search) and one adaptive
run (-ts_adapt_type basic). The output positions (/position, every output step)
and times are compared: the table gives max |difference| [the scene's
length unit] and whether the files agree bitwise. The exit status is 1
when a case differs, unless it is listed with --intended CASE=SIZE (a
defect fix that changes results on purpose) and differs by at most SIZE;
2 when a run fails.

--tolerance T judges a change of the solver itself (a preconditioner, an
inner tolerance), whose positions agree only to the solver's tolerance:
a case passes when max |difference| / size <= T, size the scene's extent
(the largest range of a coordinate over the old run's positions, all
output steps); the table prints that ratio for every case.

A scene the old build cannot run (a key it does not know) is no comparison:
leave it out with --skip (e.g. scenes newer than the old build).

--new-options and --new-set change the NEW runs only: a check that the
comparison can fail (e.g. --new-set e_s=100.000001 or --new-options
"-reduced_ksp_rtol 1e-6" must give a non-zero exit).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from postprocess.reader import read_run  # noqa: E402  (the users' reader)

# 40 steps of 1 ms, output every 10: a few seconds a run on 11 x 11.
FIXED = "dt=1e-3,t_end=0.04,output_interval=0.01"
# Extra cases: (name, input file, -nuno_set beyond FIXED, PETSc options).
# S of an 11 x 11 lattice is a BAIJ matrix filled from the element buffer
# (too few levels for nuno's multigrid); of 21 x 21, by stencil offset for
# it; with -reduced_dm_mat_type aij, written into the CSR arrays: each
# storage with each bending model.
AIJ = ["-reduced_dm_mat_type", "aij"]
EXTRA = [
    ("lift_release.21", "lift_release.nml", "nx=21,ny=21", []),
    ("lift_release_energy.21", "lift_release_energy.nml", "nx=21,ny=21", []),
    ("wave_point.21", "wave_point.nml", "nx=21,ny=21", []),
    ("lift_release.aij", "lift_release.nml", "", AIJ),
    ("wave_point.aij", "wave_point.nml", "", AIJ),
    ("hang.aij", "hang.nml", "nx=11,ny=11", AIJ),
    ("hang.pcmg", "hang.nml", "", ["-nuno_mg", "petsc"]),
    ("hang.bw", "hang.nml", "", ["-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3"]),
    ("hang.full", "hang.nml", "nx=11,ny=11", ["-nuno_jacobian", "full"]),
    # the 6-dof product (the line search's slope): the element products alone
    ("hang.bt", "hang.nml", "", ["-snes_linesearch_type", "bt"]),
]
# The adaptive run: its steps follow the error estimate, so any change in
# round-off changes the step sequence, and then every position.
ADAPTIVE = ("hang.adaptive", "hang.nml", "t_end=0.2,output_interval=0.05", ["-ts_adapt_type", "basic"])
RANKS = (1, 3)


def cases(scenes: list[Path]) -> list[tuple[str, Path, str, list[str]]]:
    out = []
    for nml in scenes:
        out.append((nml.stem, nml, FIXED, []))
    for name, file, extra, opts in EXTRA:
        out.append((name, ROOT / "input" / file, FIXED + ("," + extra if extra else ""), opts))
    name, file, extra, opts = ADAPTIVE
    out.append((name, ROOT / "input" / file, "dt=1e-3," + extra, opts))
    return out


def run(exe: str, np_: int, nml: Path, sets: str, opts: list[str], out: Path, timeout: float) -> str | None:
    """One run in out's directory; None, or why it failed."""
    cmd = [os.environ.get("NUNO_MPIEXEC", "mpiexec"), "-n", str(np_), "--oversubscribe", exe, str(nml),
           "-nuno_set", f"{sets},output_file='{out.name}'", *opts]
    try:
        p = subprocess.run(cmd, cwd=out.parent, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"timed out after {timeout:.0f} s: {' '.join(cmd)}"
    if p.returncode != 0:
        tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
        return f"exit {p.returncode}: {' '.join(cmd)}: {' | '.join(tail)}"
    return None


def compare(a: Path, b: Path) -> tuple[int, float, float, bool, str]:
    """(output steps, max |position difference|, the scene's extent (a's
    largest coordinate range over all outputs), bitwise, note)."""
    with read_run(a, load_velocity=False) as ra, read_run(b, load_velocity=False) as rb:
        if not (ra.complete and rb.complete):
            return 0, float("nan"), float("nan"), False, f"status {ra.status!r} / {rb.status!r}"
        pa = np.asarray(ra.position)
        pb = np.asarray(rb.position)
        note = ""
        if pa.shape != pb.shape:
            n = min(len(pa), len(pb))
            note = f"output steps {len(pa)} / {len(pb)}"
            pa, pb = pa[:n], pb[:n]
        diff = float(np.max(np.abs(pa - pb))) if pa.size else 0.0
        # positions (outputs, ..., 3): the range of each coordinate
        size = float(np.max(np.ptp(pa.reshape(-1, pa.shape[-1]), axis=0))) if pa.size else float("nan")
        same = pa.shape == pb.shape and pa.tobytes() == pb.tobytes() and not note
        if ra.time.tobytes() != rb.time.tobytes():
            same = False
            note = (note + "; " if note else "") + "output times differ"
        return len(pa), diff, size, same, note


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", help="the reference build's nuno (OLD/build/nuno)")
    ap.add_argument("new", help="the build under test (NEW/build/nuno)")
    ap.add_argument("--intended", action="append", default=[], metavar="CASE=SIZE",
                    help="a difference made on purpose: CASE (as in the table, e.g. hang.np3, or a scene for "
                         "both rank counts) may differ by at most SIZE; repeatable")
    ap.add_argument("--tolerance", type=float, default=None, metavar="T",
                    help="pass a case whose max |diff| / the scene's extent is at most T (a solver change judged "
                         "against the solver's tolerance); default: bitwise")
    ap.add_argument("--only", nargs="*", default=None, help="run only these cases (names as in the table, no .npN)")
    ap.add_argument("--skip", nargs="*", default=[], help="leave these cases out (names as in the table, no .npN)")
    ap.add_argument("--new-set", default="", help="-nuno_set keys added to NEW's runs only (a check that it can fail)")
    ap.add_argument("--new-options", default="", help="PETSc options added to NEW's runs only (as --new-set)")
    ap.add_argument("--keep", metavar="DIR", help="write the runs here and keep them (default: a temporary directory)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds a run may take (default 120)")
    args = ap.parse_args()

    for key, value in (("OMPI_ALLOW_RUN_AS_ROOT", "1"), ("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"),
                       ("OMPI_MCA_rmaps_base_oversubscribe", "1"), ("OMPI_MCA_mpi_yield_when_idle", "1")):
        os.environ.setdefault(key, value)
    exes = {"old": os.path.realpath(args.old), "new": os.path.realpath(args.new)}
    for tag, exe in exes.items():
        if not os.access(exe, os.X_OK):
            print(f"pinned: {tag} build '{exe}' is not an executable", file=sys.stderr)
            return 2
    intended = {}
    for item in args.intended:
        name, sep, size = item.partition("=")
        try:
            intended[name] = float(size)
        except ValueError:
            sep = ""
        if not sep:
            print(f"pinned: --intended '{item}': expected CASE=SIZE", file=sys.stderr)
            return 2

    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="nuno-pinned-"))
    work.mkdir(parents=True, exist_ok=True)
    todo = cases(sorted((ROOT / "input").glob("*.nml")))
    if args.only is not None:
        todo = [c for c in todo if c[0] in args.only]
    todo = [c for c in todo if c[0] not in args.skip]
    print(f"old: {exes['old']}\nnew: {exes['new']}")
    if args.new_set or args.new_options:
        print("NEW runs only:" + (f" -nuno_set +'{args.new_set}'" if args.new_set else "") + f" {args.new_options}")
    if args.tolerance is not None:
        print(f"tolerance: max |diff| / extent <= {args.tolerance:g}")
    print(f"{'case':<28} {'ranks':>5} {'steps':>5} {'max |diff|':>11} {'/ extent':>10}  bitwise")
    worst = (0.0, "")
    failed = differ = 0
    start = time.time()
    try:
        for name, nml, sets, opts in todo:
            for np_ in RANKS:
                label = f"{name}.np{np_}"
                files = {}
                err = None
                for tag, exe in exes.items():
                    s, o = sets, list(opts)
                    if tag == "new":
                        s += ("," + args.new_set) if args.new_set else ""
                        o += args.new_options.split()
                    files[tag] = work / f"{label}.{tag}.h5"
                    err = err or run(exe, np_, nml, s, o, files[tag], args.timeout)
                if err:
                    failed += 1
                    print(f"{name:<28} {np_:>5} {'-':>5} {'-':>11} {'-':>10}  RUN FAILED: {err}")
                    continue
                steps, diff, size, same, note = compare(files["old"], files["new"])
                rel = diff / size if size > 0 else (0.0 if diff == 0 else float("inf"))
                if rel >= worst[0]:   # (False for a NaN: an incomplete run, reported by its note)
                    worst = (rel, label)
                verdict = "yes" if same else "NO"
                allowed = intended.get(label, intended.get(name))
                if not same:
                    if allowed is not None and diff <= allowed:
                        verdict = f"no, intended (<= {allowed:g})"
                    elif args.tolerance is not None and not note and rel <= args.tolerance:
                        verdict = "no, within tolerance"
                    else:
                        differ += 1
                if note:
                    verdict += f" ({note})"
                print(f"{name:<28} {np_:>5} {steps:>5} {diff:>11.3e} {rel:>10.2e}  {verdict}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    print(f"largest max |diff| / extent: {worst[0]:.2e} ({worst[1] or '-'})")
    print(f"{differ} case(s) differ, {failed} run(s) failed; {time.time() - start:.0f} s")
    if failed:
        return 2
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
