"""`gantry compare` and `gantry run --baseline`: a run against a baseline report, block by block."""

from __future__ import annotations

import json

import pytest

from gantry_sim.sim.cli import main
from gantry_sim.sim.compare import Margins, compare, format_table

CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"


def block(line, kind, err, t):
    return {"line": line, "kind": kind, "max_error_um": err, "time_s": t}


BASE = {"cycle_time_s": 10.0, "blocks": [block(2, "linear", 1.0, 2.0), block(3, "arc", 4.0, 5.0)]}


def test_margins_are_the_larger_of_absolute_and_relative():
    m = Margins(error_um=0.1, error_pct=5.0, time_s=0.001, time_pct=1.0)
    ok = dict(BASE, blocks=[block(2, "linear", 1.09, 2.0), block(3, "arc", 4.19, 5.04)])
    assert compare(BASE, ok, m).passed  # +0.09 < 0.1 um; +0.19 < 5% of 4; +0.04 < 1% of 5 s
    bad = dict(BASE, blocks=[block(2, "linear", 1.0, 2.0), block(3, "arc", 4.3, 5.0)])
    cmp = compare(BASE, bad, m)
    assert not cmp.passed
    [fail] = cmp.failures
    assert fail["gate"] == "baseline block error" and fail["line"] == 3
    assert [r.status for r in cmp.rows] == ["ok", "FAIL error"]
    slow = dict(
        BASE, cycle_time_s=10.2, blocks=[block(2, "linear", 1.0, 2.2), block(3, "arc", 4, 5)]
    )
    gates = {f["gate"] for f in compare(BASE, slow, m).failures}
    assert gates == {"baseline block time", "baseline cycle time"}
    # a shrinking error or time never fails; a block only in one report is listed, not failed
    better = dict(BASE, cycle_time_s=9.0, blocks=[block(3, "arc", 1.0, 4.0), block(9, "arc", 9, 9)])
    cmp = compare(BASE, better, m)
    assert cmp.passed and [r.status for r in cmp.rows] == ["gone", "changed", "new"]
    table = format_table(cmp, m)
    assert "gone" in table and table.endswith("PASS")


def _run(prog, out, *extra):
    assert main(["run", str(prog), "--out", str(out), "--no-plots", *extra]) in (0, 1)
    return json.loads((out / "report.json").read_text())


@pytest.fixture
def runs(write_program, tmp_path):
    """The circle on the bundled machine (base), with half the acceleration feed-forward
    (soft: same motion, larger error) and at half the feed (slow: same error, longer)."""
    prog = write_program(CIRCLE)
    soft_machine = tmp_path / "soft.toml"
    soft_machine.write_text("[servo]\nff_acceleration = [0.5, 0.5, 0.5]\n")
    base = _run(prog, tmp_path / "base")
    soft = _run(prog, tmp_path / "soft", "--machine", str(soft_machine))
    _run(prog, tmp_path / "slow", "--feed-override", "50")
    return prog, base, soft


