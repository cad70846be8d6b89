# SPDX-License-Identifier: BSD-2-Clause
"""Namelist editing with f90nml (a real Fortran namelist parser, not regexes).

    from nuno.namelist import edit
    text = edit(path.read_text(), {"nx": "21", "output_file": "'h21.h5'"}, drop=("k_b",))

Keys are found by name in whichever group holds them (unique across groups,
as the program's keys are; ``group%key`` picks one where a name is
ambiguous); ``key(n)`` sets one element of an array. Values are Fortran text
(``21``, ``1.0e-3``, ``'name.h5'``, ``.true.``). The result is written by
f90nml: comments of the input are not kept.
"""

from __future__ import annotations

import re

import f90nml


def parse_value(text: str):
    """A Fortran value (as text) as f90nml reads it; ValueError if it is none."""
    try:
        nml = f90nml.reads(f"&v x = {text} /\n")
    except Exception as exc:  # f90nml raises several types on bad input
        raise ValueError(f"{text!r}: not a Fortran namelist value ({exc})") from None
    if "x" not in nml.get("v", {}):
        raise ValueError(f"{text!r}: not a Fortran namelist value")
    return nml["v"]["x"]


def find_group(nml, key: str) -> str:
    """The group holding key (``group%key`` names it); ValueError otherwise."""
    group, sep, name = key.lower().rpartition("%")
    if sep:
        if group not in nml or name not in nml[group]:
            raise ValueError(f"{key}: no such key in the namelist")
        return group
    groups = [g for g in nml if name in nml[g]]
    if not groups:
        raise ValueError(f"{key}: no such key in the namelist")
    if len(groups) > 1:
        raise ValueError(f"{key}: in groups {', '.join(groups)}; write group%{key}")
    return groups[0]


def _split(key: str):
    m = re.fullmatch(r"\s*([A-Za-z_][\w%]*)\s*(?:\(\s*(\d+)\s*\))?\s*", key)
    if not m:
        raise ValueError(f"{key!r}: not a namelist key")
    return m.group(1), (int(m.group(2)) if m.group(2) else None)


def edit(text: str, values: dict | None = None, drop=()) -> str:
    """The namelist text with keys set (they must exist) and keys dropped (if present)."""
    nml = f90nml.reads(text)
    for key in drop:
        name, _ = _split(key)
        try:
            group = find_group(nml, name)
        except ValueError:
            continue
        del nml[group][name.rpartition("%")[2].lower()]
    for key, value in (values or {}).items():
        name, index = _split(key)
        group = find_group(nml, name)
        name = name.rpartition("%")[2].lower()
        new = parse_value(str(value))
        if index is None:
            nml[group][name] = new
        else:
            old = nml[group][name]
            old = list(old) if isinstance(old, list) else [old]
            if not 1 <= index <= len(old):
                raise ValueError(f"{key}: index outside 1..{len(old)}")
            old[index - 1] = new
            nml[group][name] = old
    return str(nml) + "\n"


def set_key(text: str, key: str, value) -> str:
    return edit(text, {key: value})


def drop_key(text: str, key: str) -> str:
    return edit(text, drop=(key,))


def read(text: str):
    """The namelist as f90nml's Namelist (groups -> {key: value})."""
    return f90nml.reads(text)


def write(groups: dict) -> str:
    """Namelist text from {group: {key: python value}} (str, int, float, bool, lists)."""
    return str(f90nml.Namelist({g: dict(keys) for g, keys in groups.items()})) + "\n"
