"""Numbers no machine can follow (a hostile-input sweep's finds): each is refused with exit 2 on
its line, in one line of stderr, by `gantry plan` and `gantry run` alike; they ended in internal
errors (exit 3) before, from overflow to infinity and NaN in the geometry or from Ruckig finding
no profile at all."""

from __future__ import annotations

import json
import re

import pytest

from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Spline
from gantry_sim.controller.planner.magnitudes import (
    MAX_COORDINATE_MM,
    MAX_TURNS,
    WEIGHT_RANGE,
    check_magnitudes,
)
from gantry_sim.sim.cli import main

HEAD = "G21 G90 G17\nG0 X0 Y0 Z0\nF600\n"
#: 1e300 and 1e-300 as LinuxCNC's language writes them (G-code numbers have no exponent, and
#: a literal of 301 digits would make a line longer than LinuxCNC reads)
BIG = "[10**300]"
TINY = "[1/10**300]"
#: a number beyond any machine that grbl reads (no expressions; lines of 79 characters)
GRBL_BIG = "1" + "0" * 15
#: 1e-300 written out, for Marlin (no expressions, no limit on a line here)
TINY_DIGITS = "0." + "0" * 299 + "1"

#: program -> (dialect, the line refused, a fragment of the message)
CASES = {
    "huge coordinate": (HEAD + f"G1 X{BIG}\nM2\n", "linuxcnc", 4, "reaches 1e+300 mm"),
    "huge arc radius": (
        HEAD + f"G2 X10 Y0 R{BIG}\nM2\n",
        "linuxcnc",
        4,
        "centre X is not a finite",
    ),
    "huge G91 arc": (
        HEAD + f"G91\nG2 X{GRBL_BIG} Y0 R{GRBL_BIG}\nM2\n",
        "grbl",
        5,
        "reaches 1e+15 mm",
    ),
    "huge NURBS weight": (
        HEAD + "G5.2 X0 Y1 P1 L3\nX2 Y2 P100000000000000000000\nX4 Y0 P1\nG5.3\nM2\n",
        "linuxcnc",
        7,
        "spline weight 1e+20",
    ),
    "huge helix turns": (HEAD + f"G2 X0 Y0 Z-2 I5 J0 P{BIG}\nM2\n", "linuxcnc", 4, "turns"),
    "tiny feed": (HEAD + f"F{TINY}\nG1 X5\nM2\n", "linuxcnc", 5, "raise the F"),
    # (rs274 runs a G93 move at 0.1 units/min at least: tests/data/rs274 g93_least_rate)
    "tiny inverse-time feed": (
        HEAD + f"G93\nG1 X5 F{TINY_DIGITS}\nM2\n",
        "g2core",
        5,
        "raise the F",
    ),
    "tiny Marlin path acceleration": (
        HEAD + f"M204 P{TINY_DIGITS}\nG1 X5\nM2\n",
        "marlin",
        4,
        "must be 0 (none) or within 1..1e+06",
    ),
}


