# SPDX-License-Identifier: BSD-2-Clause
"""Every nuno command line quoted in the docs runs as written (issue 38).

The quoted lines are read from README.md, input/README.md,
postprocess/README.md, docs/*.md (fenced code blocks and inline code spans)
and the "! Run:" comments of input/*.nml: a line is a command when it starts
with mpirun/mpiexec running nuno, build/nuno, nuno, a nuno-* console script
or python3 -m postprocess./nuno. (a bare name such as `nuno-animate` or
`build/nuno`, without arguments, is a name, not a command line). Each is either run, in the order of the docs, or
listed in SKIP with a reason; a quoted line that is neither fails the test,
so new docs cannot add untested lines.

How a line is run: in one temporary directory that looks like the
repository root to a user after the README's first command, `bash
tools/demo.sh` (build/nuno, input/*.nml, tools/, the postprocess package),
with the `nuno-<name>` console scripts on PATH (python3 -m
postprocess.<name>, what `pip install -e .` installs) but not `nuno`
itself, with the Open MPI variables and NUNO_EXE of the caller's
environment removed, and with what the README's run section says to
source first (tools/env.sh: build/ on PATH, Open MPI's settings) sourced.
So `mpirun -n 2 nuno input/drop_table.nml`, as docs/contact.md and every
namelist header quote it, runs only because tools/env.sh puts build/ on
PATH (issue 48 item 6). The line itself is not edited, except that it is
made short (substitution rules):
  - a nuno run gets `-nuno_set nx=9,ny=17,t_end=0.05` appended, without
    the keys the line sets itself; a `-nuno_restart` line gets t_end=0.1
    (the first job's run, at t_end=0.05, has finished and must be continued);
  - inside a line's own -nuno_set, nx becomes 9, ny 17 and a t_end 0.15
    (17 rows leave 2 for each of 8 ranks, the most a quoted line uses);
  - nuno-sweep gets `--fixed nx=9,ny=17,t_end=0.05`.
"""
import os
import re
import shlex
import subprocess
import time
from pathlib import Path

import pytest

from nunorun import exe as nuno_exe

ROOT = Path(__file__).resolve().parents[2]

CMD = re.compile(r"^(?:(?:mpirun|mpiexec)\s.*\bnuno\b|(?:\./)?build/nuno\s"
                 r"|nuno\s|nuno-[a-z_]+\s|python3 -m (?:postprocess|nuno)\.)")

SMALL = {"nx": "9", "ny": "17", "t_end": "0.05"}

PLACEHOLDER = "a synopsis with placeholders (P, INPUT.nml, <name>), not a command"
NOFILE = ("operates on example file names (run.h5, np1.h5, h17.h5, ...) that no "
          "quoted run command produces; the scripts are tested in test_postprocess and "
          "test_studies, and their options checked against --help below")
SKIP = {
    "mpirun -n P nuno INPUT.nml [PETSc options]": PLACEHOLDER,
    "nuno INPUT.nml": PLACEHOLDER,
    "python3 -m postprocess.<name>": PLACEHOLDER,
    "python3 -m nuno.<name>": PLACEHOLDER,
    "python3 -m postprocess.snapshots RUN.h5": PLACEHOLDER,
    "mpiexec -n P nuno identify.nml": PLACEHOLDER,
    "mpiexec -n P nuno control.nml": PLACEHOLDER,
    "nuno-snapshots RUN.h5": PLACEHOLDER,
    "nuno-snapshots big.h5": "the synthetic 513 x 513 file of a memory measurement",
    "nuno-snapshots run.h5 --times 0 0.5 1.0 --layout overlay --view side -o fig3.png": NOFILE,
    "nuno-timeseries run.h5 -o run_timeseries.png": NOFILE,
    "nuno-timeseries runs/sweep_hang_e_s/*.h5 --label e_s -o sweep.png":
        "the files of a 4-run e_s sweep of 21 x 21 hang to t_end = 2 (minutes); "
        "nuno-sweep's own plots are run here on a small sweep",
    "nuno-animate run.h5 --stride 2 --fps 15 -o run.gif": NOFILE,
    "nuno-compare np1.h5 np3.h5 --tol 1e-10 -o ranks.png": NOFILE,
    "nuno-compare h21.h5 h41.h5 --time 0.1 --view side -o lattices.png": NOFILE,
    "nuno-convergence h17.h5 h33.h5 h65.h5 --time 0.05 -o conv.png": NOFILE,
    "nuno-convergence cn_dt1.h5 cn_dt2.h5 cn_dt3.h5 --reference-run tight.h5 -o cn.png": NOFILE,
    "nuno-convergence study.csv --x-column dt --fit-max 0.01": NOFILE,
    "nuno-workprecision runs/cn/*.h5 runs/bdf/*.h5 --reference-run tight.h5 -o wp.png": NOFILE,
    "nuno-workprecision study.csv --group-column ts_type --x-label \"error [m]\"": NOFILE,
    "python3 -m postprocess.convergence cn_dt0.02.h5 cn_dt0.01.h5 cn_dt0.005.h5 --reference-run tight.h5": NOFILE,
    "python3 -m postprocess.convergence h17.h5 h33.h5 h65.h5 h129.h5 h257.h5 [--norm rms]": NOFILE,
    "nuno-sweep input/hang.nml --lattice 17,33,65 --fixed \"lattice_scaling='continuum',t_end=0.05\"":
        "a lattice study up to 65 x 65 (the lattice is what it varies); test_studies runs --lattice",
    "python3 -m postprocess.control_plot runs/identification/control.h5 --target "
    "runs/identification/control_target.h5 --initial runs/identification/control_initial.h5 "
    "-o control.png": "needs bench/identification_figures.py's runs (about 6 minutes); test_identification_plots",
    "python3 -m postprocess.identify_plot runs/identification/identify.h5 --observed "
    "runs/identification/identify_observed.h5 --initial runs/identification/identify_initial.h5 "
    "--true e_s=1,e_d=1,eta_s=1,eta_d=1,k_b=10 -o identify.png":
        "needs bench/identification_figures.py's runs (about 6 minutes); test_identification_plots",
}


