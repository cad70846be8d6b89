# SPDX-License-Identifier: BSD-2-Clause
"""The tools leave the repository as it was (issue 38 item 8): after
tools/figures.sh --quick, a default nuno-sweep and the plotting scripts run
from the repository root, git status is unchanged and the tracked figures
in docs/figures keep their bytes; what they wrote is under runs/ (ignored)."""
import hashlib
import os
import shutil
import subprocess
import sys

import pytest

from nunorun import ROOT, exe, mpiexec


def git(*args):
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=60, check=True).stdout


def tracked_figures():
    names = git("ls-files", "docs/figures").split()
    return {n: hashlib.sha256((ROOT / n).read_bytes()).hexdigest() for n in names}


@pytest.fixture
def clean_check():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    before, figures = git("status", "--porcelain"), tracked_figures()
    yield
    assert git("status", "--porcelain") == before
    assert tracked_figures() == figures


def test_tools_write_only_under_runs(tmp_path, clean_check):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg",
               NUNO_MPIEXEC=f"{mpiexec()} --oversubscribe")
    rundir = tmp_path / "report"
    proc = subprocess.run(["bash", "tools/figures.sh", "--quick", "--exe", exe(),
                           "--rundir", str(rundir)], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "wrote runs/figures/fig3_lift_release.png" in proc.stdout
    # a sweep with its default output directory (runs/sweep_<stem>_<key>)
    nml = tmp_path / "cleantree.nml"
    nml.write_text("&scene scene='hang' /\n&lattice nx=5 ny=5 /\n&time t_end=0.02 dt=1e-2 /\n"
                   "&output output_interval=0.01 /\n")
    outdir = ROOT / "runs" / "sweep_cleantree_e_s"
    shutil.rmtree(outdir, ignore_errors=True)
    try:
        proc = subprocess.run([sys.executable, "-m", "postprocess.sweep", str(nml), "--set",
                               "e_s=50,100", "--exe", exe()], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        assert (outdir / "cleantree_e_s-100.h5").is_file() and (outdir / "compare.png").is_file()
    finally:
        shutil.rmtree(outdir, ignore_errors=True)
