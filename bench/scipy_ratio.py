#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""SciPy's BDF against nuno on hang 21 x 21 to t = 1 s, at equal final error
(docs/workprecision.md, "SciPy with a careful linear solve"): SciPy's
solve_ivp BDF with the exact sparse Jacobian of bench/scipy_cloth.py, once
with its own SuperLU factorisation and once with the diagonal pivots
(--lu nopivot), against nuno's adaptive bdf3 and bdf4 on one rank. The
errors are final position errors over the cloth size against nuno's bdf5 at
-ts_rtol 1e-11 (the reference of bench/workprecision.py). Times: SciPy's
process time around solve_ivp, nuno's /run wall_time (its time loop), each
the fastest of --repeat runs. About 2 minutes on an idle 2-core machine.

    source tools/env.sh && python3 bench/scipy_ratio.py
"""
import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))

import scipy_cloth  # noqa: E402
from workprecision import INF, Nuno  # noqa: E402

SCENE = dict(key="hang 21 x 21", input="hang.nml", sets={}, t_end=1.0)
NUNO = [f"-ts_type bdf -ts_bdf_order {k} -ts_adapt_type basic {INF} -ts_rtol {r:g}"
        for k, r in ((3, 1e-3), (4, 1e-3), (3, 1e-5))]
REFERENCE = f"-ts_type bdf -ts_bdf_order 5 -ts_adapt_type basic {INF} -ts_rtol 1e-11"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--rtols", type=float, nargs="+", default=[1e-3, 1e-5], help="SciPy's rtol values")
    a = p.parse_args(argv)
    cloth_cfg = scipy_cloth.read_config(ROOT / "input" / SCENE["input"], SCENE["sets"])
    size = scipy_cloth.Cloth(cloth_cfg).size
    with tempfile.TemporaryDirectory() as work:
        nuno = Nuno(Path(a.exe), Path(work), sys.stderr)
        ref = nuno.run(SCENE, REFERENCE)
        if ref["rc"] != 0:
            raise SystemExit(f"reference failed: {ref.get('error_message')}")

        def err(x):
            return float(np.max(np.linalg.norm(np.asarray(x).reshape(-1, 3) - ref["x"].reshape(-1, 3), axis=1)) / size)

        rows = []
        for opts in NUNO:
            runs = [nuno.run(SCENE, opts) for _ in range(a.repeat)]
            best = min(runs, key=lambda r: r["time_s"])
            rows.append(("nuno", opts, err(best["x"]), best["time_s"], best["steps"]))
        for lu in ("superlu", "nopivot"):
            for rtol in a.rtols:
                best = None
                for _ in range(a.repeat):
                    cloth = scipy_cloth.Cloth(cloth_cfg)
                    x, info = cloth.solve(SCENE["t_end"], "BDF", rtol, lu=lu)
                    if best is None or info["cpu_time"] < best[1]["cpu_time"]:
                        best = (x, info)
                rows.append(("scipy", f"BDF rtol {rtol:g} lu {lu}", err(best[0]), best[1]["cpu_time"],
                             best[1]["steps"]))
    print("| program | run | error | time [s] | steps |\n|---|---|---|---|---|")
    for prog, run, e, t, n in rows:
        print(f"| {prog} | {run} | {e:.3g} | {t:.3g} | {n} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