def _strip_comment(s):
    m = re.search(r"\s{2,}#.*$", s)  # a trailing "   # comment"
    return (s[:m.start()] if m else s).strip()


def quoted(root=ROOT):
    """[(file, line number, command)] in the order of the docs."""
    out = []
    files = ["README.md", "input/README.md", "postprocess/README.md"]
    files += sorted(str(p.relative_to(root)) for p in root.glob("docs/*.md"))
    for f in files:
        lines = (root / f).read_text().splitlines()
        block, i = False, 0
        while i < len(lines):
            line = lines[i]
            i += 1
            if line.strip().startswith("```"):
                block = not block
                continue
            if block:
                s, n = line.strip(), i
                while s.endswith("\\") and i < len(lines):
                    s = s[:-1].rstrip() + " " + lines[i].strip()
                    i += 1
                s = _strip_comment(s)
                if CMD.match(s):
                    out.append((f, n, s))
            elif line.strip():
                # a paragraph: an inline code span may go over a line break
                n, para = i, [line]
                while (i < len(lines) and lines[i].strip()
                       and not lines[i].strip().startswith("```")):
                    para.append(lines[i])
                    i += 1
                text = "\n".join(para)
                for m in re.finditer(r"`([^`]+)`", text):
                    s = " ".join(m.group(1).split())
                    if CMD.match(s):
                        out.append((f, n + text.count("\n", 0, m.start()), s))
    for p in sorted(root.glob("input/*.nml")):
        for n, line in enumerate(p.read_text().splitlines(), 1):
            m = re.match(r"!\s*Run:\s*(.*?)(?:\s{2,}\(.*)?$", line)
            if m:
                out.append((str(p.relative_to(root)), n, m.group(1).strip()))
    return out


def shrunk(cmd):
    """The command with the substitution rules of the module docstring."""
    words = shlex.split(cmd)
    if words[0] == "nuno-sweep":
        return cmd + " --fixed " + ",".join(f"{k}={v}" for k, v in SMALL.items())
    runs_nuno = any(w in ("nuno", "build/nuno", "./build/nuno") for w in words)
    if not runs_nuno or any(w.startswith("--") for w in words):
        return cmd
    small = dict(SMALL)
    if "-nuno_restart" in words:
        small["t_end"] = "0.1"

    def own(m):
        body = m.group(2)
        for key in list(small):
            if re.search(rf"\b{key}\s*=", body):
                small.pop(key)
        body = re.sub(r"\b(nx|ny)\s*=\s*\d+", lambda k: f"{k.group(1)}={SMALL[k.group(1)]}", body)
        body = re.sub(r"\bt_end\s*=\s*[0-9.eE+-]+", "t_end=0.15", body)
        return m.group(1) + body
    cmd = re.sub(r"(-nuno_set\s+)(\"[^\"]*\"|'[^']*'|\S+)", own, cmd)
    if small:
        cmd += " -nuno_set " + ",".join(f"{k}={v}" for k, v in small.items())
    return cmd


