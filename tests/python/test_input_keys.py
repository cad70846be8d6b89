# SPDX-License-Identifier: BSD-2-Clause
"""input/README.md's key tables against the key table of the program
(src/input/input_keys.f90, printed by `nuno --list-keys`): every key documented
once, in its group's section, with the same type, unit and default, and no
documented key that the program does not have. The program's table is in
turn held against the namelist reader by tests/mpi/test_input_keys.F90.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import h5py

from nunorun import exe, run

REPO = Path(__file__).resolve().parents[2]
README = REPO / "input" / "README.md"
HEADER = "| key | type | unit | default | meaning, allowed values |"


def program_keys():
    proc = subprocess.run([exe(), "--list-keys"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("# name\tgroup\ttype\tunit\tdefault"), lines[0]
    keys = {}
    for ln in lines[1:]:
        name, group, typ, unit, default, allowed, meaning = ln.split("\t")
        assert name not in keys, f"{name} twice in --list-keys"
        assert meaning, f"{name} has no meaning in the key table"
        keys[name] = dict(group=group, type=typ, unit=unit, default=default)
    return keys


def cells(row):
    """The cells of a Markdown table row ('\\|' is a bar inside a cell)."""
    parts = re.split(r"(?<!\\)\|", row.strip())[1:-1]
    return [p.strip().replace("\\|", "|") for p in parts]


def program_allowed():
    """{key: allowed} of the key table (`nuno --list-keys`)."""
    proc = subprocess.run([exe(), "--list-keys"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return {ln.split("\t")[0]: ln.split("\t")[5] for ln in proc.stdout.splitlines()[1:]}


def readme_meanings():
    """{key: its meaning cell} of input/README.md's key tables."""
    out, in_table = {}, False
    for ln in README.read_text().splitlines():
        if ln.strip() == HEADER:
            in_table = True
            continue
        if in_table and not ln.startswith("|"):
            in_table = False
        if in_table:
            c = cells(ln)
            for n in re.findall(r"`([a-z_0-9]+)`", c[0]):
                out[n] = c[4]
    return out


def test_readme_states_the_tables_bounds():
    """A key whose allowed values are bounds with an upper one (">= 0, <= 1e30",
    the material constants and the mass: issue 48 item 4) says so in
    input/README.md in the table's words, the range the program checks
    (module input_checks' need_in_range reads it from the table)."""
    doc = readme_meanings()
    bounded = {k: a for k, a in program_allowed().items() if re.fullmatch(r"(>=?|<=?) \S+(, (>=?|<=?) \S+)*", a)
               and "<" in a}
    assert {"e_s", "eta_s", "e_d", "eta_d", "k_b", "eta_b", "total_mass"} <= set(bounded), bounded
    missing = [f"{k}: {a!r} not in {doc.get(k)!r}" for k, a in sorted(bounded.items()) if a not in doc.get(k, "")]
    assert not missing, "input/README.md does not state these bounds:\n" + "\n".join(missing)


def readme_keys():
    """{key: {group, type, unit, default}} from the key tables under each
    '## &group' heading; a row may document several keys (`a`, `b`)."""
    keys, group, in_table = {}, None, False
    for ln in README.read_text().splitlines():
        m = re.match(r"^## &(\w+)\s*$", ln)
        if m:
            group, in_table = m.group(1), False
            continue
        if ln.startswith("#"):
            group, in_table = None, False
            continue
        if group and ln.strip() == HEADER:
            in_table = True
            continue
        if in_table:
            if not ln.startswith("|"):
                in_table = False
                continue
            c = cells(ln)
            if set(c[0]) <= set("-"):
                continue
            names = re.findall(r"`([a-z_0-9]+)`", c[0])
            assert names and ", ".join(f"`{n}`" for n in names) == c[0], f"bad key cell: {c[0]}"
            for n in names:
                assert n not in keys, f"{n} documented twice in input/README.md"
                keys[n] = dict(group=group, type=c[1], unit=c[2], default=c[3].replace("`", ""))
    return keys


