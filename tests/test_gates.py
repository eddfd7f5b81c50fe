"""Gates: per-kind and per-line-range error limits, the cycle-time limit, the verdict in
report.json, and sweep/tune failing when nothing passes."""

from __future__ import annotations

import json

import pytest

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.cli import main
from gantry_sim.sim.gates import (
    ErrorLimit,
    Gates,
    evaluate,
    gates_from_options,
    parse_error_limits,
    parse_line_limits,
)

# a lead-in line (2), a full R5 circle (3), a lead-out line (4): ~1 s simulated
CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"
REPORT = {
    "cycle_time_s": 12.0,
    "blocks": [
        {"line": 5, "kind": "linear", "max_error_um": 9.0},
        {"line": 6, "kind": "arc", "max_error_um": 4.0},
        {"line": 7, "kind": "arc", "max_error_um": 6.0},
        {"line": 40, "kind": "linear", "max_error_um": 2.0},
    ],
}


def test_limits_parse_per_kind_and_per_line_range():
    assert parse_error_limits("8") == [ErrorLimit(8.0)]
    assert parse_error_limits("arc=5, linear=8") == [
        ErrorLimit(5.0, kind="arc"),
        ErrorLimit(8.0, kind="linear"),
    ]
    assert parse_line_limits("10-40=3,12=2.5") == [
        ErrorLimit(3.0, lines=(10, 40)),
        ErrorLimit(2.5, lines=(12, 12)),
    ]
    for bad in ("helix=3", "arc=-1", "x", "arc=nan"):
        with pytest.raises(ConfigError):
            parse_error_limits(bad)
    for bad in ("10-40", "40-10=3", "a-b=3", "0=3"):
        with pytest.raises(ConfigError):
            parse_line_limits(bad)


def test_each_limit_judges_only_its_blocks():
    # the plunge-like linear block 5 (9 um) must not decide the arcs' gate
    assert evaluate(REPORT, Gates((ErrorLimit(6.5, kind="arc"),))) == []
    [fail] = evaluate(REPORT, Gates((ErrorLimit(5.0, kind="arc"),)))
    assert (fail["line"], fail["value"], fail["blocks_over"], fail["lines"]) == (7, 6.0, 1, [7])
    [fail] = evaluate(REPORT, Gates((ErrorLimit(1.5, lines=(30, 50)),)))
    assert fail["line"] == 40 and fail["gate"] == "--max-error-um-lines 30-50=1.5"
    [fail] = evaluate(REPORT, Gates((ErrorLimit(5.0),)))
    assert fail["line"] == 5 and fail["blocks_over"] == 2
    [fail] = evaluate(REPORT, gates_from_options(max_cycle_time_s=10.0))
    assert fail["unit"] == "s" and fail["value"] == 12.0 and fail["limit"] == 10.0
    assert evaluate(REPORT, gates_from_options(["arc=6,linear=9"], ["40=2"], 12.0)) == []


def _run(prog, out, *extra):
    status = main(["run", str(prog), "--out", str(out), "--no-plots", *extra])
    return status, json.loads((out / "report.json").read_text())


def test_run_gates_write_the_verdict(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    out = tmp_path / "out"
    status, rep = _run(prog, out)
    assert status == 0
    assert rep["verdict"] == {"passed": True, "gates": [], "failures": [], "baseline": None}
    arc = next(b for b in rep["blocks"] if b["kind"] == "arc")["max_error_um"]
    line = max(b["max_error_um"] for b in rep["blocks"] if b["kind"] == "linear")
    # a limit between the lines' error and the arc's: only the arc fails
    status, rep = _run(prog, out, "--max-error-um", f"arc={arc * 0.9},linear={line * 1.1}")
    assert status == 1
    assert rep["verdict"]["passed"] is False
    [fail] = rep["verdict"]["failures"]
    assert fail["line"] == 3 and fail["gate"].startswith("--max-error-um arc=")
    assert "FAIL: line 3 (arc)" in capsys.readouterr().out
    status, rep = _run(prog, out, "--max-error-um-lines", f"3={arc * 1.01}")
    assert "PASS: --max-error-um-lines 3=" in capsys.readouterr().out
    assert status == 0 and rep["verdict"]["gates"] == [f"--max-error-um-lines 3={arc * 1.01:g}"]
    status, rep = _run(prog, out, "--max-error-um-lines", f"2-4={arc * 0.5}")
    assert status == 1 and rep["verdict"]["failures"][0]["line"] == 3
    status, rep = _run(prog, out, "--max-cycle-time-s", str(rep["cycle_time_s"] * 0.99))
    assert status == 1 and rep["verdict"]["failures"][0]["unit"] == "s"
    status, rep = _run(prog, out, "--max-cycle-time-s", str(rep["cycle_time_s"] * 1.01))
    assert status == 0


def test_bad_gate_option_exits_2(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    assert main(["run", str(prog), "--out", str(tmp_path), "--max-error-um", "helix=3"]) == 2
    assert "--max-error-um: error:" in capsys.readouterr().err


def test_sweep_exits_1_when_every_point_faults(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    strict = tmp_path / "strict.toml"  # a following-error limit no motion can keep
    strict.write_text("[servo]\nmax_following_error_mm = 0.0001\n")
    args = ["sweep", str(prog), "--machine", str(strict), "--workers", "1"]
    assert main([*args, "--out", str(tmp_path / "sw")]) == 1
    assert "FAIL: all 1 grid point(s) faulted" in capsys.readouterr().err
    assert (tmp_path / "sw" / "sweep_error_vs_feed.png").exists()


@pytest.mark.slow
def test_tune_exits_1_when_a_radius_is_unreachable(tmp_path, capsys):
    # 1 nm on a circle: no feed down to the 100 mm/min minimum passes
    args = ["tune", "--radii", "5", "--tolerance-um", "0.001", "--out", str(tmp_path)]
    assert main(args) == 1
    assert "unreachable" in capsys.readouterr().err
    summary = json.loads((tmp_path / "tune.json").read_text())
    assert summary["rows"][0]["max_feed_mm_per_min"] is None
