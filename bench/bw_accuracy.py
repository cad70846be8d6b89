#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-2-Clause
"""What the Baraff-Witkin mode (one linearised solve a step) costs in
accuracy: hang at N x N integrated to t_end with backward Euler at one dt,
(1) by full Newton (the default), (2) in the Baraff-Witkin mode
(-snes_type ksponly -reduced_ksp_rtol 1e-3), and (3) by full Newton at
dt/8 as the reference; the position error of each against (3), relative to
the largest displacement, at every output time. The linearisation error of
(2) is |(2) - (1)|; the time-discretisation error of backward Euler is
|(1) - (3)|.

    source tools/env.sh
    python3 bench/bw_accuracy.py --n 33 --t-end 0.3
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from postprocess import namelist  # noqa: E402
from postprocess.reader import read_run  # noqa: E402


def run(exe, mpiexec, d, name, n, t_end, dt, out_dt, opts, nranks):
    nml = Path(d) / f"{name}.nml"
    nml.write_text(namelist.write({"scene": {"scene": "hang"}, "lattice": {"nx": n, "ny": n},
                                   "time": {"t_end": t_end, "dt": dt},
                                   "output": {"output_interval": out_dt,
                                              "output_file": f"{name}.h5"}}))
    t0 = time.perf_counter()
    subprocess.run([mpiexec, "-n", str(nranks), "--oversubscribe", exe, nml.name, *opts], cwd=d, check=True,
                   capture_output=True, text=True)
    return read_run(str(Path(d) / f"{name}.h5")), time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=str(ROOT / "build" / "nuno"))
    ap.add_argument("--mpiexec", default=os.environ.get("NUNO_MPIEXEC", "mpiexec"))
    ap.add_argument("--n", type=int, default=33)
    ap.add_argument("--t-end", type=float, default=0.3)
    ap.add_argument("--dt", type=float, default=1.0 / 600.0)
    ap.add_argument("--ranks", type=int, default=2)
    a = ap.parse_args(argv)
    out_dt = a.t_end / 3
    with tempfile.TemporaryDirectory() as d:
        newton, tn = run(a.exe, a.mpiexec, d, "newton", a.n, a.t_end, a.dt, out_dt, [], a.ranks)
        bw, tb = run(a.exe, a.mpiexec, d, "bw", a.n, a.t_end, a.dt, out_dt,
                     ["-snes_type", "ksponly", "-reduced_ksp_rtol", "1e-3"], a.ranks)
        ref, tr = run(a.exe, a.mpiexec, d, "ref", a.n, a.t_end, a.dt / 8, out_dt, [], a.ranks)
    scale = np.abs(ref.position - ref.position[0]).max()
    print(f"hang {a.n} x {a.n}, dt = {a.dt:.4g} s, {a.ranks} ranks; errors relative to the largest "
          f"displacement ({scale:.3g} m) of the dt/8 Newton reference")
    print(f"wall time: Newton {tn:.1f} s, Baraff-Witkin {tb:.1f} s, reference {tr:.1f} s\n")
    print("| t [s] | Newton vs reference | Baraff-Witkin vs reference | Baraff-Witkin vs Newton |")
    print("|---|---|---|---|")
    for k in range(1, ref.nt):
        e_n = np.abs(newton.position[k] - ref.position[k]).max() / scale
        e_b = np.abs(bw.position[k] - ref.position[k]).max() / scale
        e_bn = np.abs(bw.position[k] - newton.position[k]).max() / scale
        print(f"| {ref.time[k]:.3f} | {e_n:.2e} | {e_b:.2e} | {e_bn:.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
