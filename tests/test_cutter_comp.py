"""Cutter radius compensation (G41/G42, G41.1/G42.1, G40): the tool-centre path rs274 makes.

The differential corpus (gen_comp_*, LinuxCNC's comp samples) checks it against rs274 program by
program; these tests pin the geometry a reader can check by hand.
"""

from __future__ import annotations

import math

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.gcode.tools import Tool

SQUARE = "G21 F100\n{on}\nG1 X10\nG1 Y10\nG1 X0\nG1 Y0\nG40 G1 X-5 Y-5\nM2\n"


def moves(text: str, tools: dict[int, Tool] | None = None) -> list:
    return list(interpret(text, tools=tools))


def ends(text: str, tools: dict[int, Tool] | None = None) -> list[tuple[float, float]]:
    return [(round(m.end[0], 9), round(m.end[1], 9)) for m in moves(text, tools)]


def test_left_of_a_ccw_square_is_inside_with_sharp_inside_corners() -> None:
    # tool radius 1 on the left of a counter-clockwise square: the centre runs 1 mm inside
    assert ends(SQUARE.format(on="G41.1 D2")) == [
        (9.0, 1.0),  # entry: perpendicular to the first move at its end, then cut back...
        (9.0, 9.0),  # ...to where it touches the next side (inside corner)
        (1.0, 9.0),
        (1.0, 0.0),  # last side, finished by G40 at the offset point
        (-5.0, -5.0),  # the exit move leaves from it
    ]


def test_right_of_a_ccw_square_is_outside_with_corner_arcs() -> None:
    got = moves(SQUARE.format(on="G42.1 D2"))
    kinds = [m.kind for m in got]
    assert kinds == ["linear", "arc", "linear", "arc", "linear", "arc", "linear", "linear"]
    corner = got[1]  # about the programmed corner (10, 0), radius 1, clockwise (right side)
    assert corner.center[:2] == (10.0, 0.0) and corner.direction == "ccw"
    assert corner.radius == pytest.approx(1.0) and corner.angle == pytest.approx(math.pi / 2)
    assert got[2].start[:2] == pytest.approx((11.0, 0.0)) and got[2].end[:2] == pytest.approx(
        (11.0, 10.0)
    )


def test_g41_takes_the_diameter_of_the_tool_table() -> None:
    tools = {5: Tool(5, 0.0, 4.0)}
    by_table = ends(SQUARE.format(on="G41 D5"), tools)
    assert by_table == ends(SQUARE.format(on="G41.1 D4"))
    spindle = ends(SQUARE.format(on="T5 M6\nG41"), tools)  # no D: the tool in the spindle
    assert spindle == by_table


def test_negative_diameter_swaps_the_side() -> None:
    assert ends(SQUARE.format(on="G41.1 D-2")) == ends(SQUARE.format(on="G42.1 D2"))


def test_moves_carry_the_line_that_releases_them_as_rs274_prints() -> None:
    got = moves(SQUARE.format(on="G41.1 D2"))
    assert [m.line for m in got] == [4, 5, 6, 7, 7]  # the entry (line 3) shows with line 4


def test_an_arc_is_offset_along_its_radius() -> None:
    text = "G21 F100\nG41.1 D2\nG1 X10\nG3 X10 Y10 J5\nG40 G1 X0\nM2\n"
    arc = [m for m in moves(text) if m.kind == "arc"][-1]
    assert arc.center[:2] == (10.0, 5.0)
    assert arc.radius == pytest.approx(4.0)  # inside the R5 arc by the tool radius 1


