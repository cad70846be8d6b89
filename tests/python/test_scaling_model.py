# SPDX-License-Identifier: BSD-2-Clause
"""bench/scaling_model.py (docs/performance.md, "Scaling"): the model runs,
its numbers obey the laws a strip model must (one rank is the measured
step; more ranks never less halo a rank, never more compute a rank, never
better than perfect), and its multigrid hierarchy is the one nuno builds
(which level is replicated) on 8 and 16 ranks."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

import nunorun

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
import scaling_model as sm  # noqa: E402


def args(*extra):
    return sm.parse(["--no-figure", *extra])


def test_runs_and_prints_every_case():
    proc = subprocess.run([sys.executable, str(ROOT / "bench" / "scaling_model.py"), "--no-figure"],
                          capture_output=True, text=True, check=True, cwd=ROOT)
    rows = [line for line in proc.stdout.splitlines() if re.match(r"\| \d", line)]
    assert len(rows) == 4 * 7          # N in 1025..8193, P in 64..4096
    subprocess.run([sys.executable, str(ROOT / "bench" / "scaling_model.py"), "--help"],
                   capture_output=True, check=True)


def test_one_rank_is_the_measured_step():
    # with the measured run's cycles a step, the model's one-rank step at
    # its size is that run's TSStep time over its steps
    m = sm.MEASURED
    a = args("--cycles", repr(m["cycles"] / m["steps"]))
    r = sm.model(m["n"], 1, a)
    assert r["total"] == pytest.approx(m["t_step"] / m["steps"], rel=1e-12)
    assert r["halo"] == r["reductions"] == r["coarse"] == 0.0


def test_telescope_halo_grows_with_ranks():
    # every level distributed (the remedy): more ranks, never less halo a rank
    a = args("--telescope")
    for n in a.sizes:
        ok = [sm.model(n, p, a) for p in a.ranks if sm.strips_allow(n, p)]
        for lo, hi in zip(ok, ok[1:]):
            assert hi["halo"] >= lo["halo"]


def test_strip_laws():
    a = args()
    for n in a.sizes:
        ok = [sm.model(n, p, a) for p in a.ranks if sm.strips_allow(n, p)]
        assert ok, n
        for lo, hi in zip(ok, ok[1:]):
            # more ranks: the strip's halo a rank at least its sweeps'
            # (two rows of N whatever P), more over all ranks; never more
            # rows or compute a rank
            # at least the three exchanges of the finest level's sweeps, 2 rows of N each
            assert hi["halo_fine"] >= hi["cycles"] * 6 * sm.message(3 * 4 * 2 * n, a)
            assert hi["p"] * hi["halo_fine"] > lo["p"] * lo["halo_fine"]
            assert hi["rows"] <= lo["rows"]
            assert hi["reductions"] > lo["reductions"]
            assert hi["compute"] <= lo["compute"] * (1 + 1e-12)
        for r in ok:
            # the breakdown is the whole step
            parts = r["compute"] + r["halo"] + r["reductions"] + r["coarse"]
            assert parts == pytest.approx(r["total"], rel=1e-12)
            t1 = sm.model(n, 1, a)["total"]
            assert t1 / (r["p"] * r["total"]) <= 1.0     # never better than perfect
        # strips stop at 2 rows a rank (DMDA's stencil width)
        for p in a.ranks:
            assert sm.strips_allow(n, p) == (n // p >= 2)


def test_free_communication_leaves_the_load_imbalance():
    # with free messages, memory and flops, the time a step on P ranks is
    # the one-rank compute of the largest strip's rows (all levels
    # distributed): no less than T(1) / P, no more than T(1) times the
    # largest strip's 17 rows and one (the coarse levels' rounding) over 1025
    a = args("--latency", "0", "--bandwidth", "inf", "--core-bandwidth", "inf", "--flops", "inf", "--telescope")
    n, p = 1025, 64
    r = sm.model(n, p, a)
    assert r["halo"] == r["reductions"] == 0.0
    assert r["coarse"] == 0.0
    t1 = sm.model(n, 1, a)["total"]
    assert t1 / p <= r["total"] <= t1 * (17 + 1) / 1025


def test_replicated_coarsest_grows_with_ranks_not_lattice():
    a = args()
    # the replicated level is the first with fewer than 2 rows a rank:
    # between P / 2 and 4 P rows whatever N (the model's dominant cost)
    for n in a.sizes:
        for p in a.ranks:
            if sm.strips_allow(n, p):
                side = sm.model(n, p, a)["coarse_side"]
                assert p // 2 <= side <= 4 * p, (n, p, side)


@pytest.mark.parametrize("n, p, gather", [(65, 8, "auto"), (129, 16, "auto"), (65, 16, "auto"),
                                           (65, 8, "never"), (129, 16, "never")])
def test_hierarchy_is_nunos(tmp_path, n, p, gather):
    # nuno's own levels on p ranks (oversubscribed): sides, which ones are
    # gathered on how many ranks, and which one is the replicated coarsest,
    # against the model's (--telescope: -nuno_mg_gather auto, nuno's
    # default; without: never). Without the gathering nuno's levels stop
    # at the replicated 9 x 9 (65 on 8 ranks) or 17 x 17 (16 ranks) and
    # the auto cases fail.
    dt = 1.0 / 600
    proc, _ = nunorun.run(tmp_path, f"h{n}", nranks=p,
                          options=("-snes_type", "ksponly", "-reduced_ksp_view", "-nuno_mg_gather", gather),
                          timeout=240, scene="scene='hang'", lattice=f"nx={n} ny={n}",
                          time=f"t_end={dt!r} dt={dt!r}", output=f"output_interval={dt!r}")
    view = proc.stdout[:proc.stdout.index("one cycle reads")]    # the first solve's hierarchy
    sides = [int(s) for s in re.findall(r"level \d+: (\d+) x \d+", view)]
    gathered = {int(s): int(k) for s, k in re.findall(r"level \d+: (\d+) x \d+[^\n]*gathered on (\d+) ranks", view)}
    coarsest = [int(s) for s in re.findall(r"level \d+: (\d+) x \d+, [^\n]*coarsest: banded LU", view)]
    assert sides and len(coarsest) == 1
    levels = sm.hierarchy(n, p, telescope=gather == "auto")
    assert sides == [s for s, _, _, _ in levels]
    assert coarsest[0] == levels[-1][0]
    assert gathered == {s: k for s, _, dist, k in levels if dist and k < p}
    if gather == "auto":
        # at least one level gathered, each rank of it with 2 rows or more
        assert gathered and all(s // k >= 2 for s, k in gathered.items())
        assert levels[-1][0] == 5
