"""A subroutine file's lines are feed blocks of their own (sim/block_files.py): its line 3 is not
the program's line 3, in report.json, the summary, the gates and ``gantry compare``, streamed or
not."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.sim import api
from gantry_sim.sim.block_files import block_keys, split_key, tick_keys
from gantry_sim.sim.compare import Margins, compare
from gantry_sim.sim.gates import Gates, evaluate, parse_error_limits, parse_line_limits

SIDE = "o<side> sub\nG1 X10 F600\nG1 Y10\no<side> endsub\nM2\n"
#: line 3 here and line 3 of side.ngc are both G1 moves; line 2 here is a rapid
MAIN = "G21 G90 G17\nG0 X0 Y0\nG1 X5 F900\no<side> call\nG1 X0 Y0\nM2\n"


def test_keys_are_the_lines_without_subroutine_files_and_apart_with_them():
    lines = np.array([3, 2, 3, 5])
    same, none = block_keys(lines, [None] * 4)
    assert none == () and np.array_equal(same, lines)
    assert tick_keys(lines, None, same, none) is lines
    keys, files = block_keys(lines, [None, "a.ngc", "a.ngc", "b.ngc"])
    assert files == ("a.ngc", "b.ngc") and len(set(keys.tolist())) == 4
    assert [split_key(int(k), files) for k in keys] == [
        (3, None), (2, "a.ngc"), (3, "a.ngc"), (5, "b.ngc")
    ]  # fmt: skip
    source = np.array([[0, 0], [2, 2], [-1, -1], [3, 3]])  # a tick with no move: its line
    ticks = tick_keys(np.array([3, 3, 7, 5]), source, keys, files)
    assert ticks.tolist() == [3, keys[2], 7, keys[3]]


def _report(machine, folder: Path, stream: bool, monkeypatch) -> dict:
    if stream:
        monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    result = api.run_program(folder / "main.ngc", machine=machine, plots=False)
    out = folder / ("streamed" if stream else "whole")
    api.write_run_outputs(result, out, deterministic=True)
    return json.loads((out / "report.json").read_text())


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "side.ngc").write_text(SIDE)
    (tmp_path / "main.ngc").write_text(MAIN)
    return tmp_path


def test_a_subroutine_files_lines_are_blocks_of_their_own(machine, folder, monkeypatch):
    whole = _report(machine, folder, False, monkeypatch)
    side = str(folder / "side.ngc")
    assert [(b["line"], b.get("file")) for b in whole["blocks"]] == [
        (3, None), (2, side), (3, side), (5, None)
    ]  # fmt: skip
    assert all(b["kind"] == "linear" for b in whole["blocks"])
    # the blocks' times are their own moves': side.ngc's line 3 (10 mm at F600) twice its
    # line 2 (5 mm), the program's line 3 (5 mm at F900) apart from it (merged: 1.36 s)
    t = {(b["line"], b.get("file")): b["time_s"] for b in whole["blocks"]}
    assert t[(3, side)] == pytest.approx(2 * t[(2, side)], rel=0.1)
    assert t[(3, None)] < 0.5 < t[(3, side)] < 1.1
    streamed = _report(machine, folder, True, monkeypatch)
    assert streamed["blocks"] == whole["blocks"]  # the same figures, bit for bit


def test_line_gates_are_the_programs_lines_and_failures_name_the_file(machine, folder, monkeypatch):
    report = _report(machine, folder, False, monkeypatch)
    side = str(folder / "side.ngc")
    worst = max(report["blocks"], key=lambda b: b["max_error_um"])
    assert worst.get("file") == side  # the bundled machine lags most on side.ngc's corner
    # line 2 of the program is a rapid: a gate on it sees no block, not side.ngc's line 2
    assert evaluate(report, Gates(tuple(parse_line_limits("2=0.001")))) == []
    (fail,) = evaluate(report, Gates(tuple(parse_error_limits("0.001"))))
    assert fail["file"] == side and f"line {worst['line']} of {side}" in fail["message"]


def test_compare_tells_the_same_line_of_two_files_apart(machine, folder, monkeypatch):
    base = _report(machine, folder, False, monkeypatch)
    run = json.loads(json.dumps(base))
    side = str(folder / "side.ngc")
    for b in run["blocks"]:
        if b["line"] == 3 and b.get("file") == side:
            b["max_error_um"] += 5.0  # side.ngc's line 3 got worse; the program's did not
    cmp = compare(base, run, Margins())
    (bad,) = [r for r in cmp.rows if r.status != "ok"]
    assert (bad.line, bad.file, bad.status) == (3, side, "FAIL error")
    assert len(cmp.rows) == 4 and f"line 3 of {side}" in cmp.failures[0]["message"]


@pytest.mark.parametrize("stream", [False, True])
def test_a_servo_error_in_a_subroutine_file_names_that_file(machine, folder, monkeypatch, stream):
    from gantry_sim.controller.errors import SimulationError

    if stream:
        monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    (folder / "first.ngc").write_text("G21 G90\no<side> call\nM2\n")  # its line 2 calls
    tight = machine.with_changes("servo", max_following_error_mm=1e-4)
    with pytest.raises(SimulationError) as err:
        api.run_program(folder / "first.ngc", machine=tight, plots=False)
    assert (err.value.file, err.value.line) == (str(folder / "side.ngc"), 2)
    assert str(err.value).startswith(f"{folder / 'side.ngc'}:2: error: following error")


def test_gantry_plan_names_the_file_of_its_largest_blend(folder, capsys):
    """A G64 corner in a subroutine file: the plan's largest blend is that file's line 2."""
    from gantry_sim.sim.cli import main

    (folder / "corner.ngc").write_text("o<corner> sub\nG1 X10 F3000\nG1 Y10\no<corner> endsub\n")
    (folder / "c.ngc").write_text("G21 G90 G64 P0.05\nG1 X0 Y0 F3000\no<corner> call\nM2\n")
    assert main(["plan", str(folder / "c.ngc")]) == 0
    blends = json.loads(capsys.readouterr().out)["blends"]
    assert (blends["max_deviation_line"], blends["max_deviation_file"]) == (
        2,
        str(folder / "corner.ngc"),
    )
    assert 0.0 < blends["max_deviation_mm"] <= 0.05
