# SPDX-License-Identifier: BSD-2-Clause
"""Every enumerated -nuno_* option is in -help with the choices and the
default that input/README.md's option tables give the user (a row
`-nuno_NAME a\\|b\\|c` each, its default marked "`a` (default").

The choice lists are defined once, in module solver_choices, and handed to
the C options blocks that put them in -help; a block that listed its own
names, or codes out of step with them, shows here as a choice or a default
that differs from the users' documentation."""
import re
import subprocess
from pathlib import Path

from nunorun import ROOT, exe, mpiexec

ROW = re.compile(r"^\| `(-nuno_\w+) (\w+(?:\\\|\w+)+)` \|(.*)$")


def documented():
    """{option: (set of choices, default)} from input/README.md."""
    rows = {}
    for line in (ROOT / "input" / "README.md").read_text().splitlines():
        m = ROW.match(line)
        if m:
            default = re.search(r"`(\w+)` \(default", m.group(3))
            rows[m.group(1)] = (set(m.group(2).split("\\|")), default.group(1) if default else None)
    return rows


def test_help_lists_every_choice_as_documented(tmp_path):
    rows = documented()
    # the multigrid's three among them (they were the last lists kept in C)
    assert {"-nuno_mg", "-nuno_mg_cycle", "-nuno_mg_product", "-nuno_mg_coarse"} <= rows.keys(), sorted(rows)
    assert len(rows) >= 8, sorted(rows)
    h5 = Path(tmp_path) / "help.h5"
    cmd = [mpiexec(), "-n", "1", "--oversubscribe", exe(), str(ROOT / "input" / "hang.nml"),
           "-nuno_set", f"nx=9,ny=9,t_end=0.01,output_interval=0.01,output_file='{h5.name}'", "-help"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for option, (choices, default) in rows.items():
        # PETSc's line of a choice option: "  -NAME <now VALUE : formerly VALUE>: TEXT (choose one of) A B C (MAN)"
        lines = [ln for ln in proc.stdout.splitlines() if re.match(rf"\s*{option} <now ", ln)]
        assert len(lines) == 1, f"{option}: {lines}"
        m = re.match(rf"\s*{option} <now (\w+) : formerly \w+>.*\(choose one of\) ([\w ]+) \(\w+\)\s*$", lines[0])
        assert m, lines[0]
        assert set(m.group(2).split()) == choices, f"{option}: -help {m.group(2).split()}, README {sorted(choices)}"
        assert m.group(1) == default, f"{option}: -help's default {m.group(1)}, README's {default}"
