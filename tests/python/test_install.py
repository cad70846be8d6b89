# SPDX-License-Identifier: BSD-2-Clause
"""Installation: `cmake --install` gives a working program and the scenes;
`pip install .` gives the post-processing package and its commands, usable
from any directory (issue 9, item 8)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import nuno_exe

ROOT = Path(__file__).resolve().parents[2]


def test_cmake_install_gives_a_working_program(tmp_path):
    build = Path(nuno_exe()).resolve().parent
    prefix = tmp_path / "prefix"
    # cmake --install writes install_manifest.txt into the build tree: harmless.
    p = subprocess.run(["cmake", "--install", str(build), "--prefix", str(prefix)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    exe = prefix / "bin" / "nuno"
    assert exe.is_file() and os.access(exe, os.X_OK)
    assert sorted(x.name for x in (prefix / "share" / "nuno" / "input").glob("*.nml")) == \
        sorted(x.name for x in (ROOT / "input").glob("*.nml"))
    assert (prefix / "share" / "doc" / "nuno" / "model.md").is_file()
    h = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert h.returncode == 0 and "namelist" in (h.stdout + h.stderr).lower()


def test_pip_install_gives_the_package_and_its_commands(tmp_path):
    # A copy of the package sources, so that setuptools' build/ does not
    # land in the repository's CMake build directory.
    src = tmp_path / "src"
    shutil.copytree(ROOT / "postprocess", src / "postprocess",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", src)
    target = tmp_path / "site"
    p = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                        "--no-build-isolation", "--disable-pip-version-check",
                        "--target", str(target), str(src)],
                       capture_output=True, text=True, timeout=300)
    if p.returncode != 0 and "setuptools" in p.stderr and "No module" in p.stderr:
        pytest.skip("setuptools is not installed")
    assert p.returncode == 0, p.stderr
    # Installed under its import name nuno (the folder postprocess/ is mapped).
    assert (target / "nuno" / "reader.py").is_file()
    assert not (target / "postprocess").exists()
    scripts = {x.name for x in (target / "bin").iterdir()}
    assert {"nuno-snapshots", "nuno-timeseries", "nuno-compare", "nuno-sweep"} <= scripts
    # From elsewhere, with only the installed copy on the path.
    env = dict(os.environ, PYTHONPATH=str(target))
    r = subprocess.run([sys.executable, "-c", "import nuno, nuno.convergence, sys; print(nuno.__file__)"],
                       capture_output=True, text=True, cwd=tmp_path, env=env, timeout=60)
    assert r.returncode == 0 and str(target) in r.stdout, r.stderr
    for script in ("nuno-snapshots", "nuno-report-figures", "nuno-sweep"):
        h = subprocess.run([str(target / "bin" / script), "--help"],
                           capture_output=True, text=True, cwd=tmp_path, env=env, timeout=60)
        # the usage line names the command the user typed
        assert h.returncode == 0 and h.stdout.startswith(f"usage: {script} "), h.stdout + h.stderr


def test_editable_install_leaves_the_tree_clean(tmp_path):
    """pip install -e . into a scratch prefix: nuno imports from the checkout,
    and git status is what it was (no unignored egg-info or build files)."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    before = git_status()
    prefix = tmp_path / "prefix"
    p = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                        "--no-build-isolation", "--disable-pip-version-check",
                        "--prefix", str(prefix), "-e", str(ROOT)],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    if p.returncode != 0 and "setuptools" in p.stderr and "No module" in p.stderr:
        pytest.skip("setuptools is not installed")
    assert p.returncode == 0, p.stderr
    (site,) = prefix.glob("lib/python*/site-packages")
    r = subprocess.run([sys.executable, "-c", f"import site; site.addsitedir({str(site)!r}); "
                        "import nuno.reader; print(nuno.reader.__file__)"],
                       capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert r.returncode == 0 and str(ROOT / "postprocess" / "reader.py") in r.stdout, r.stderr
    assert git_status() == before


def git_status() -> str:
    return subprocess.run(["git", "status", "--porcelain"], cwd=ROOT, capture_output=True,
                          text=True, timeout=60, check=True).stdout
