"""The exit-status contract under hostile input (issue 15, defects 4, 6, 7, 13, 15 and the
internal-error status): 3 and one line for a bug, a clean exit 2 that says what is allowed
for numbers out of physical range, costs refused before they are paid, MuJoCo's instability
warnings checked, and messages that name what the user typed."""

from __future__ import annotations

import dataclasses
import math
import re
import time

import pytest
from fault_helpers import TRACEBACK

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError, SimulationError
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML
from gantry_sim.sim import cli
from gantry_sim.sim.circular.tune import max_feed_for_radius
from gantry_sim.sim.cli import main

LINE = "G21 G90\nG1 X2 F1200\nM2\n"


@pytest.fixture
def no_planning(monkeypatch):
    """The planner fails the test if it is called (a program must be refused before)."""
    import importlib

    planner = importlib.import_module("gantry_sim.controller.planner.plan")

    def never(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("planned")

    monkeypatch.setattr(planner, "plan", never)


@pytest.fixture
def prog(tmp_path):
    path = tmp_path / "p.ngc"
    path.write_text(LINE)
    return path


def _bug(args):
    raise ZeroDivisionError("float division by zero")


# --- exit 3: internal errors ---------------------------------------------------------------------


def test_an_internal_error_exits_3_with_one_line(monkeypatch, capsys, prog):
    monkeypatch.setattr("gantry_sim.sim.commands.parse.run", _bug)
    monkeypatch.delenv(cli.DEBUG_ENV, raising=False)
    assert main(["parse", str(prog)]) == 3
    err = capsys.readouterr().err
    assert TRACEBACK not in err and len(err.strip().splitlines()) == 1
    assert err.startswith("gantry: internal error (ZeroDivisionError: float division by zero")
    assert "please report" in err and "--debug" in err


@pytest.mark.parametrize("how", ["option before", "option after", "environment"])
def test_the_traceback_only_on_request(monkeypatch, capsys, prog, how):
    monkeypatch.setattr("gantry_sim.sim.commands.parse.run", _bug)
    argv = ["parse", str(prog)]
    if how == "option before":
        argv = ["--debug", *argv]
    elif how == "option after":
        argv = [*argv, "--debug"]
    else:
        monkeypatch.setenv(cli.DEBUG_ENV, "1")
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert TRACEBACK in err and "ZeroDivisionError" in err
    assert err.strip().splitlines()[-1].startswith("gantry: internal error")


def test_a_bug_in_a_real_process_exits_3_not_1(tmp_path, prog):
    """As a process, with a bug injected: the status a CI job sees (1 is "a gate failed")."""
    import subprocess
    import sys

    inject = (
        "import sys, gantry_sim.sim.commands.parse as p\n"
        "p.run = lambda args: {}['missing']\n"
        "from gantry_sim.sim.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    r = subprocess.run(
        [sys.executable, "-c", inject, "parse", str(prog)],
        capture_output=True, text=True, timeout=60, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 3 and TRACEBACK not in r.stderr
    assert r.stderr.startswith("gantry: internal error (KeyError: 'missing' at ")
    assert len(r.stderr.splitlines()) == 1


# --- defect 6: machine-file numbers -------------------------------------------------------------

HUGE_INT = "1" + "0" * 400


@pytest.mark.parametrize(
    ("text", "allowed"),
    [
        (f"[servo]\nperiod_s = {HUGE_INT}\n", "within 1e-05..0.1 s"),
        (f"[limits]\nmax_velocity_mm_per_s = [{HUGE_INT}, 1, 1]\n", "within 0.01..100000 mm/s"),
        (f"[servo]\nff_gravity = {HUGE_INT}\n", "within 0..2"),
        (f"[travel]\nmax_mm = [{HUGE_INT}, 1, 1]\n", "within -100000..100000 mm"),
        ("[servo]\nperiod_s = 1e308\n", "within 1e-05..0.1 s"),
        ("[limits]\nmax_acceleration_mm_per_s2 = [1e-20, 1e-20, 1e-20]\n", "1..1e+06 mm/s^2"),
        ("[limits]\nmax_jerk_mm_per_s3 = [1e-300, 1, 1]\n", "1..1e+09 mm/s^3"),
        ("[sim]\nphysics_timestep_s = 1e-300\n", "within 1e-06..0.01 s"),
        ("[sim]\nphysics_timestep_s = 1e-9\n", "within 1e-06..0.01 s"),
        ("[servo]\nmax_following_error_mm = 1e300\n", "within 0.0001..1000 mm"),
    ],
)
def test_out_of_range_machine_numbers_say_the_range(tmp_path, capsys, prog, text, allowed):
    mf = tmp_path / "m.toml"
    mf.write_text(text)
    for cmd in (["plan", str(prog)], ["run", str(prog), "--out", str(tmp_path / "o")]):
        assert main([*cmd, "--machine", str(mf)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{mf}: error: [") and allowed in err, err
        assert len(err) < 400  # a 400-digit value is not echoed whole


def test_sweep_max_accel_out_of_range_names_the_option(capsys, prog):
    assert main(["sweep", str(prog), "--max-accel", "1e-20"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--max-accel: error: ") and "1..1e+06 mm/s^2" in err
    assert main(["sweep", str(prog), "--max-jerk", "1e30"]) == 2
    assert capsys.readouterr().err.startswith("--max-jerk: error: ")


# --- defect 7: bounds on cost --------------------------------------------------------------------


def test_a_program_of_600000_simulated_seconds_is_refused_at_once(tmp_path, capsys):
    slow = tmp_path / "slow.ngc"
    slow.write_text("G1 X1 F0.0001\nM2\n")
    for cmd in (
        ["run", str(slow), "--out", str(tmp_path / "o")],
        ["plan", str(slow), "--out", str(tmp_path / "t.npz")],
        ["sweep", str(slow), "--workers", "1", "--out", str(tmp_path / "s")],
    ):
        t0 = time.monotonic()
        status = main(cmd)
        assert time.monotonic() - t0 < 30
        cap = capsys.readouterr()
        if cmd[0] == "sweep":  # per grid point: a row, not a crash; no point ran: exit 1
            assert status == 1 and "over the budget" in cap.out
            continue
        assert status == 2  # refused before planning: its moves at their feeds take 600000 s
        assert cap.err.startswith(f"{slow}:1: error: the program takes at least 600000 s of")
        assert "--max-sim-s above 600000" in cap.err


def test_far_beyond_the_bound_is_refused_before_planning(tmp_path, capsys, no_planning):
    """A canned cycle of 5,100 pecks at F10 (15,300 moves, 2.6 hours; Q0.0001 at a high feed
    makes a million moves, minutes and gigabytes to plan) is refused from its moves alone; the
    planner is never called."""
    pecks = tmp_path / "pecks.ngc"
    pecks.write_text("G0 Z5\nG83 X1 Y1 Z-50 R1 Q0.01 F10\nM2\n")
    assert main(["run", str(pecks), "--out", str(tmp_path / "o"), "--no-plots"]) == 2
    err = capsys.readouterr().err
    found = re.match(
        rf"{re.escape(str(pecks))}:2: error: the program takes at least ([\d.]+) s", err
    )
    assert found and float(found.group(1)) > 7200
    assert "(this line alone takes at least" in err and TRACEBACK not in err


@pytest.mark.parametrize(
    ("text", "dialect"),
    [
        (
            "G21 G90\nG0 X50 Y20 Z-5\nG1 X10 F3000\nG2 X0 Y10 I-10 J0 F1200\nG4 P0.5\nG1 Y-30\nM2\n",
            "linuxcnc",
        ),
        (
            "G21 G90 G64 P0.01\nG1 X1 Y0.2 F6000\nG1 X2 Y0\nG1 X3 Y0.2\nG3 X5 Y0.2 I1 J0\nM2\n",
            "linuxcnc",
        ),
        # Marlin's M203 raises X past the machine file's 500 mm/s: the plan takes 1.15 s
        ("G21\nM203 X1000 Y1000 Z1000\nM201 X100000 Y100000\nG1 X250 F60000\nG1 X-250\n", "marlin"),
        # reversals: every one a rest (rest-to-rest runs bound each move), rapids too
        (
            "G21 G90 G64 P0.01\nG1 X1 F100000\nG1 X0\nG1 X1 Y0.001\nG0 X0 Y0\nG0 X0.5\nM2\n",
            "linuxcnc",
        ),
        # G64 Q may fold the 0.5 mm step back into the line: no rest there
        ("G21 G90 G64 P0.01 Q1\nG1 X2 F6000\nG1 X1.5\nG1 X3\nG1 X2.5 Y0.0001\nM2\n", "linuxcnc"),
        ("G21 G90\nG0 X1\nG4 P0.2\nG0 X0\nG1 X0.001 F600\nG1 X0\n", "grbl"),
        # G64 blends cut 120-degree corners of 0.1 mm steps: the path is a fifth shorter than
        # the program's (the speeds-only bound was 1.23 x the plan of LinuxCNC's flowsnake.ngc)
        (
            "G21 G90 G64 P0.01\n"
            + "".join(f"G1 X{0.05 * i:.3f} Y{0.0866 * (i % 2):.4f} F60\n" for i in range(1, 41))
            + "M2\n",
            "linuxcnc",
        ),
        # arcs capped by their curvature (|a| >= v^2 k): small circles, helices in G18 and
        # a steep one, an arc between lines in G19
        (
            "G21 G90 G17 F3000\nG0 X0.05 Y0\n" + "G2 X0.05 Y0 I-0.05 J0 P3\n" * 3 + "M2\n",
            "linuxcnc",
        ),
        ("G21 G90 G18 F6000\nG0 X1 Z0\nG2 X1 Z0 I-1 K0 Y-2 P4\nM2\n", "linuxcnc"),
        ("G21 G90 G17 F6000\nG0 X0.2 Y0\nG3 X0.2 Y0 I-0.2 J0 Z-20 P2\nM2\n", "linuxcnc"),
        ("G21 G90 G19 G64 P0.01 F4000\nG0 Y0 Z0\nG1 Y5\nG2 Y7 Z2 J0 K2\nG1 Z6\nM2\n", "linuxcnc"),
        # the same with Q: naive-CAM runs count for nothing
        (
            "G21 G90 G64 P0.01 Q0.01\n"
            + "".join(f"G1 X{0.05 * i:.3f} Y{0.0866 * (i % 2):.4f} F60\n" for i in range(1, 41))
            + "G1 X0 Y0\nG1 X3\nG1 X2.995\nG1 X4\nM2\n",
            "linuxcnc",
        ),
    ],
)
def test_the_bound_from_the_moves_is_below_the_planned_duration(text, dialect, machine):  # type: ignore[no-untyped-def]
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.budget import duration_lower_bound

    items = list(interpret_events(text, dialect))
    bound, _, _ = duration_lower_bound(items, machine)
    assert 0.0 < bound <= plan(items, machine).duration_s


def test_reversals_bound_each_move_by_a_rest_to_rest_run(machine):
    """Back and forth: each move starts and ends at rest, so it takes at least the fastest
    rest-to-rest run of its length (0.0285 s for 1 mm at the bundled machine's acceleration
    norm), far above its time at the feed (0.002 s at 500 mm/s)."""
    import math

    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.sim.duration_bound import duration_lower_bound, rest_to_rest_s

    text = "G21 G90\n" + "G1 X1 F100000\nG1 X0\n" * 50 + "M2\n"
    bound, _, _ = duration_lower_bound(list(interpret_events(text)), machine)
    acc = math.hypot(*machine.limits.max_acceleration_mm_per_s2)
    assert bound == pytest.approx(100 * 2 * math.sqrt(1.0 / acc))
    assert bound == pytest.approx(100 * rest_to_rest_s(1.0, 1e9, acc))
    # the same moves turning by 90 degrees are not rests (in G61, with no blend to shorten
    # them): their length runs as one stretch
    square = "G21 G90 G61\n" + "G1 X1 F100000\nG1 Y1\nG1 X0\nG1 Y0\n" * 25 + "M2\n"
    bound, _, _ = duration_lower_bound(list(interpret_events(square)), machine)
    speed = math.hypot(*machine.limits.max_velocity_mm_per_s)
    assert bound == pytest.approx(rest_to_rest_s(100.0, speed, acc))


def test_small_circles_are_refused_before_planning(tmp_path, capsys, no_planning):  # type: ignore[no-untyped-def]
    """10,000 circles of R 0.05 mm, 100 turns each: 15.8 million chords and 53,901 s of
    motion, which at F3000 looked like 1,000 s. Planned for 194 s at 11 GB before the run
    refused them; their curvature bounds them at 19,948 s before planning."""
    prog = tmp_path / "tiny.ngc"
    prog.write_text(
        "G21 G90 G17 F3000\nG0 X0.05 Y0\n" + "G2 X0.05 Y0 I-0.05 J0 P100\n" * 10000 + "M2\n"
    )
    out = tmp_path / "o"
    assert main(["run", str(prog), "--out", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "takes at least 19948" in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("mode", "line"),
    [
        ("", 2),
        # the same loop in G64 P0.1 (Q0.1 with it, as in LinuxCNC): no naive-CAM run can take a
        # move that turns back (its end would lie a millimetre off the run's chord), so every
        # reversal is still a rest. The bound once counted any run of straight moves at one
        # feed as its chord -- near 0 here -- and 600,000 such moves were refused only after
        # an 84 s plan.
        ("G64 P0.1\n", 3),
    ],
)
def test_a_back_and_forth_loop_is_refused_before_planning(
    tmp_path, capsys, no_planning, mode, line
):  # type: ignore[no-untyped-def]
    """10,000 one-millimetre moves back and forth at F100000 take 20 s at their feeds but at
    least 285 s from rest to rest: refused with --max-sim-s 100 before planning."""
    loop = tmp_path / "loop.ngc"
    loop.write_text(mode + "o1 repeat [5000]\nG1 X1 F100000\nG1 X0\no1 endrepeat\nM2\n")
    out = tmp_path / "o"
    assert main(["run", str(loop), "--out", str(out), "--max-sim-s", "100", "--no-plots"]) == 2
    err = capsys.readouterr().err
    found = re.match(
        rf"{re.escape(str(loop))}:{line}: error: the program takes at least ([\d.]+) s", err
    )
    assert found and float(found.group(1)) > 280 and TRACEBACK not in err


def _folded_polyline(seed: int) -> str:
    """A G64 P Q polyline of short steps that fold back along their line now and then
    (what the naive-CAM merge may remove), with turns, a program stop and a dwell."""
    import random

    rng = random.Random(seed)
    x = y = 0.0
    lines = [f"G21 G90 G64 P0.02 Q{rng.choice((0.005, 0.02, 0.1))}", "G1 X0 Y0 F3000"]
    heading = 0.0
    for k in range(60):
        step = rng.uniform(0.05, 1.0)
        if rng.random() < 0.2:
            step = -rng.uniform(0.0, 0.15)  # back along the line, within or beyond Q
        elif rng.random() < 0.3:
            heading += rng.uniform(-1.0, 1.0)
        x += step * math.cos(heading)
        y += step * math.sin(heading)
        lines.append(f"G1 X{x:.4f} Y{y:.4f}")
        if k == 20:
            lines.append("M0")
        if k == 40:
            lines.append("G4 P0.1")
    return "\n".join([*lines, "M2", ""])


@pytest.mark.parametrize("seed", range(6))
def test_the_bound_of_folded_g64_q_polylines_is_below_the_plan(seed, machine):  # type: ignore[no-untyped-def]
    """The bound follows the planner's naive-CAM runs: never above the planned duration, and
    within a factor of it (each run counts as the line the planner makes of it)."""
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.budget import duration_lower_bound

    items = list(interpret_events(_folded_polyline(seed)))
    bound, _, _ = duration_lower_bound(items, machine)
    planned = plan(items, machine).duration_s
    assert 0.3 * planned < bound <= planned


def test_the_bounds_can_be_raised_explicitly(tmp_path, capsys, prog):
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--max-sim-s", "0.05"]) == 2
    # its moves alone take 0.1 s at their feeds: refused before planning
    assert re.search(r"--max-sim-s (above )?1 to", capsys.readouterr().err)
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--max-sim-s", "1"]) == 0
    mf = tmp_path / "m.toml"
    mf.write_text("[sim]\nphysics_timestep_s = 1e-6\n")
    assert main(["run", str(prog), "--machine", str(mf), "--max-physics-steps", "1e5"]) == 2
    err = capsys.readouterr().err
    assert "MuJoCo physics steps" in err and re.search(r"--max-physics-steps \d+ to", err)
    assert main(["run", str(prog), "--max-sim-s", "nan"]) == 2
    assert capsys.readouterr().err.startswith("--max-sim-s: error:")


def test_servo_ticks_are_bounded_too(tmp_path, capsys):
    mf = tmp_path / "m.toml"
    mf.write_text("[servo]\nperiod_s = 1e-5\n[sim]\nphysics_timestep_s = 1e-5\n")
    long = tmp_path / "long.ngc"
    long.write_text("G1 X300 F60\nM2\n")  # 300 s at 100 kHz: 3e7 ticks, about 18 GB
    assert main(["run", str(long), "--machine", str(mf), "--out", str(tmp_path / "o")]) == 2
    assert "servo ticks" in capsys.readouterr().err


def test_tune_feed_resolution_1e_300_is_refused_and_the_search_is_bounded(capsys):
    assert main(["tune", "--radii", "5", "--feed-resolution", "1e-300"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--feed-resolution: error: 1e-300 mm/min: must be a finite number >=")
    # the search itself ends whatever the resolution (it used to loop for ever)
    row = max_feed_for_radius(
        5.0, 5.0, lambda f: (5.0 * (f / 1234.5) ** 2, f), 24000.0, resolution_mm_per_min=1e-300
    )
    assert row.limited_by == "tolerance" and len(row.tried) < 140
    assert abs(row.max_feed_mm_per_min - 1234.5) < 1e-6


# --- defect 13: MuJoCo's warnings ---------------------------------------------------------------


def test_mujoco_bad_ctrl_warning_is_a_simulation_error(tmp_path, monkeypatch, capfd):
    """An unstable loop with a following-error limit too large to trip: MuJoCo warns of a huge
    control (and zeroes it); the run used to end with exit 0 and a report."""
    from gantry_sim.sim.api import run_program

    monkeypatch.chdir(tmp_path)  # MuJoCo logs its warnings to ./MUJOCO_LOG.TXT

    xml = tmp_path / "variant.xml"
    xml.write_text(
        re.sub(r'(ctrlrange|forcerange)="[^"]*"', r'\1="-1e12 1e12"', GANTRY_XML.read_text())
    )
    mf = tmp_path / "m.toml"
    mf.write_text(f'[sim]\nmodel = "{xml.name}"\n[servo]\nkp_N_per_mm = [1e7, 1e7, 1e7]\n')
    m = load_machine_config(DEFAULT_MACHINE, mf)
    # beyond the machine file's range on purpose (the Python API takes any MachineConfig)
    m = dataclasses.replace(m, servo=dataclasses.replace(m.servo, max_following_error_mm=1e300))
    with pytest.raises(SimulationError, match="mjWARN_BADCTRL") as info:
        run_program(LINE, file="p.ngc", machine=m)
    assert str(mf) in info.value.message  # the machine file, not the program, is to blame
    assert "huge value in CTRL" in info.value.message  # MuJoCo's own words, in the error
    # ... and nowhere else: not on stdout, not in a MUJOCO_LOG.TXT left in the working folder
    assert "WARNING" not in capfd.readouterr().out
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


# --- defect 15: messages a user can act on -------------------------------------------------------


def test_ballbar_errors_name_the_option_not_a_generated_program(capsys):
    assert main(["ballbar", "--radius", "1000"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--radius: error: the ballbar circle (R 1000 mm")
    assert "travel" in err and "ballbar.ngc" not in err
    assert main(["ballbar", "--feed", "0.5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--feed: error: ") and "ballbar.ngc" not in err and ":10:" not in err


def test_tune_errors_name_radii_not_radius(capsys):
    for radius in ("1000", "0.0001"):
        assert main(["tune", "--radii", radius]) == 2
        err = capsys.readouterr().err
        assert err.startswith("--radii: error: ") and "tune_r" not in err, err
    assert main(["tune", "--radii", "5,nan"]) == 2
    assert capsys.readouterr().err.startswith("--radii: error: ")


def test_following_error_points_at_the_machine_file(tmp_path, capsys, prog):
    mf = tmp_path / "weak.toml"
    mf.write_text(
        "[servo]\nkp_N_per_mm = [0.001, 0.001, 0.001]\nkd_N_s_per_mm = [0, 0, 0]\nmax_following_error_mm = 0.5\n"
        "ff_velocity = [0, 0, 0]\nff_acceleration = [0, 0, 0]\n"
    )
    assert main(["run", str(prog), "--machine", str(mf), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"{prog}:2: error:" in err and str(mf) in err


def test_invalid_options_are_exit_2_with_the_option_named(capsys, prog):
    for argv, option in (
        (["run", str(prog), "--max-error-um", "-1"], "--max-error-um"),
        (["sweep", str(prog), "--workers", "0"], "--workers"),
        (["tune", "--radii", ",".join(["5"] * 101)], "--radii"),
    ):
        assert main(argv) == 2
        assert capsys.readouterr().err.startswith(f"{option}: error: ")


def test_config_error_keeps_its_type(tmp_path):
    mf = tmp_path / "m.toml"
    mf.write_text("[servo]\nperiod_s = -1\n")
    with pytest.raises(ConfigError):
        load_machine_config(DEFAULT_MACHINE, mf)


def test_a_program_too_long_for_the_budget_is_refused_while_it_is_read(
    tmp_path, capsys, no_planning, monkeypatch
):  # type: ignore[no-untyped-def]
    """sim.budget.ParseBound checks the bound of what is read every EVERY items: a loop of
    20,000 slow moves is refused on its own line before the bad line after it is read (read
    whole, that line's G-code error came first, after the whole loop)."""
    from gantry_sim.sim import budget

    monkeypatch.setattr(budget.ParseBound, "EVERY", 64)
    prog = tmp_path / "slow.ngc"
    prog.write_text("G21 G90\no1 repeat [10000]\nG1 X1 F30\nG1 X0\no1 endrepeat\nG99999\nM2\n")
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--max-sim-s", "100"]) == 2
    err = capsys.readouterr().err
    found = re.match(
        rf"{re.escape(str(prog))}:3: error: the program takes at least ([\d.]+) s", err
    )
    assert found and 100 < float(found.group(1)) < 200, err  # 64 moves of 2 s: 128 s
    monkeypatch.setattr(budget.ParseBound, "EVERY", 10**9)  # checked whole: the G99999 first
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--max-sim-s", "100"]) == 2
    assert re.match(rf"{re.escape(str(prog))}:6: error: ", capsys.readouterr().err)


@pytest.mark.parametrize("dialect", ["linuxcnc", "marlin"])
def test_the_bound_taken_while_reading_is_the_whole_programs(dialect, machine):  # type: ignore[no-untyped-def]
    """ParseBound.check gives check_lower_bound's verdict and figures: the same bound from the
    items seen one by one (BoundWalk) as from the whole list; a Marlin limit change (M203 may
    raise the speed cap later) turns the running bound off, and the whole list is read
    again."""
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.sim.budget import Budget, BudgetError, ParseBound
    from gantry_sim.sim.duration_bound import BoundWalk, duration_lower_bound

    text = (
        "G21 G90 G64 P0.05\nG1 X5 F600\nG2 X10 I2.5\nG4 P0.5\nG1 Y5\nG1 X0\nG0 Z3\n"
        + ("M203 X900\n" if dialect == "marlin" else "")
        + "G1 X4 Y3 F60\nM2\n"
    )
    items = list(interpret_events(text, dialect))
    whole = duration_lower_bound(items, machine)
    walk = BoundWalk(machine, 100.0, list(machine.limits.max_velocity_mm_per_s), False)
    for item in items:
        walk.add(item)
    if dialect == "linuxcnc":
        assert walk.finish() == whole
    errors = []
    for limit in (whole[0] * 0.99, whole[0] * 1.01):
        bound = ParseBound(machine, Budget(max_sim_s=limit), "p")
        for k, item in enumerate(items):
            bound(item, items[: k + 1])
        assert bound.on == (dialect == "linuxcnc")
        try:
            bound.check(items)
            errors.append(None)
        except BudgetError as exc:
            errors.append(f"{whole[0]:.6g} s" in exc.message)
    assert errors == [True, None]


def test_a_program_refused_while_read_for_its_travel_says_it_was_read_in_part(
    tmp_path, capsys, no_planning, monkeypatch
):  # type: ignore[no-untyped-def]
    """The travel comes first (an option lifts the bound, none makes the program fit); the
    span a running check gives is the read part's, and the message says so."""
    from gantry_sim.sim import budget

    monkeypatch.setattr(budget.ParseBound, "EVERY", 64)
    prog = tmp_path / "far.ngc"
    # back and forth, 10 mm further each time: each reversal closes a stretch of the bound
    prog.write_text("G21 G91\no1 repeat [10000]\nG1 X20 F30\nG1 X-10\no1 endrepeat\nM2\n")
    assert main(["run", str(prog), "--out", str(tmp_path / "o"), "--max-sim-s", "100"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{prog}:3: error: ") and "outside the machine's travel" in err
    assert "in the part read before its duration bound stopped the reading" in err
    assert err.count("\n") == 1 and TRACEBACK not in err
