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
    assert set(data.files) == {"t", "pos", "vel", "acc", "line", "feed_mm_per_min"}
    n = data["t"].size
    assert data["pos"].shape == data["vel"].shape == data["acc"].shape == (n, 3)
    assert np.allclose(np.diff(data["t"]), machine.servo.period_s)
    assert data["t"][-1] >= summary["duration_s"] > data["t"][-2]
    assert np.array_equal(data["pos"][-1], [0.0, 30.0, 0.0]) and not data["vel"][-1].any()
    assert list(np.unique(data["line"])) == [2, 3, 4, 5, 6]
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_the_npz_gives_each_sample_the_feed_that_bounds_its_speed(write_program, tmp_path):
    # a rapid, feeds of 300/3000/1200/6000 mm/min blended at their corners, a dwell, and a
    # canned cycle whose rapids and feeds share its lines: the speed never passes the feed
    # given, and rapids have none (a checker reading only "line" would take a G81's rapid for
    # its feed move)
    text = (
        "G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z5\nG1 Z-1 F300\nG1 X20 F3000\nG1 X40 Y3 F1200\n"
        "G4 P0.2\nG1 X0 F6000\nG1 X0 F100\nG1 X-10 F6000\nG0 Z5\n"
        "G81 X10 Y10 Z-2 R1 F200\nX15\nG80\nM2\n"
    )
    out = tmp_path / "traj.npz"
    assert main(["plan", str(write_program(text)), "--out", str(out)]) == 0
    data = np.load(out)
    feed, speed = data["feed_mm_per_min"], np.linalg.norm(data["vel"], axis=1)
    fed = np.isfinite(feed)
    # a move of no length (line 8: where a printer retracts) bounds nothing around it
    assert set(np.unique(feed[fed])) == {200.0, 300.0, 1200.0, 3000.0, 6000.0}
    assert (speed[fed] <= feed[fed] / 60.0 * (1 + 1e-12)).all()
    assert speed[~fed].max() > 6000.0 / 60.0  # the rapids: faster than any feed
    g81 = data["line"] == 11
    assert np.isfinite(feed[g81]).any() and not np.isfinite(feed[g81]).all()
    corner = (data["line"] == 4) & (feed == 1200.0)  # the blend into the slower move
    assert corner.any() and (data["line"] == 4).sum() > corner.sum()


def test_a_program_without_moves_has_every_array_too(write_program, tmp_path):
    # nothing moves (a program of parameters only): the file has the arrays of any plan (a
    # checker reading feed_mm_per_min found none)
    out = tmp_path / "traj.npz"
    assert main(["plan", str(write_program("G21 G90\n#1 = 5\nM2\n")), "--out", str(out)]) == 0
    data = np.load(out)
    assert data.files == ["t", "pos", "vel", "acc", "line", "feed_mm_per_min"]
    assert data["t"].tolist() == [0.0] and np.isnan(data["feed_mm_per_min"]).all()


def test_the_npz_is_written_range_by_range_with_the_same_arrays(
    write_program, tmp_path, machine, monkeypatch
):
    """sim.plan_samples: ranges of a few samples (the last one short) give the arrays of the
    whole plan sampled at once, in numpy.savez's order and dtypes."""
    import importlib

    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner import plan

    samples = importlib.import_module("gantry_sim.sim.plan_samples")
    monkeypatch.setattr(samples, "RANGE_SAMPLES", 397)
    out = tmp_path / "traj.npz"
    assert main(["plan", str(write_program(PROGRAM)), "--out", str(out)]) == 0
    p = plan(list(interpret_events(PROGRAM)), machine)
    whole = p.sample(machine.servo.period_s)
    want = whole.to_npz_dict() | {"feed_mm_per_min": p.feeds_mm_per_min(whole.source)}
    assert whole.t.size > 3 * 397 and whole.t.size % 397
    data = np.load(out)
    assert data.files == list(want)
    for name, a in want.items():
        assert data[name].dtype == a.dtype and np.array_equal(data[name], a, equal_nan=True)
    assert not list(tmp_path.glob(".*"))


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


def test_plan_progress_goes_to_stderr_only_when_asked(write_program, capsys, monkeypatch):
    from gantry_sim.sim import progress

    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.0)  # the stages here are short
    program = str(write_program(PROGRAM))
    assert main(["plan", program, "--progress"]) == 0
    got = capsys.readouterr()
    assert json.loads(got.out)["moves"] == 5  # stdout is still the one JSON object
    assert "parse: " in got.err and "plan: " in got.err and "/5 [" in got.err  # 5 moves
    assert main(["plan", program]) == 0  # stderr is no terminal here: quiet
    assert capsys.readouterr().err == ""


def test_plans_bound_says_what_plan_writes_and_does(tmp_path, capsys):
    """`gantry plan --out` past --max-sim-s says what it holds back: the reference it writes
    (20-40 kB per simulated second) and planning it anyway, not the run's trace and
    simulation (the words `gantry run` uses)."""
    from gantry_sim.sim.cli import main

    prog = tmp_path / "p.ngc"
    prog.write_text("G21 G90\nG1 X100 F0.5\nM2\n")  # 12,000 s
    assert main(["plan", str(prog), "--out", str(tmp_path / "t.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{prog}:2: error: the program takes at least 12000 s"), err
    assert "20-40 kB per simulated second" in err and "to plan it anyway" in err, err
    assert "simulate it" not in err and "trace" not in err, err
    assert not (tmp_path / "t.npz").exists()
