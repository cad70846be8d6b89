# SPDX-License-Identifier: BSD-2-Clause
"""Messages of a program that reads like one (issue 38 item 6, issue 37 item
14): a value not of its key's type names the key and the type, an unquoted
string gets the hint to quote it, a key given twice in the file is refused,
`nuno --version` prints the version and commit, and -log_view in the
namelist's petsc_options is honoured (to the screen) or refused (to a file)
without touching the user's file. On 2-3 ranks; each failed on the old code."""
import re
import subprocess

import pytest

from nunorun import exe, mpiexec

RUN = ("&scene scene='lift_release' /\n&lattice nx=5 ny=5 /\n&time t_end=0.004 dt=1e-3 /\n")


def launch(tmp_path, args, nranks=3):
    cmd = [mpiexec(), "-n", str(nranks), "--oversubscribe", exe(), *args]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=120)


def errors(proc):
    return [ln for ln in proc.stderr.splitlines() if ln.startswith("nuno: error")]


FILE_CASES = {
    # The old messages: "Cannot match namelist object name .5", "... foo.h5", "Bad repeat count".
    "real_for_integer": ("&lattice nx=33.5 /", ["&lattice: nx = 33.5: expected an integer"]),
    "word_for_real": ("&material e_s=stiff /", ["&material: e_s = stiff: expected a real number"]),
    "number_for_logical": ("&output output_file='bad.h5' write_velocity=3 /",
                           ["write_velocity = 3: expected a logical"]),
    "unquoted_output_file": ("&output output_file=bad.h5 /",
                             ["output_file = bad.h5", "must be quoted", "output_file='bad.h5'"]),
    "unquoted_scene": ("&scene scene=hang /", ["&scene: scene = hang", "scene='hang'"]),
    # The old code took the last value silently.
    "repeated_key": ("&lattice nx=5 ny=5 nx=7 /", ["&lattice: nx is given twice", "nx=5", "nx=7"]),
    "repeated_scene": ("&scene scene='hang', gravity=0,0,-1, scene='flat' /", ["&scene: scene is given twice"]),
    # The old code kept the default silently (issue 48 item 4).
    "empty_value": ("&lattice nx = , ny=5 /", ["&lattice: nx has no value", "nx = ,"]),
    "empty_value_at_end": ("&lattice nx=5 ny= /", ["&lattice: ny has no value"]),
    "empty_list_item": ("&scene scene='hang' gravity = 0, , -9.81 /", ["&scene: gravity = 0, , -9.81", "empty item"]),
}


@pytest.mark.parametrize("case", sorted(FILE_CASES))
def test_namelist_value_errors_name_key_and_type(tmp_path, case):
    text, words = FILE_CASES[case]
    if "&output" not in text:
        text += "\n&output output_file='bad.h5' /"
    (tmp_path / "bad.nml").write_text(text + "\n")
    proc = launch(tmp_path, ["bad.nml"])
    assert proc.returncode != 0
    errs = errors(proc)
    assert len(errs) == 1, proc.stderr
    for w in words:
        assert w in errs[0], (case, errs[0])
    assert not list(tmp_path.glob("*.h5"))


def test_array_elements_are_not_a_repeated_key(tmp_path):
    """keyframe_time(2) and keyframe_time(3) are two keys, not one given twice."""
    (tmp_path / "ok.nml").write_text(
        "&scene scene='wave_point' keyframe_time(2)=0.004 keyframe_time(3)=0.006 /\n"
        "&lattice nx=5 ny=5 /\n&time t_end=0.002 dt=1e-3 /\n&output output_file='ok.h5' /\n")
    proc = launch(tmp_path, ["ok.nml"], nranks=2)
    assert proc.returncode == 0, proc.stderr


def test_version_prints_version_and_commit(tmp_path):
    """nuno --version: one line, the project's version (CMakeLists.txt) and
    the git commit of the build, once on several ranks; --help lists it."""
    root = __import__("pathlib").Path(__file__).resolve().parents[2]
    version = re.search(r"project\(nuno VERSION ([0-9.]+)", (root / "CMakeLists.txt").read_text()).group(1)
    proc = launch(tmp_path, ["--version"], nranks=2)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 1, proc.stdout
    assert re.fullmatch(rf"nuno {re.escape(version)} \(git [0-9A-Za-z._-]+\)", lines[0]), lines[0]
    # The commit is one of this repository's (the build may predate HEAD).
    commit = lines[0].split("(git ")[1].rstrip(")").removesuffix("-dirty")
    if commit != "unknown" and (root / ".git").exists():
        found = subprocess.run(["git", "rev-parse", "--verify", "--quiet", commit + "^{commit}"], cwd=root,
                               capture_output=True, text=True)
        assert found.returncode == 0, f"{commit} is not a commit of {root}"
    proc = launch(tmp_path, ["--help"], nranks=1)
    assert proc.returncode == 0 and "--version" in proc.stdout


def test_log_view_in_namelist_is_honoured(tmp_path):
    """-log_view (to the screen) in petsc_options: PETSc's log is printed at
    the end and the run exits 0 (the old code: exit 56 after 'complete',
    PETSc's log never started)."""
    (tmp_path / "lv.nml").write_text(RUN + "&output output_file='lv.h5' petsc_options='-log_view' /\n")
    proc = launch(tmp_path, ["lv.nml"], nranks=2)
    assert proc.returncode == 0, proc.stderr
    assert "PETSc Performance Summary" in proc.stdout
    assert "complete" in proc.stdout
    assert "-log_view was not used" not in proc.stderr


@pytest.mark.parametrize("option", ["-log_view :mine.txt", "-ksp_view ascii:mine.txt"])
def test_viewer_file_in_namelist_is_refused_and_file_kept(tmp_path, option):
    """A viewer that names a file in petsc_options is refused with one line
    before anything is written, and the user's file keeps its bytes (the old
    code truncated it to 0 bytes and exited 56)."""
    mine = tmp_path / "mine.txt"
    mine.write_bytes(b"the user's notes\n")
    (tmp_path / "lv.nml").write_text(RUN + f"&output output_file='lv.h5' petsc_options='{option}' /\n")
    proc = launch(tmp_path, ["lv.nml"], nranks=2)
    assert proc.returncode != 0
    errs = errors(proc)
    assert len(errs) == 1, proc.stderr
    assert option in errs[0] and "command line" in errs[0], errs[0]
    assert mine.read_bytes() == b"the user's notes\n"
    assert not list(tmp_path.glob("lv.h5*"))
