"""Marlin's extruder axis as far as the planner needs it: which moves extrude (M204 P) and which
are travels (M204 T), through M82/M83, G90/G91, G92 E, E-only lines, arcs and G20
(controller/gcode/extruder.py)."""

from __future__ import annotations

import json

from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.extruder import Extruder
from gantry_sim.controller.gcode.interpreter import interpret, parse_program
from gantry_sim.sim.cli import main


def _extrudes(text: str, dialect: str = "marlin") -> dict[int, bool | None]:
    return {m.line: m.extrudes for m in parse_program(text, dialect=dialect)}


def test_relative_e_extrudes_where_e_is_not_zero():
    text = "G21\nG90\nM83\nG1 X1 E0.5 F1200\nG1 X2\nG1 X3 E0\nG1 X4 E-0.2\nG1 E-0.8\nG0 X5\n"
    assert _extrudes(text) == {4: True, 5: False, 6: False, 7: True, 8: True, 9: False}


def test_absolute_e_extrudes_where_e_changes_and_g92_sets_it():
    text = (
        "G21\nG90\nM82\nG1 X1 E1 F1200\nG1 X2 E1\nG1 X3 E1.5\n"  # 4, 5, 6
        "G92 E0\nG1 X4 E0\nG1 X5 E0.1\n"  # 8, 9: from the G92 position
        "G92 X5 E3 ; with an axis\nG1 X6 E3\nG1 X7 E2\n"  # 11, 12
    )
    assert _extrudes(text) == {4: True, 5: False, 6: True, 8: False, 9: True, 11: False, 12: True}


def test_marlins_default_is_absolute_e_and_g90_g91_set_e_too():
    # no M82/M83: absolute; G91 makes E relative, G90 absolute again (Marlin's
    # set_relative_mode), and M83 before G90 is undone by it
    text = (
        "G21\nG1 X1 E2 F1200\nG1 X2 E2\nG91\nG1 X1 E2\nG1 X1 E0\nM83\nG90\nG1 X5 E2\nG1 X6 E2.1\n"
    )
    assert _extrudes(text) == {2: True, 3: False, 5: True, 6: False, 9: True, 10: True}
    assert _extrudes("G21\nM83\nG90\nG1 X1 E2 F100\nG1 X2 E2\n") == {4: True, 5: False}


def test_arcs_and_curves_extrude_as_their_lines_say_and_g20_converts_e():
    text = "G21\nM82\nG1 X10 E1 F1200\nG2 X20 Y0 I5 J0 E1\nG3 X10 Y0 I-5 J0 E2\n"
    assert _extrudes(text) == {3: True, 4: False, 5: True}
    text = "G21\nM83\nG1 X1 F1200\nG5 I1 J1 P-1 Q1 X5 Y0 E0.4\nG5 I1 J1 P-1 Q1 X9 Y0\n"
    assert _extrudes(text) == {3: False, 4: True, 5: False}
    # 0.5 in is 12.7 mm: the same E position after the change of units
    text = "G20\nM82\nG1 X0.1 E0.5 F10\nG21\nG1 X5 E12.7\nG1 X6 E12.8\n"
    assert _extrudes(text) == {3: True, 5: False, 6: True}


def test_other_dialects_follow_no_extruder():
    assert set(_extrudes("G21\nG1 X1 F100\nG2 X3 Y0 I1 J0\nM2\n", "linuxcnc").values()) == {None}
    assert set(_extrudes("G21\nG1 X1 F100\nG1 X2 Y1\n", "grbl").values()) == {None}


def test_a_refused_line_leaves_the_extruder_as_it_was():
    # --all-errors goes on after a refused line: its E must not count (the line did nothing)
    errors: list[GcodeError] = []
    text = "G21\nM82\nG1 X1 E1 F100\nG2 X2 I1 P101 E5\nG1 X3 E5\n"  # line 4: P beyond 100
    moves = list(interpret(text, dialect="marlin", errors=errors))
    assert [e.line for e in errors] == [4]
    assert {m.line: m.extrudes for m in moves} == {3: True, 5: True}


def test_an_arc_marlin_plans_nothing_for_leaves_the_extruder_as_it_was():
    # no centre (G2_G3.cpp: "bad parameters"), or an end on the start's ray (plan_arc returns):
    # Marlin commits no current_position, its E neither, so the next E5 still extrudes
    for arc in ("G2 X2 E5", "G2 X3 Y0 I-1 J0 E5"):
        text = f"G21\nM82\nG1 X1 E1 F100\n{arc}\nG1 X3 E5\n"
        moves = list(interpret(text, dialect="marlin"))
        assert {m.line: m.extrudes for m in moves} == {3: True, 5: True}, arc


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(
        st.one_of(
            st.tuples(st.just("move"), st.one_of(st.none(), st.floats(-5, 5, width=32))),
            st.tuples(st.just("mode"), st.booleans()),
            st.tuples(st.just("set"), st.floats(-5, 5, width=32)),
        ),
        max_size=30,
    )
)
def test_the_extruder_matches_a_plain_running_position(steps):
    """Whether each move extrudes is whether the position E would reach differs from where it
    is (relative: any E but 0), the position the sum or the last absolute E."""
    e, relative, position = Extruder(), False, 0.0
    for kind, value in steps:
        if kind == "mode":
            e, relative = e.with_mode(value), value
        elif kind == "set":
            e, position = e.at(value), value
        else:
            moved, e = e.move(value)
            if value is None:
                assert moved is False
            elif relative:
                assert moved == (value != 0.0)
                position += value
            else:
                assert moved == (value != position)
                position = value
        assert e.position_mm == position and e.relative == relative


def test_gantry_parse_says_which_moves_extrude(tmp_path, capsys):
    prog = tmp_path / "print.gcode"
    prog.write_text("G21\nM83\nG1 X1 E0.5 F1200\nG1 X2\n")
    assert main(["parse", "--dialect", "marlin", str(prog)]) == 0
    moves = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert [m["extrudes"] for m in moves] == [True, False]
    prog.write_text("G21\nG1 X1 F1200\nM2\n")
    assert main(["parse", str(prog)]) == 0
    assert "extrudes" not in json.loads(capsys.readouterr().out.splitlines()[0])
