"""``gantry plan``: the JSON summary and the npz of CONTRACTS.md, and its error paths."""

from __future__ import annotations

import json

import numpy as np

from gantry_sim.sim.cli import main

PROGRAM = """G21 G90 G17
G0 X10 Y0
G1 X10 Y-10 F3000
G3 X10 Y10 I0 J10
G2 X10 Y30 I0 J10 F6000
G1 X0 Y30
M2
"""


def test_plan_prints_the_contract_and_writes_the_trajectory(
    write_program, tmp_path, capsys, machine
):
    out = tmp_path / "traj.npz"
    assert main(["plan", str(write_program(PROGRAM)), "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary) >= {
        "duration_s",
        "moves",
        "segments",
        "chord_tolerance_mm",
        "servo_period_s",
        "limits",
    }
    assert summary["moves"] == 5 and summary["segments"] > 100
    assert summary["chord_tolerance_mm"] == machine.segmentation.chord_tolerance_mm
    assert summary["servo_period_s"] == machine.servo.period_s
    assert summary["limits"] == machine.limits.to_json()
    data = np.load(out)
    assert set(data.files) == {"t", "pos", "vel", "acc", "line"}
    n = data["t"].size
    assert data["pos"].shape == data["vel"].shape == data["acc"].shape == (n, 3)
    assert np.allclose(np.diff(data["t"]), machine.servo.period_s)
    assert data["t"][-1] >= summary["duration_s"] > data["t"][-2]
    assert np.array_equal(data["pos"][-1], [0.0, 30.0, 0.0]) and not data["vel"][-1].any()
    assert list(np.unique(data["line"])) == [2, 3, 4, 5, 6]
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_program_outside_travel_exits_2_with_line(write_program, tmp_path, capsys):
    path = write_program("G0 X0\nG1 Y250 F100\nM2\n")
    out = tmp_path / "t.npz"
    assert main(["plan", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{path}:2: error: ") and "Y" in err and "-200..200" in err
    assert "Traceback" not in err and not out.exists()


def test_bad_machine_file_and_program_errors_exit_2(write_program, tmp_path, capsys):
    prog = write_program("G1 X1 F100\nM2\n")
    machine = tmp_path / "m.toml"
    machine.write_text("[limits]\nmax_jerk_mm_per_s3 = [1, -2, 3]\n")
    assert main(["plan", str(prog), "--machine", str(machine)]) == 2
    assert "max_jerk_mm_per_s3" in capsys.readouterr().err
    assert main(["plan", str(tmp_path / "missing.ngc")]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["plan", str(prog), "--out", str(tmp_path / "no" / "dir" / "t.npz")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_a_marlin_limit_out_of_range_names_the_program_line(write_program, capsys):
    # the M204 value made the machine file's [limits] invalid, and the error named the machine
    # file (found by a hostile-input sweep); it is the program's line
    for text, code in (("M204 S-100", "M204"), ("M203 X0", "M203")):
        path = write_program(f"G21 G90\n{text}\nG1 X10 F1000\n", "p.gcode")
        assert main(["plan", "--dialect", "marlin", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{path}:2: error: {code} on this line would set"), err
        assert "gantry.toml" not in err and err.count("\n") == 1