def test_readme_key_tables_agree_with_the_program():
    prog, doc = program_keys(), readme_keys()
    assert len(prog) > 40 and len(doc) > 40
    missing = sorted(set(prog) - set(doc))
    extra = sorted(set(doc) - set(prog))
    assert not missing, f"keys of the program not in input/README.md: {missing}"
    assert not extra, f"keys in input/README.md the program does not have: {extra}"
    wrong = [f"{k}.{field}: README {doc[k][field]!r}, program {prog[k][field]!r}"
             for k in sorted(prog) for field in ("group", "type", "unit", "default")
             if doc[k][field] != prog[k][field]]
    assert not wrong, "input/README.md disagrees with the key table:\n" + "\n".join(wrong)


def test_help_lists_every_key_in_its_group():
    """--help's group lines name each key of the table (they are generated
    from it); checked here against --list-keys."""
    proc = subprocess.run([exe(), "--help"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout
    start, end = text.index("INPUT.nml holds"), text.index("The scene sets the defaults")
    block = text[start:end]
    groups = {}
    current = None
    for ln in block.splitlines()[2:]:
        m = re.match(r"^  &(\w+)\s+(.*)$", ln)
        if m:
            current = m.group(1)
            groups[current] = m.group(2)
        elif current and re.fullmatch(r" {13}[a-z_0-9]+(, [a-z_0-9]+)*,?", ln):
            groups[current] += " " + ln.strip()
    listed = {g: set(re.findall(r"[a-z_0-9]+", v)) for g, v in groups.items()}
    for name, k in program_keys().items():
        assert name in listed.get(k["group"], set()), f"--help does not list {name} in &{k['group']}"


def test_config_in_the_output_holds_the_table_keys(tmp_path):
    """The output's /config (written key by key in src/run/timestepping.F90,
    write_config) records every key of the table's always-present groups,
    and no other: a key added to the table and not to the writer fails."""
    _, h5 = run(tmp_path, "cfg", options=["-ts_max_steps", "1"],
                scene="scene='flat'", lattice="nx=5 ny=5")
    prog = program_keys()
    with h5py.File(h5, "r") as f:
        for group in ("lattice", "material", "scene", "time", "output"):
            table = {k for k, v in prog.items() if v["group"] == group}
            written = set(f["config"][group].attrs)
            assert written == table, (group, sorted(written ^ table))


SCENES = ["lift_release", "bend_release", "wave_point", "hang", "flat"]


def table_default(default, scene):
    """The table's default text for one scene: the plain value, or the one
    after '; SCENE '."""
    parts = default.split("; ")
    value = parts[0]
    for p in parts[1:]:
        name, _, rest = p.partition(" ")
        if name == scene:
            value = rest
    return value.replace("<scene>", scene)


def as_values(text):
    """Numbers of a default ('(0, 0, -9.81)' -> [0, 0, -9.81]) or a bare
    string ("'area'" -> ['area'])."""
    text = re.sub(r"\s*\((paper|energy)\)\s*$", "", text.strip()).strip("()")
    out = []
    for item in re.split(r"\s*,\s*", text):
        item = item.strip().strip("'\"`")
        try:
            out.append(float(item))
        except ValueError:
            out.append(item)
    return out


def test_readme_scene_defaults_agree_with_the_program():
    """input/README.md's 'Scene defaults' table (key by scene) against the
    table's per-scene defaults."""
    prog = program_keys()
    lines = README.read_text().splitlines()
    start = lines.index("| key | lift_release | bend_release | wave_point | hang | flat |")
    rows, checked = [], 0
    for ln in lines[start + 2:]:
        if not ln.startswith("|"):
            break
        rows.append(cells(ln))
    for row in rows:
        label, values = row[0], row[1:]
        if label.startswith("k_b"):
            continue                      # derived from the model (see the text above the table)
        names = re.split(r" x | = ", label)
        for name in names:
            assert name in prog, f"Scene defaults row {label!r}: {name} is not a key"
        for scene, cell in zip(SCENES, values):
            pieces = cell.split(" x ") if len(names) > 1 and " x " in label else [cell] * len(names)
            for name, piece in zip(names, pieces):
                want = as_values(table_default(prog[name]["default"], scene))
                got = as_values(piece)
                if len(got) == 1 and len(want) > 1 and all(w == got[0] for w in want):
                    got = want                # '0' for a zero vector
                assert got == want, f"Scene defaults: {name} in {scene}: README {piece!r}, program {want}"
                checked += 1
    assert checked > 60
