# SPDX-License-Identifier: BSD-2-Clause
"""The documents' relative links resolve: every [text](target) and
![alt](target) in README.md, CHANGELOG.md, docs/*.md and the READMEs of
input/, postprocess/ and bench/ names a file of the repository, and an
anchor (#section) names a heading of the target as GitHub spells it. Also:
docs/performance.md's table is the one its data file gives (the table and
the figure come from one set of logs), and every result file the docs cite
exists. No program run: a few milliseconds."""
import json
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = sorted([ROOT / "README.md", ROOT / "CHANGELOG.md", ROOT / "input" / "README.md",
               ROOT / "postprocess" / "README.md", ROOT / "bench" / "README.md",
               *(ROOT / "docs").glob("*.md")])
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]|<[^>]+>", "", heading.strip()).lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set:
    seen, out = {}, set()
    text = FENCE.sub("", path.read_text())
    for m in re.finditer(r"^#{1,6}\s+(.*?)\s*#*\s*$", text, re.M):
        s = slug(m.group(1))
        n = seen.get(s, 0)
        out.add(s if n == 0 else f"{s}-{n}")
        seen[s] = n + 1
    return out


def links(path: Path):
    text = FENCE.sub("", path.read_text())
    text = re.sub(r"`[^`\n]*`", "", text)           # code spans are not links
    for m in LINK.finditer(text):
        target = m.group(1)
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        yield target


def test_the_documents_exist():
    missing = [str(p.relative_to(ROOT)) for p in DOCS if not p.exists()]
    assert not missing, missing


