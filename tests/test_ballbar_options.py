"""`gantry ballbar` options of issue 14: --centre, the --max-g-um gate, summary or JSON on stdout."""

from __future__ import annotations

import io
import json
import sys

import numpy as np
import pytest

from gantry_sim.sim.cli import main

SHORT = ["ballbar", "--radius", "5", "--feed", "3000"]


@pytest.mark.parametrize(
    "plane,centre,expected",
    [
        ("XY", "-20,-10", (-20.0, -10.0, 0.0)),
        ("XZ", "15,5", (15.0, 0.0, 5.0)),
        ("YZ", "1,2,3", (1.0, 2.0, 3.0)),
    ],
)
def test_centre_places_the_circle(tmp_path, capsys, plane, centre, expected):
    out = tmp_path / "bb"
    argv = [*SHORT, "--plane", plane, f"--centre={centre}", "--out", str(out)]
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["centre_mm"] == list(expected)
    assert printed["conditions"]["centre_mm"] == list(expected)
    i1, i2 = ("XYZ".index(plane[0]), "XYZ".index(plane[1]))
    pos = np.load(out / "trace_ccw.npz")["pos"]
    r = np.hypot(pos[:, i1] - expected[i1], pos[:, i2] - expected[i2])
    assert np.all(np.abs(r - 5.0) < 0.05)
    assert (
        f"centre X{expected[0]:g} Y{expected[1]:g} Z{expected[2]:g}"
        in (out / "ballbar.ngc").read_text()
    )
    # The analysis is about the given centre: no centre offset, G as at the origin.
    for d in ("ccw", "cw"):
        assert max(abs(v) for v in printed[d]["centre_offset_um"]) < 0.5


@pytest.mark.parametrize(
    "centre,where",
    [
        ("1", "--centre: error:"),
        ("a,b", "--centre: error:"),
        ("1,nan", "--centre: error:"),
        ("298,0", "error:"),
    ],
)
def test_bad_centre_is_status_2(capsys, centre, where):
    assert main([*SHORT, "--centre", centre]) == 2
    err = capsys.readouterr().err
    assert where in err and "Traceback" not in err


@pytest.mark.parametrize(
    "options,blamed,fragment",
    [
        # hostile-input review: a centre of 1e300 made an overlong line, blamed on --radius
        (["--centre=1e300,0"], "--centre", "within +-1e+09 mm"),
        (["--centre=0,0,-1e300"], "--centre", "within +-1e+09 mm"),
        (["--centre=1000,0"], "--centre", "outside the machine's travel"),  # the centre itself
        (["--radius=1e300"], "--radius", "at most 1e+09 mm"),
        (["--radius=290"], "--radius", "outside the machine's travel"),  # centre in, circle out
    ],
)
def test_the_option_at_fault_is_blamed(capsys, options, blamed, fragment):
    assert main([*SHORT, *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{blamed}: error: ") and fragment in err, err
    assert "--work-offset" not in err  # no option of gantry ballbar


def test_g_gate_fails_with_status_1_and_still_writes_the_report(tmp_path, capsys):
    out = tmp_path / "bb"
    assert main([*SHORT, "--max-g-um", "1", "--out", str(out)]) == 1
    cap = capsys.readouterr()
    printed = json.loads(cap.out)
    assert "gate failed: CCW circular deviation G" in cap.err
    gate = printed["gate"]
    assert gate["max_g_um"] == 1.0 and gate["passed"] is False and len(gate["reasons"]) == 2
    assert json.loads((out / "ballbar.json").read_text()) == printed
    assert (out / "polar.png").exists()


def test_g_gate_passes_when_g_is_within_the_limit(capsys):
    assert main([*SHORT, "--max-g-um", "50"]) == 0
    gate = json.loads(capsys.readouterr().out)["gate"]
    assert gate == {"max_g_um": 50.0, "passed": True, "reasons": []}


def test_bad_gate_is_status_2(capsys):
    assert main([*SHORT, "--max-g-um", "-1"]) == 2
    assert "--max-g-um: error:" in capsys.readouterr().err


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_stdout_is_json_when_piped_and_the_summary_on_a_terminal(monkeypatch, capsys):
    """A pipe (CI, `| jq`) keeps getting the JSON object; a terminal gets the summary; --json and
    --summary choose either way."""
    assert main(SHORT) == 0  # captured: not a terminal
    assert json.loads(capsys.readouterr().out)["radius_mm"] == 5.0
    assert main([*SHORT, "--summary"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("ballbar XY  R 5 mm  F 3000 mm/min") and "servo mismatch" in text
    terminal = Terminal()
    monkeypatch.setattr(sys, "stdout", terminal)
    assert main(SHORT) == 0
    assert "backlash" in terminal.getvalue() and not terminal.getvalue().startswith("{")
    terminal = Terminal()
    monkeypatch.setattr(sys, "stdout", terminal)
    assert main([*SHORT, "--json"]) == 0
    assert json.loads(terminal.getvalue())["feed_mm_per_min"] == 3000.0


def test_json_and_summary_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as exc:
        main([*SHORT, "--json", "--summary"])
    assert exc.value.code == 2


@pytest.mark.parametrize("feed", ["1e-9", "0.0004"])
def test_a_feed_below_the_programs_resolution_is_blamed_on_feed(capsys, feed):
    """The program writes F to 6 decimals: --feed 1e-9 was written F0 and refused as "zero
    feed rate" on --radius; now --feed says the least feed it takes."""
    assert main(["ballbar", "--radius", "5", "--feed", feed]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--feed: error: ") and ">= 0.001 mm/min" in err, err
