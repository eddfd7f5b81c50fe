"""The example scripts in scripts/ run headless as a user runs them, with small arguments."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CIRCLE = "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n"


def script(name: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / name), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_run_and_gate_passes_and_fails_on_the_gate(write_program, tmp_path):
    prog = write_program(CIRCLE)
    ok = script(
        "run_and_gate.py", str(prog), "--max-error-um", "1000", "--out", str(tmp_path / "o")
    )
    assert ok.returncode == 0, ok.stderr
    assert "contour error max" in ok.stdout
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    gate = report["contour_error_um"]["max"] / 2
    fail = script("run_and_gate.py", str(prog), "--max-error-um", f"{gate}")
    assert fail.returncode == 1 and "FAIL" in fail.stdout


def test_run_and_gate_reports_a_bad_program(write_program):
    bad = script("run_and_gate.py", str(write_program("G21\nG3 X1 F100\nM2\n")))
    assert bad.returncode == 2 and ":2: error:" in bad.stderr


def test_ballbar_script(tmp_path):
    res = script("ballbar.py", "--radius", "5", "--feed", "3000", "--out", str(tmp_path))
    assert res.returncode == 0, res.stderr
    assert "CCW" in res.stdout and "CW" in res.stdout and "G(b)" in res.stdout
    assert json.loads((tmp_path / "ballbar.json").read_text())["radius_mm"] == 5.0


def test_feed_sweep_script(write_program, tmp_path):
    prog = write_program(CIRCLE)
    res = script(
        "feed_sweep.py",
        str(prog),
        "--feed-override",
        "50,100",
        "--workers",
        "1",
        "--out",
        str(tmp_path),
    )
    assert res.returncode == 0, res.stderr
    with open(tmp_path / "sweep.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["feed_override_pct"] for r in rows] == ["50.0", "100.0"]
    assert float(rows[0]["cycle_time_s"]) > float(rows[1]["cycle_time_s"])


def test_tune_script():
    res = script("tune.py", "--radii", "5", "--tolerance-um", "20")
    assert res.returncode == 0, res.stderr
    assert "radius mm" in res.stdout and "machine_limits" in res.stdout