@pytest.mark.parametrize("doc", [p for p in DOCS if p.exists()], ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    bad = []
    for target in links(doc):
        file, _, frag = target.partition("#")
        dest = (doc.parent / file).resolve() if file else doc
        if not dest.exists():
            bad.append(f"{target}: no file {dest}")
            continue
        try:
            dest.relative_to(ROOT)
        except ValueError:
            bad.append(f"{target}: outside the repository")
            continue
        if frag and dest.suffix == ".md" and frag not in anchors(dest):
            bad.append(f"{target}: no heading #{frag} in {dest.relative_to(ROOT)}")
    assert not bad, f"{doc.relative_to(ROOT)}:\n" + "\n".join(bad)


def test_cited_result_files_exist():
    """Every bench/results/... path named in a document is in the repository."""
    bad = []
    for doc in DOCS:
        if not doc.exists():
            continue
        for m in re.finditer(r"bench/results/([A-Za-z0-9_.*{},-]+)", doc.read_text()):
            name = m.group(1).rstrip(".,")
            if any(c in name for c in "*{") or "COMMIT" in name or "DATE" in name:   # patterns
                continue
            if not (ROOT / "bench" / "results" / name).exists():
                bad.append(f"{doc.relative_to(ROOT)}: bench/results/{name}")
    assert not bad, "\n".join(bad)


def test_no_round_diary_in_the_documents():
    """The documents say the current state; the history of the speed-up rounds is in
    git and, in a few lines with dates, in CHANGELOG.md."""
    bad = []
    for doc in DOCS:
        if doc.exists() and doc.name != "CHANGELOG.md":
            for m in re.finditer(r"^#+ .*\b(round|[0-9]+ (Nov|Dec) 20[0-9][0-9])\b.*$",
                                 doc.read_text(), re.M | re.I):
                bad.append(f"{doc.relative_to(ROOT)}: {m.group(0)}")
    assert not bad, "\n".join(bad)


def test_performance_table_is_its_data():
    """docs/performance.md's table is what bench/solver.py writes from docs/performance-data.json."""
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        import solver
    finally:
        sys.path.pop(0)
    data = json.loads((ROOT / "docs" / "performance-data.json").read_text())
    text = (ROOT / "docs" / "performance.md").read_text()
    begin, end = "<!-- table begin (bench/solver.py) -->", "<!-- table end -->"
    table = text[text.index(begin) + len(begin):text.index(end)].strip("\n").splitlines()
    assert table == solver.doc_table(data)
    for source in data["sources"] + [data["donewhen"]]:
        assert (ROOT / "bench" / "results" / source["log"]).exists(), source["log"]


def _solver():
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        import solver
    finally:
        sys.path.pop(0)
    return solver


def _bench_row(mode, bending, n, nranks, rate):
    """One row as bench/solver.py prints it (14 cells; the last four are not read back)."""
    return (f"| {mode} | {bending} | {n} | {nranks} | 10 | {rate:.3g} | 1.00 | 5.0 | 0.10 | 3.50 "
            f"| 30 % | 60 % | nan (nan %) | 12.0 (30 %) |")


DONEWHEN_LOG = """# bash bench/performance.sh: the done-when run, input/hang.nml at nx = ny = 65, t_end = 0.1;
t = 1.00000E-01  steps      100  rejected     0  newton      108  linear        454  retries     0
nuno: complete at t =  1.00000E-01: 100 steps, 0 rejected, wall time  1.000E+00 s
TSStep               100 1.0 9.0000e-01 1.0 1.48e+08 1.0 1.2e+04 2.3e+04 1.2e+04 96 100 86 84 92  96 100 86 84 92   759
\tMaximum resident set size (kbytes): 61440
real\t0m1.500s
"""


def test_performance_table_peer_columns(tmp_path):
    """bench/solver.py --replot of a log with the peer's lines (bench/performance.sh
    runs the peer with nuno, issue 46): the bw rows with bending at the peer's N get
    its node-steps/s and nuno/peer at as many ranks as the peer had threads, every
    other row '-'; a later log wins for the same (N, threads); a log without the
    peer gives today's ten columns. Synthetic logs; the ratios by hand."""
    solver = _solver()
    first = tmp_path / "performance-bench-aaaaaaa.log"
    first.write_text("\n".join([
        "triad: 40.0 GB/s on 1 core, 50.0 GB/s on 2",
        _bench_row("bw", "yes", 257, 1, 6.0e5), _bench_row("bw", "yes", 257, 2, 1.1e6),
        "peer N=257 threads=1 steps=30 cg_iterations_per_step=102.43 node_steps_per_s=3e+05",
        _bench_row("bw", "yes", 1025, 1, 4.0e5), _bench_row("bw", "yes", 1025, 2, 9.0e5),
        "peer N=1025 threads=2 steps=10 cg_iterations_per_step=318.10 node_steps_per_s=1.8e+05",
        _bench_row("newton", "yes", 257, 1, 4.0e5), _bench_row("bw", "no", 257, 1, 2.0e6)]) + "\n")
    later = tmp_path / "performance-bench-bbbbbbb.log"
    later.write_text("peer N=257 threads=1 steps=30 cg_iterations_per_step=102.43 node_steps_per_s=1.5e+05\n")
    dw = tmp_path / "performance-donewhen-aaaaaaa.log"
    dw.write_text(DONEWHEN_LOG)
    doc = tmp_path / "performance.md"
    doc.write_text("before\n<!-- table begin (bench/solver.py) -->\nold\n<!-- table end -->\nafter\n")
    out = tmp_path / "data.json"
    args = ["--replot", str(first), str(later), "--donewhen", str(dw), "--output", str(out), "--doc", str(doc)]
    pytest.importorskip("matplotlib")
    assert solver.main(args + ["--plot", str(tmp_path / "p.png")]) == 0
    assert (tmp_path / "p.png").stat().st_size > 0
    lines = doc.read_text().splitlines()
    assert lines[0] == "before" and lines[-1] == "after"
    head = [c.strip() for c in lines[2].strip("|").split("|")]
    assert head[5:7] == ["peer node-steps/s", "nuno / peer"] and len(head) == 12
    cells = {tuple(c.strip() for c in line.strip("|").split("|"))[:3]: [c.strip() for c in line.strip("|").split("|")]
             for line in lines[4:] if line.startswith("| yes") or line.startswith("| no")}
    # 6.0e5 / 1.5e5 = 4 (the later log's peer), 9.0e5 / 1.8e5 = 5 on 2 ranks against 2 threads
    assert cells[("yes", "bw", "257")][5:7] == ["1.5e+05 (1 thread)", "4.00 (1 rank)"]
    assert cells[("yes", "bw", "1025")][5:7] == ["1.8e+05 (2 threads)", "5.00 (2 ranks)"]
    assert cells[("yes", "newton", "257")][5:7] == ["-", "-"]
    assert cells[("no", "bw", "257")][5:7] == ["-", "-"]
    assert any(line.startswith("Done-when run (hang 65 x 65, 0.1 s, 2 ranks") for line in lines)
    data = json.loads(out.read_text())
    assert sorted((q["n"], q["threads"], q["node_steps_per_s"]) for q in data["peer"]) == \
        [(257, 1, 1.5e5), (1025, 2, 1.8e5)]
    assert solver.doc_table(data) == lines[2:-2]

    # without the peer's lines: no peer columns, no "peer" in the data
    first.write_text("\n".join(l for l in first.read_text().splitlines() if not l.startswith("peer ")) + "\n")
    assert solver.main(["--replot", str(first), "--donewhen", str(dw), "--output", str(out), "--doc", str(doc)]) == 0
    head = [c.strip() for c in doc.read_text().splitlines()[2].strip("|").split("|")]
    assert len(head) == 10 and "peer node-steps/s" not in head
    assert "peer" not in json.loads(out.read_text())