@pytest.mark.parametrize(
    ("program", "line", "message"),
    [
        ("G41.1 D2\nG1 X0.5", 2, "entry move is not greater than the tool radius"),
        ("G41.1 D2\nG1 X10\nG18", 3, "cannot change planes"),
        ("G41.1 D2\nG1 X10\nG42.1 D1", 3, "already on"),
        ("G41.1 D2\nG1 X10\nG81 X5 Z-1 R1", 3, "canned cycles"),
        ("G41.1 D2\nG1 X10\nG28", 3, "G28 or G30"),
        ("G41.1 D2\nG1 X10\nG1 X20\nG40\nG2 X30 I5", 5, "must be straight"),
        ("G41.1 D8\nG1 X10\nG1 X20\nG3 X20 Y4 J2", 4, "tool radius not less than arc radius"),
        ("G41.1 D4\nG1 X10\nG1 X20\nG1 X0 Y3", 4, "gouging"),
        ("G41.1", 1, "no D word"),
        ("G18 G41.1 D2", 1, "not supported"),
    ],
)
def test_refusals_name_the_line(program: str, line: int, message: str) -> None:
    with pytest.raises(GcodeError) as info:
        moves(f"G21 F100\n{program}\nM2\n")
    assert info.value.line == line + 1 and message in info.value.message


def test_dialects_without_compensation_refuse_it() -> None:
    with pytest.raises(GcodeError) as info:
        list(interpret("G41.1 D2\nG1 X10 F100\n", dialect="g2core"))
    assert "no cutter radius compensation" in info.value.message


#: a compensated outside profile (with a corner of exactly the tool radius) and drilled holes
PART = """G21 G17 G90 G94
G0 X-4 Y-4 Z2
M3 S9000
G1 Z-1 F600
G42.1 D4 G1 X0 Y-2
G1 Y0
G1 X20
G3 X25 Y5 I0 J5
G1 Y20
G1 X0
G1 Y0
G40 G1 X-4 Y-4
G0 Z2
G98 G81 X5 Y5 Z-3 R1 F300
X15
G83 Y15 Z-4 R1 Q1.5
G80 G0 Z2
M2
"""


def test_a_drilled_and_compensated_part_runs_end_to_end(machine) -> None:
    from gantry_sim.sim.api import run_program

    rep = run_program(PART, file="part.ngc", machine=machine).report
    lines = {b["line"]: b["kind"] for b in rep["blocks"]}
    assert lines[9] == "arc"  # the offset G3 of line 8, released by line 9 (as rs274 -g)
    assert {14, 15, 16} <= lines.keys()  # the cycles' feeds
    assert 0.0 < rep["contour_error_um"]["max"] < 50.0
    assert rep["cycle_time_s"] > 5.0


def test_a_dwell_waits_where_the_held_move_ends_as_rs274_orders_it() -> None:
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.moves import Dwell

    text = "G21 F100\nG41.1 D2\nG1 X10\nG4 P0.5\nG1 Y10\nG40 G1 X0\nM2\n"
    items = list(interpret_events(text))
    # rs274 -g: STRAIGHT_FEED(9, 1), DWELL(0.5), STRAIGHT_FEED(9, 10), STRAIGHT_FEED(0, 10)
    assert [i.kind for i in items] == ["linear", "dwell", "linear", "linear"]
    dwell = items[1]
    assert isinstance(dwell, Dwell) and dwell.seconds == 0.5
    assert dwell.position == pytest.approx((9.0, 1.0, 0.0))


@pytest.mark.parametrize(
    ("code", "message"),
    [
        ("T2 M6", "cannot change tools"),
        ("G43 H1", "cannot change tool offset"),
        ("G64 P0.1", "cannot change control mode"),
        ("G10 L2 P1 X2", "cannot change the active coordinate system"),
    ],
)
def test_codes_rs274_refuses_while_compensation_is_on(code: str, message: str) -> None:
    with pytest.raises(GcodeError) as info:
        moves(f"G21 F100\nG42.1 D3\nG1 X10\n{code}\nG1 Y10\nG40\nM2\n")
    assert info.value.line == 4 and message in info.value.message
    # G10 L2 of another system is allowed
    assert len(moves("G21 F100\nG42.1 D3\nG1 X10\nG10 L2 P2 X2\nG1 Y10\nG40\nM2\n")) == 3
