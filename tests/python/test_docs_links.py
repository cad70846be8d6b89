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