@pytest.mark.parametrize("command", ["plan", "run"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_a_number_no_machine_follows_is_refused_on_its_line(
    name, command, write_program, tmp_path, capsys
):
    text, dialect, line, fragment = CASES[name]
    path = write_program(text)
    out = ["--out", str(tmp_path / "out"), "--no-plots"] if command == "run" else []
    status = main([command, "--dialect", dialect, str(path), *out])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and err.startswith(f"{path}:{line}: error: "), err
    if command == "run" and fragment == "raise the F":
        fragment = "of simulated time"  # the run's simulated-time bound refuses it first
        # the option to raise it is a number to type, not 303 digits
        assert re.search(r"--max-sim-s above [\d.e+]{1,16} to", err), err
    assert fragment in err


def test_the_interpreter_still_reads_what_rs274_reads():
    # `gantry parse` shows the program as rs274 makes it; the planner refuses the numbers
    (arc,) = [m for m in parse_program(HEAD + f"G2 X0 Y0 Z-2 I5 J0 P{BIG}\nM2\n") if m.line == 4]
    assert arc.turns > MAX_TURNS
    (far,) = [m for m in parse_program(HEAD + f"G1 X{BIG}\nM2\n") if m.line == 4]
    assert far.end[0] == 1e300


def test_the_bounds_themselves():
    (ok,) = [m for m in parse_program(HEAD + "G1 X1000000000\nM2\n") if m.line == 4]
    assert ok.end[0] == MAX_COORDINATE_MM and check_magnitudes(ok) is ok
    (beyond,) = [m for m in parse_program(HEAD + "G1 X1000000001\nM2\n") if m.line == 4]
    with pytest.raises(PlanningError, match="reaches 1e\\+09 mm"):
        check_magnitudes(beyond)
    # coordinates each within the bound whose magnitudes sum beyond it pass
    (wide,) = [
        m for m in parse_program(HEAD + "G0 X-600000000\nG1 X600000000\nM2\n") if m.line == 5
    ]
    assert check_magnitudes(wide) is wide
    lo, hi = WEIGHT_RANGE
    spline = HEAD + "G5.2 X0 Y1 P1 L3\nX2 Y2 P{w}\nX4 Y0 P1\nG5.3\nM2\n"
    for w, refused in ((lo, False), (hi, False), (lo / 2, True), (2 * hi, True)):
        program = spline.format(w=f"{w:.12f}".rstrip("0"))
        (s,) = [m for m in parse_program(program) if isinstance(m, Spline)]
        if refused:
            with pytest.raises(PlanningError, match="spline weight"):
                check_magnitudes(s)
        else:
            assert check_magnitudes(s) is s
    (helix,) = [m for m in parse_program(HEAD + f"G2 I5 Z-2 P{MAX_TURNS}\nM2\n") if m.line == 4]
    assert check_magnitudes(helix) is helix


HUGE_FEED = "1" + "0" * 160  # F 1e160 mm/min: its square in mm/s overflowed to infinity
BEYOND = HEAD + "G1 X10\nG2 X20 R5\nG5 I2 J2 P-2 Q2 X30 Y0\nG1 X40 Y5\nM2\n"


def _cycle_s(args: list[str], capsys) -> float:
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert err == ""
    return json.loads(out)["duration_s" if args[0] == "plan" else "cycle_time_s"]


def test_a_feed_beyond_any_axis_is_planned_at_the_axes_speeds(
    write_program, tmp_path, capsys, recwarn
):
    """A feed no axis reaches (a program's F of 160 digits, a feed override of 1e308 %) plans
    and runs as a feed just above the axes' speeds does: no overflow, no warning."""
    huge, fast = (write_program(BEYOND.replace("F600", f"F{f}")) for f in (HUGE_FEED, "100000"))
    assert _cycle_s(["plan", str(huge)], capsys) == _cycle_s(["plan", str(fast)], capsys)
    run = ["--out", str(tmp_path / "out"), "--no-plots", "--no-trace", "--json"]
    at_top = _cycle_s(["run", str(fast), *run], capsys)
    assert _cycle_s(["run", str(huge), *run], capsys) == at_top
    slow = write_program(BEYOND)  # F600, at 1e308 % and at 1e5 % (F 600,000 mm/min)
    assert _cycle_s(["run", str(slow), *run, "--feed-override", "1e308"], capsys) == at_top
    assert _cycle_s(["run", str(slow), *run, "--feed-override", "1e5"], capsys) == at_top
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


#: programs whose computed numbers overflow a double, each value on its own within 1e300
#: (hostile-input review: G95's F x S gave a feed of Infinity, printed by `gantry parse`)
OVERFLOWS = {
    "G95 feed": (f"G95 S{BIG} M3\nG1 X1 F{BIG}\nM2\n", 5, "feed per revolution (G95) F 1e+300"),
    "G95 canned cycle": (
        f"G95 S{BIG} M3\nG81 X1 Y1 Z-1 R1 F{BIG}\nM2\n",
        5,
        "feed per revolution (G95)",
    ),
    "arc radius": (f"G2 X10 Y0 R{BIG}\nM2\n", 4, "arc move's centre X is not a finite number"),
    "inch arc radius": (f"G20 G2 X1 Y0 R{BIG}\nM2\n", 4, "not a finite number"),
    "inverse-time feed": (f"G93 G1 X{BIG} F{BIG}\nM2\n", 4, "feed [mm/min] is not a finite"),
}


@pytest.mark.parametrize("name", sorted(OVERFLOWS))
def test_parse_refuses_a_number_that_overflows_on_its_line(name, write_program, capsys):
    text, line, fragment = OVERFLOWS[name]
    path = write_program(HEAD + text)
    status = main(["parse", str(path)])
    out, err = capsys.readouterr()
    assert status == 2, err
    assert err.startswith(f"{path}:{line}: error: ") and fragment in err, err
    for row in out.splitlines():  # what was printed before the refused line is JSON
        json.loads(row, parse_constant=lambda c: pytest.fail(f"{c} printed"))