def test_compare_fails_when_the_error_grows_and_prints_the_table(runs, tmp_path, capsys):
    _prog, base, soft = runs
    pairs = zip(base["blocks"], soft["blocks"], strict=True)
    grown = [s["max_error_um"] - b["max_error_um"] for b, s in pairs]
    assert min(grown) > 1.0
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "base"), str(tmp_path / "soft")]) == 1
    out = capsys.readouterr().out
    assert out.count("FAIL error") == 3 and "block error" in out and "(3 block(s) over)" in out
    assert "note: machine differs" in out
    assert out.rstrip().endswith("FAIL")
    # slower: every block's time and the cycle time grew
    assert main(["compare", str(tmp_path / "base"), str(tmp_path / "slow" / "report.json")]) == 1
    out = capsys.readouterr().out
    assert out.count("FAIL time") == 3 and "FAIL: cycle time" in out
    # a report against itself: nothing changed
    assert main(["compare", str(tmp_path / "base"), str(tmp_path / "base")]) == 0
    out = capsys.readouterr().out
    assert "0 block(s) changed" in out and out.rstrip().endswith("PASS")
    # wide margins let the softer machine pass
    assert main(["compare", "--error-margin-pct", "400", "--json", str(tmp_path / "base"),
                 str(tmp_path / "soft")]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["passed"] is True


def test_run_baseline_gates_and_records_it(runs, tmp_path, capsys):
    prog, _base, _soft = runs
    # the baseline is the report in the output folder itself: read before it is replaced
    rep = _run(prog, tmp_path / "base", "--feed-override", "50", "--baseline",
               str(tmp_path / "base"))  # fmt: skip
    assert rep["verdict"]["passed"] is False
    assert rep["verdict"]["baseline"] == str(tmp_path / "base")
    gates = {f["gate"] for f in rep["verdict"]["failures"]}
    assert gates == {"baseline block time", "baseline cycle time"}
    assert "FAIL time" in capsys.readouterr().out
    rep = _run(prog, tmp_path / "again", "--feed-override", "50", "--baseline",
               str(tmp_path / "slow" / "report.json"))  # fmt: skip
    assert rep["verdict"]["passed"] is True and rep["verdict"]["failures"] == []


def test_compare_missing_report_exits_2(tmp_path, capsys):
    assert main(["compare", str(tmp_path), str(tmp_path)]) == 2
    assert "report.json: error: no report.json here" in capsys.readouterr().err


def test_cli_margin_defaults_are_the_library_defaults():
    from gantry_sim.sim.commands.compare import MARGINS

    defaults = Margins()
    cli = {option: default for option, default, _, _ in MARGINS}
    assert cli == {
        "--error-margin-um": defaults.error_um,
        "--error-margin-pct": defaults.error_pct,
        "--time-margin-s": defaults.time_s,
        "--time-margin-pct": defaults.time_pct,
    }


def test_a_baseline_without_block_times_compares_errors_and_cycle_time():
    old = {"cycle_time_s": 10.0, "blocks": [{"line": 3, "kind": "arc", "max_error_um": 4.0}]}
    run = {"cycle_time_s": 10.5, "blocks": [block(3, "arc", 4.0, 9.0)]}
    cmp = compare(old, run, Margins())
    assert [r.status for r in cmp.rows] == ["ok"]  # no time to compare per block
    assert [f["gate"] for f in cmp.failures] == ["baseline cycle time"]


GOOD = {"cycle_time_s": 1.0, "blocks": [{"line": 2, "kind": "linear", "max_error_um": 1.0}]}


@pytest.mark.parametrize(
    ("bad", "fragment"),
    [
        ({"cycle_time_s": 1.0, "blocks": "x"}, "blocks is not a list"),
        ({"cycle_time_s": None, "blocks": []}, "cycle_time_s is None"),
        ({"cycle_time_s": 1.0, "blocks": [None]}, "blocks[0] is not an object"),
        ({"cycle_time_s": "1", "blocks": []}, "not a number"),
        ({"cycle_time_s": 1.0, "blocks": [{"line": 2, "max_error_um": "big"}]}, "max_error_um"),
        ({"cycle_time_s": 1.0, "blocks": [{"line": 2.5, "max_error_um": 1.0}]}, ".line is 2.5"),
        # a 400-digit integer exited 3 (OverflowError); a negative time or error is no report's
        ({"cycle_time_s": 10**400, "blocks": []}, "cycle_time_s is 1000"),
        ({"cycle_time_s": -1.0, "blocks": []}, "cycle_time_s is -1.0, not a number >= 0"),
        ({"cycle_time_s": 1.0, "blocks": [{"line": 2, "max_error_um": -3}]}, "is -3, not a"),
        # a megabyte of value: quoted to 40 characters
        ({"cycle_time_s": 1.0, "blocks": [{"line": "a" * 10**6}]}, ".line is 'aaaa"),
    ],
)
def test_a_report_of_the_wrong_shape_exits_2_naming_it(tmp_path, capsys, bad, fragment):
    # these exited 3 (TypeError inside the comparison), found by a hostile-input sweep
    good, wrong = tmp_path / "good.json", tmp_path / "wrong.json"
    good.write_text(json.dumps(GOOD))
    wrong.write_text(json.dumps(bad))
    assert main(["compare", str(good), str(wrong)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{wrong}: error: not a gantry report.json (") and fragment in err, err
    assert len(err) < 200 + len(str(wrong))
    assert main(["compare", str(good), str(good)]) == 0