def _workdir(tmp_path, exe):
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "nuno").symlink_to(exe)
    (tmp_path / "input").mkdir()
    for p in (ROOT / "input").glob("*.nml"):
        (tmp_path / "input" / p.name).write_text(p.read_text())
    (tmp_path / "postprocess").symlink_to(ROOT / "postprocess")
    (tmp_path / "tools").symlink_to(ROOT / "tools")
    bindir = tmp_path / ".bin"          # what pip install -e . puts on PATH: no nuno
    bindir.mkdir()
    for p in (ROOT / "postprocess").glob("*.py"):
        script = bindir / f"nuno-{p.stem}"
        script.write_text(f"#!/bin/sh\nPYTHONPATH={shlex.quote(str(ROOT))}${{PYTHONPATH:+:$PYTHONPATH}} "
                          f"exec python3 -m postprocess.{p.stem} \"$@\"\n")
        script.chmod(0o755)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("OMPI_") and k not in ("NUNO_EXE", "NUNO_MPIEXEC", "NUNO_ROOT")}
    path = [d for d in env.get("PATH", "").split(":")      # no nuno of the caller's (a build/
            if d and not (Path(d) / "nuno").exists()]      # on PATH from tools/env.sh)
    env["PATH"] = ":".join([str(bindir), *path])
    return env


def readme_setup(root=ROOT):
    """The `source ...` lines of the README's "Running a scene" block: what a
    user runs once in the shell before the quoted command lines."""
    text = (root / "README.md").read_text()
    section = text.split("## Running a scene", 1)[1]
    block = section.split("```", 2)[1]
    return [ln.split("#")[0].strip() for ln in block.splitlines()
            if ln.strip().startswith("source ")]


