# SPDX-License-Identifier: BSD-2-Clause
"""Convergence studies that judge the asymptotic range (issue 48 item 2).

Synthetic time-step studies (test_postprocess.write_study_run: a sheet
whose end state is a known quadratic plus err * g(x, y)) give differences
of successive runs |err_k - err_k+1| max|g| exactly, so the orders the tool
must judge are computed here from the chosen errors: falling differences of
one order give a Richardson estimate and a fit; growing differences, or
orders that disagree beyond the band, give one line and no estimate or fit
(never an order p <= 0); three runs give one ratio, whose errors against
Richardson are not drawn as evidence; the title names the files (or the
sweep's namelist file), not the scene key. The last test is the issue's
own example through nuno-sweep (drop_table, 4 steps, 11 x 11)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from postprocess import convergence, plotting, sweep
from postprocess.reader import read_run
from test_postprocess import assert_png, g_max_on, write_study_run

DTS = (0.008, 0.004, 0.002, 0.001, 0.0005)


def dt_study(tmp_path, errs, dts=DTS, stem="case_dt-", scene="flat"):
    """One file a step, named <stem><dt>.h5, whose error term is errs[k] g."""
    return [write_study_run(tmp_path / f"{stem}{dt:g}.h5", 11, dt=dt, err=e, scene=scene)
            for dt, e in zip(dts, errs)]


def printed(text: str, key: str) -> list[list[float]]:
    return [list(map(float, ln.split()[1:])) for ln in text.splitlines()
            if ln.startswith(key + " ")]


def expected_orders(errs, dts):
    """Orders of the differences of successive runs, from the chosen errors."""
    d = np.abs(np.diff(errs))
    return [math.log(d[k] / d[k + 1]) / math.log(dts[k] / dts[k + 1]) for k in range(len(d) - 1)]


def legend_texts(fig):
    return [t.get_text() for t in plotting.panels(fig)[0].get_legend().get_texts()]


def test_growing_differences_give_no_estimate(tmp_path, capsys):
    """The issue's shape: differences that grow as dt shrinks (1e-9, 2e-9,
    5e-7). One line says so with the orders of the differences; no
    Richardson errors, no fitted or observed order (the old tool built a
    Richardson estimate with p = -6.28)."""
    errs = [0.0, 1e-9, 3e-9, 5.03e-7]
    dts = DTS[:4]
    paths = dt_study(tmp_path, errs, dts)
    out = tmp_path / "conv.png"
    assert convergence.main([*map(str, paths), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    ps = expected_orders(errs, dts)
    assert ps[0] == pytest.approx(-1.0) and ps[1] < -7           # what is to be judged
    lines = [ln for ln in text.splitlines() if ln.startswith("not in the asymptotic range")]
    assert len(lines) == 1, text
    assert lines[0].startswith(f"not in the asymptotic range: orders {ps[0]:.2f}, {ps[1]:.2f} ")
    assert "(band: each > 0, largest <= 1.2 x smallest)" in lines[0]
    assert "no Richardson estimate and no fitted order" in lines[0]
    for key in ("error", "order", "orders", "observed_order_differences"):
        assert printed(text, key) == [], (key, text)
    np.testing.assert_allclose([d for _, d in printed(text, "difference")],
                               np.abs(np.diff(errs)) * g_max_on(11), rtol=1e-5)  # round-off of 0.4 + 1e-9
    assert_png(out)
    res = convergence.study([read_run(p) for p in paths])
    assert res["range"] == "out" and res["observed"] is None and res["order"] is None
    assert len(res["errors"]) == 0
    fig = convergence.build_figure(res)
    legend = legend_texts(fig)
    assert not any("distance from" in t for t in legend), legend
    assert fig._supxlabel.get_text().replace("\n", " ").startswith("not in the asymptotic range")


def test_orders_that_disagree_beyond_the_band(tmp_path, capsys):
    """Differences 8e-3, 2e-3, 1e-3 fall, at orders 2 and 1: outside the
    default band (2 > 1.2 x 1), inside --band 1.5 (2 <= 2.5 x 1), where the
    Richardson estimate and the fit are given."""
    errs = np.array([11e-3, 3e-3, 1e-3, 0.0])
    dts = DTS[:4]
    paths = dt_study(tmp_path, errs, dts)
    ps = expected_orders(errs, dts)
    np.testing.assert_allclose(ps, [2.0, 1.0], atol=1e-12)
    assert convergence.main([*map(str, paths), "-o", str(tmp_path / "a.png")]) == 0
    text = capsys.readouterr().out
    assert "not in the asymptotic range: orders 2.00, 1.00 " in text
    assert printed(text, "order") == [] and printed(text, "observed_order_differences") == []
    assert convergence.main([*map(str, paths), "--band", "1.5", "-o", str(tmp_path / "b.png")]) == 0
    text = capsys.readouterr().out
    assert "asymptotic range: orders 2.00, 1.00 of the differences of successive runs agree " \
           "(band: each > 0, largest <= 2.5 x smallest)" in text
    (observed,) = printed(text, "observed_order_differences")
    d = np.abs(np.diff(errs))
    slope = np.polyfit(np.log(dts[:3]), np.log(d), 1)[0]       # the fit of the differences
    assert observed[0] == pytest.approx(slope, abs=1e-9) and observed[0] > 0
    assert len(printed(text, "error")) == 4 and len(printed(text, "order")) == 1


def test_one_order_in_range_gives_richardson_and_a_fit(tmp_path, capsys):
    """Errors C dt^2 g on five steps: the differences fall at order 2 three
    times, in range; Richardson removes the error exactly (errors C dt^2
    max|g|) and the fit is 2."""
    C = 40.0
    errs = [C * dt**2 for dt in DTS]
    paths = dt_study(tmp_path, errs)
    assert convergence.main([*map(str, paths), "-o", str(tmp_path / "c.png")]) == 0
    text = capsys.readouterr().out
    assert "asymptotic range: orders 2.00, 2.00, 2.00 of the differences of successive runs agree" in text
    np.testing.assert_allclose([e for _, e in printed(text, "error")],
                               C * np.array(DTS)**2 * g_max_on(11), rtol=1e-8)
    assert printed(text, "order")[0][0] == pytest.approx(2.0, abs=1e-8)


def test_three_runs_are_one_ratio(tmp_path, capsys):
    """Three runs: one order of the differences, the range unchecked; the
    errors against Richardson come from that ratio: printed as estimates
    (exactly C dt^2 max|g| here), said so, not drawn, no order fitted."""
    C = 40.0
    dts = DTS[:3]
    paths = dt_study(tmp_path, [C * dt**2 for dt in dts], dts)
    assert convergence.main([*map(str, paths), "-o", str(tmp_path / "d.png")]) == 0
    text = capsys.readouterr().out
    (line,) = [ln for ln in text.splitlines() if "asymptotic range" in ln]
    assert line.startswith("asymptotic range not checked: 3 runs give one order (2.00)")
    assert "follow from that one ratio" in line and "not separate evidence" in line
    np.testing.assert_allclose([e for _, e in printed(text, "error")],
                               C * np.array(dts)**2 * g_max_on(11), rtol=1e-8)
    assert printed(text, "order") == [] and printed(text, "orders") == []
    fig = convergence.build_figure(convergence.study([read_run(p) for p in paths]))
    legend = legend_texts(fig)
    assert not any("distance from" in t for t in legend), legend
    assert any(t.startswith("max difference of successive runs: orders 2.00") for t in legend)
    ax = plotting.panels(fig)[0]
    drawn = [ln for ln in ax.get_lines() if ln.get_label().startswith("max")]
    assert len(drawn) == 1 and len(drawn[0].get_xdata()) == 2     # the two differences only


def test_reference_run_errors_at_a_floor_give_no_fit(tmp_path, capsys):
    """Against a reference run: errors 4e-2, 1e-2, 5e-3, 4.9e-3 (the last at
    the reference's own accuracy) have orders 2, 1, 0.03: no fitted order;
    the errors themselves (distances from an independent run) are printed."""
    errs = [4e-2, 1e-2, 5e-3, 4.9e-3]
    dts = DTS[:4]
    paths = dt_study(tmp_path, errs, dts)
    ref = write_study_run(tmp_path / "ref.h5", 11, dt=1e-5, err=0.0)
    assert convergence.main([*map(str, paths), "--reference-run", str(ref),
                             "-o", str(tmp_path / "e.png")]) == 0
    text = capsys.readouterr().out
    np.testing.assert_allclose([e for _, e in printed(text, "error")],
                               np.array(errs) * g_max_on(11), rtol=1e-9)
    assert printed(text, "order") == []
    assert "not in the asymptotic range: orders 2.00, 1.00, 0.03 of the errors against the " \
           "reference run" in text


def test_csv_study_outside_the_range_has_no_slope(tmp_path, capsys):
    csv = tmp_path / "s.csv"
    csv.write_text("parameter,error\n0.1,1e-3\n0.05,2e-3\n0.025,1e-2\n")
    assert convergence.main([str(csv), "-o", str(tmp_path / "f.png")]) == 0
    text = capsys.readouterr().out
    assert printed(text, "slope") == []
    assert "not in the asymptotic range: orders -1.00, -2.32 " in text
    csv.write_text("parameter,error\n0.1,4e-2\n0.05,1e-2\n0.025,2.5e-3\n")
    assert convergence.main([str(csv), "-o", str(tmp_path / "g.png")]) == 0
    assert printed(capsys.readouterr().out, "slope")[0][0] == pytest.approx(2.0, abs=1e-9)


def test_title_names_the_files_not_the_scene(tmp_path):
    """Files drop_table_dt-*.h5 of scene 'flat': the title names the files
    and what varies; --name (what nuno-sweep passes: the namelist file)
    replaces the files' name."""
    dts = DTS[:3]
    paths = dt_study(tmp_path, [40.0 * dt**2 for dt in dts], dts, stem="drop_table_dt-")
    res = convergence.study([read_run(p) for p in paths])
    title = plotting.panels(convergence.build_figure(res))[0].get_title()
    assert title == "drop_table_dt-*.h5: dt = 0.008 .. 0.002 s (3 runs), max norm, t = 1 s"
    assert "flat" not in title
    out = tmp_path / "n.png"
    assert convergence.main([*map(str, paths), "--name", "drop_table.nml", "-o", str(out)]) == 0
    res["name"] = "drop_table.nml"
    assert convergence.title(res).startswith("drop_table.nml: dt = 0.008 .. 0.002 s")


def test_issue_example_through_nuno_sweep(tmp_path, capsys):
    """`nuno-sweep input/drop_table.nml --dt 4e-3,2e-3,1e-3,5e-4` (11 x 11):
    whatever the runs give, the tool's verdict follows from the differences
    it prints (orders computed here): outside the range no error, order or
    observed order is printed; inside, the observed order is > 0. The
    figure's title names drop_table.nml, not the scene key 'flat'."""
    import nunorun
    root = Path(__file__).resolve().parents[2]
    args = [str(root / "input" / "drop_table.nml"), "--dt", "4e-3,2e-3,1e-3,5e-4",
            "--fixed", "nx=11,ny=11", "--outdir", str(tmp_path / "out"), "--exe", nunorun.exe(),
            "--mpiexec", f"{nunorun.mpiexec()} --oversubscribe"]
    assert sweep.main(args) == 0
    text = capsys.readouterr().out
    d = [v for _, v in printed(text, "difference")]
    assert len(d) == 3
    ps = [math.log(d[k] / d[k + 1]) / math.log(2.0) for k in range(2)]
    inside = min(ps) > 0 and max(ps) <= 1.2 * min(ps)
    if inside:
        assert printed(text, "observed_order_differences")[0][0] > 0
    else:
        assert f"not in the asymptotic range: orders {ps[0]:.2f}, {ps[1]:.2f} " in text
        for key in ("error", "order", "observed_order_differences"):
            assert printed(text, key) == [], key
    runs = [read_run(p) for p in sorted((tmp_path / "out").glob("*.h5"))]
    assert runs[0].scene() == "flat"
    title = plotting.panels(convergence.build_figure(convergence.study(runs)))[0].get_title()
    assert "flat" not in title
    assert_png(tmp_path / "out" / "convergence.png")
    assert "--name drop_table.nml" in text
