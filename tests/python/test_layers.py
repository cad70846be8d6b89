# SPDX-License-Identifier: BSD-2-Clause
"""The layers of src/ (docs/design.md, "Layers"): each folder of src/ is a
layer and a library, listed from the bottom up in CMakeLists.txt
(NUNO_LAYERS); a module may use only modules of its own layer or of a
layer below. A pure scan of the sources (no build): every `use` statement
and `submodule (parent)` line is read, and each upward use is named with
its file and line. The scanner's own tests build small trees with an
upward use, a use of a module no layer defines, and a folder that is not a
layer, and show that each is found."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

USE = re.compile(r"^\s*use\s*(?:,\s*(intrinsic|non_intrinsic)\s*)?(?:::)?\s*(\w+)", re.I)
SUBMODULE = re.compile(r"^\s*submodule\s*\(\s*(\w+)", re.I)
MODULE = re.compile(r"^\s*module\s+(?!procedure\b|subroutine\b|function\b)(\w+)\s*(?:!.*)?$", re.I)
# Modules of the compiler, MPI, PETSc and HDF5 (not ours).
EXTERNAL = re.compile(r"^(mpi|mpi_f08|hdf5|h5ds|h5lt|petsc\w*|iso_\w+|ieee_\w+)$", re.I)


def layer_order(cmake: Path) -> list[str]:
    """NUNO_LAYERS of CMakeLists.txt, bottom first."""
    m = re.search(r"^set\(NUNO_LAYERS\s+([^)]*)\)", cmake.read_text(), re.M)
    assert m, f"{cmake}: no set(NUNO_LAYERS ...)"
    return m.group(1).split()


def sources(src: Path):
    return sorted(p for p in src.rglob("*") if p.suffix.lower() == ".f90")


def module_layers(src: Path) -> dict[str, str]:
    """Module name (lower case) -> the folder that defines it."""
    owner = {}
    for path in sources(src):
        for line in path.read_text().splitlines():
            m = MODULE.match(line)
            if m:
                owner[m.group(1).lower()] = path.relative_to(src).parts[0]
    return owner


def violations(src: Path, layers: list[str]) -> list[str]:
    """Each use of a module of a higher layer, an unknown module, or a
    source outside the layers' folders: one line each."""
    rank = {name: k for k, name in enumerate(layers)}
    owner = module_layers(src)
    found = []
    for path in sources(src):
        rel = path.relative_to(src)
        here = rel.parts[0]
        if len(rel.parts) < 2 or here not in rank:
            found.append(f"src/{rel}: not in a layer's folder ({' '.join(layers)})")
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            m = USE.match(line) or SUBMODULE.match(line)
            if not m:
                continue
            name = m.group(m.lastindex).lower()
            if (m.re is USE and m.group(1) and m.group(1).lower() == "intrinsic") or EXTERNAL.match(name):
                continue
            if name not in owner:
                found.append(f"src/{rel}:{n}: uses {name}, which no layer defines")
            elif rank[owner[name]] > rank[here]:
                found.append(f"src/{rel}:{n}: {here} uses {name} of the higher layer {owner[name]}")
    return found


def test_layers_in_cmake_are_the_folders():
    layers = layer_order(ROOT / "CMakeLists.txt")
    folders = sorted(p.name for p in (ROOT / "src").iterdir() if p.is_dir())
    assert sorted(layers) == folders


def test_no_module_uses_a_higher_layer():
    found = violations(ROOT / "src", layer_order(ROOT / "CMakeLists.txt"))
    assert not found, "\n".join(found)


def _tree(tmp_path, files):
    for rel, text in files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


LOW = "module low_a\n  use, intrinsic :: iso_c_binding\n  use mpi\nend module low_a\n"


def test_layer_scanner_finds_an_upward_use(tmp_path):
    src = _tree(tmp_path, {
        "low/low_a.f90": LOW + "",
        "low/low_b.F90": "module low_b\n  use low_a, only: x\n  use high_a\nend module low_b\n",
        "high/high_a.f90": "module high_a\n  use low_a\nend module high_a\n",
        "high/high_b.F90": "submodule (high_a) high_b\nend submodule high_b\n",
    })
    assert violations(src, ["low", "high"]) == [
        "src/low/low_b.F90:3: low uses high_a of the higher layer high"]


def test_layer_scanner_finds_a_submodule_of_a_higher_parent(tmp_path):
    src = _tree(tmp_path, {
        "low/low_a.f90": LOW,
        "high/high_a.f90": "module high_a\nend module high_a\n",
        "low/low_sub.F90": "submodule(high_a) low_sub\nend submodule low_sub\n",
    })
    assert violations(src, ["low", "high"]) == [
        "src/low/low_sub.F90:1: low uses high_a of the higher layer high"]


def test_layer_scanner_finds_unknown_modules_and_stray_files(tmp_path):
    src = _tree(tmp_path, {
        "low/low_a.f90": "module low_a\n  use nowhere\nend module low_a\n",
        "stray.f90": "module stray\nend module stray\n",
        "other/x.f90": "module x\nend module x\n",
    })
    found = violations(src, ["low"])
    assert "src/low/low_a.f90:2: uses nowhere, which no layer defines" in found
    assert any(f.startswith("src/stray.f90: not in a layer") for f in found)
    assert any(f.startswith("src/other/x.f90: not in a layer") for f in found)


@pytest.mark.parametrize("layers", [["base", "kernels"], ["kernels", "base"]])
def test_layer_order_decides(tmp_path, layers):
    src = _tree(tmp_path, {
        "base/kinds.f90": "module kinds\nend module kinds\n",
        "kernels/k.f90": "module k\n  use kinds, only: rp\nend module k\n",
    })
    assert bool(violations(src, layers)) == (layers[0] == "kernels")