def run_line(cmd, cwd, env, timeout=120, setup=None):
    setup = readme_setup() if setup is None else setup
    script = " && ".join([*setup, shrunk(cmd)])
    return subprocess.run(["bash", "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def failed(r):
    """A line fails when it exits non-zero or nuno says an option of it was not used."""
    return r.returncode != 0 or "was not used" in r.stdout + r.stderr


def test_extraction_finds_the_readme_run_line():
    """The extractor sees the README's run lines (a broken regex would pass vacuously)."""
    cmds = [c for _, _, c in quoted()]
    assert any(c.startswith("mpirun") and "nuno input/hang.nml" in c for c in cmds)
    assert any(c.startswith("nuno-") for c in cmds)
    assert len(cmds) > 20


def test_every_namelist_header_and_docs_page_is_covered():
    """Each input/*.nml has its "! Run:" line among the lines run (none
    skipped), and so have docs/contact.md's run lines: the lines of issue
    48 item 6 that failed from a checkout."""
    found = quoted()
    for p in sorted((ROOT / "input").glob("*.nml")):
        name = str(p.relative_to(ROOT))
        runs = [c for f, _, c in found if f == name]
        assert runs == [c for c in runs if c not in SKIP] and len(runs) == 1, (name, runs)
        words = runs[0].split()
        assert words[:2] == ["mpirun", "-n"] and words[3:5] == ["nuno", name], runs  # from the root
    assert "mpirun -n 2 nuno input/drop_table.nml" in [c for f, _, c in found
                                                       if f == "docs/contact.md"]


def test_nuno_is_on_path_only_through_tools_env_sh(tmp_path):
    """In the test's directory `nuno` is not found until tools/env.sh is
    sourced (it puts build/ on PATH): the header lines pass because of it,
    not because the test put nuno on PATH. Once sourced, `nuno` is the
    directory's build/nuno."""
    env = _workdir(tmp_path, nuno_exe())
    bare = subprocess.run(["bash", "-c", "command -v nuno"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=60)
    assert bare.returncode != 0, bare.stdout
    line = next(c for f, _, c in quoted() if f == "input/drop_table.nml")
    r = run_line(line, tmp_path, dict(env, OMPI_ALLOW_RUN_AS_ROOT="1",
                                      OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                                      OMPI_MCA_rmaps_base_oversubscribe="1"), setup=[])
    assert failed(r) and not (tmp_path / "drop_table.h5").exists(), r.stdout + r.stderr
    sourced = subprocess.run(["bash", "-c", "source tools/env.sh && command -v nuno"], cwd=tmp_path,
                             env=env, capture_output=True, text=True, timeout=60)
    assert sourced.returncode == 0 and sourced.stdout.strip() == str(tmp_path / "build" / "nuno")
    r = run_line(line, tmp_path, env)
    assert not failed(r), r.stdout + r.stderr
    assert (tmp_path / "drop_table.h5").is_file()


def test_skip_list_has_no_stale_entries():
    cmds = {c for _, _, c in quoted()}
    stale = sorted(set(SKIP) - cmds)
    assert not stale, f"SKIP names lines no doc quotes any more: {stale}"


def test_shrunk_rules():
    assert shrunk("mpirun -n 2 nuno a.nml") == "mpirun -n 2 nuno a.nml -nuno_set nx=9,ny=17,t_end=0.05"
    assert shrunk("nuno --help") == "nuno --help"
    assert (shrunk("mpirun -n 8 nuno h.nml -nuno_restart h.h5 -nuno_set t_end=5")
            == "mpirun -n 8 nuno h.nml -nuno_restart h.h5 -nuno_set t_end=0.15 -nuno_set nx=9,ny=17")
    assert (shrunk("build/nuno i.nml -nuno_set \"nx=257,ny=257,output_file='a.h5'\"")
            == "build/nuno i.nml -nuno_set \"nx=9,ny=17,output_file='a.h5'\" -nuno_set t_end=0.05")


def test_every_quoted_command_runs(tmp_path):
    env = _workdir(tmp_path, nuno_exe())
    failures = []
    for f, n, cmd in quoted():
        if cmd in SKIP:
            continue
        t0 = time.monotonic()
        r = run_line(cmd, tmp_path, env)
        print(f"{time.monotonic() - t0:6.1f} s  {f}:{n}: {cmd}")
        if failed(r):
            tail = "\n".join((r.stdout + r.stderr).strip().splitlines()[-6:])
            failures.append(f"{f}:{n}: {cmd}\n  ran: {shrunk(cmd)}\n  exit {r.returncode}:\n{tail}")
    assert not failures, "quoted command lines that fail as written:\n\n" + "\n\n".join(failures)


@pytest.mark.parametrize("bad", [
    "mpirun -n 2 build/nuno input/hang.nml -nuno_no_such_option 1",   # unused: a warning
    "mpirun -n 2 build/nuno input/hang.nml -nuno_set nxx=5",           # unknown key: an error
    "nuno-sweep input/hang.nml --no-such-flag",
])
def test_a_wrong_quoted_line_fails(tmp_path, bad):
    """The check can fail: a README quoting a wrong line is found, not in SKIP, and fails."""
    docs = tmp_path / "docs_root"
    (docs / "input").mkdir(parents=True)
    (docs / "README.md").write_text(f"# x\n\n```sh\n{bad}   # a comment\n```\n")
    for name in ("input/README.md", "postprocess/README.md"):
        (docs / name).parent.mkdir(exist_ok=True)
        (docs / name).write_text("nothing quoted\n")
    assert [c for _, _, c in quoted(docs)] == [bad]
    assert bad not in SKIP
    work = tmp_path / "work"
    work.mkdir()
    env = _workdir(work, nuno_exe())
    r = run_line(bad, work, env)
    assert failed(r), r.stdout + r.stderr


def test_readme_run_line_needs_what_the_readme_sources(tmp_path):
    """As root or with fewer than 4 cores, Open MPI refuses the README's
    `mpirun -n 4` line unless tools/env.sh is sourced: the README says so."""
    setup = readme_setup()
    assert "source tools/env.sh" in setup
    if os.geteuid() != 0 and (os.cpu_count() or 1) >= 4:
        pytest.skip("Open MPI runs mpirun -n 4 here without tools/env.sh")
    env = _workdir(tmp_path, nuno_exe())
    line = next(c for f, _, c in quoted() if f == "README.md" and c.startswith("mpirun -n 4"))
    assert failed(run_line(line, tmp_path, env, setup=[]))
    r = run_line(line, tmp_path, env)
    assert not failed(r), r.stdout + r.stderr


def test_skipped_script_lines_use_options_the_script_has(tmp_path):
    """The post-processing lines that are not run (example file names) name
    only options their script's --help lists: a misspelt option fails here."""
    env = _workdir(tmp_path, nuno_exe())
    for _, _, cmd in quoted():
        if cmd not in SKIP:
            continue
        words = shlex.split(cmd)
        if words[0].startswith("nuno-"):
            module, args = words[0][len("nuno-"):], words[1:]
        elif words[:2] == ["python3", "-m"] and "<" not in words[2]:
            module, args = words[2].split(".", 1)[1], words[3:]
        else:
            continue
        r = subprocess.run(["bash", "-c", f"nuno-{module} --help"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        for w in args:
            opt = w.strip("[]").split("=", 1)[0]
            if opt.startswith("-") and not re.fullmatch(r"-?[0-9.eE+-]+", opt):
                assert re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", r.stdout), \
                    f"{cmd}: {opt} is not in nuno-{module} --help"
