"""Commands LinuxCNC runs only with motion stopped make an exact stop before their block
(controller/gcode/motion_waits.py), as LinuxCNC 2.9's own planner showed, and the others pass."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Dwell, Linear, Stop
from gantry_sim.controller.planner import plan

HEAD = "G21 G90 G17 G64 P0.01\nF1200\nM3 S500\nG1 X10\n"
TAIL = "G1 X20\nM2\n"

#: codes at whose line LinuxCNC 2.9 came to rest between two moves in line (module docstring)
STOPS = [
    "S500",
    "S2000",
    "M3",
    "M4 S500",
    "M5",
    "M19 R0",
    "M7",
    "M8",
    "M9",
    "M64 P0",
    "M65 P0",
    "M66 P0 L0",
    "M68 E0 Q1",
    "G43 H0",
    "G43.1 Z1",
    "G49",
    "G92 X0",
    "G92.1",
    "G55",
    "G10 L2 P1 X1",
    "G10 L20 P1 X1",
    "T2 M6",
    "G10 L1 P2 Z1",
    "G10 L1 P2 R1",
    "G10 L10 P2 Z1",
    "G10 L11 P2 Z1",
]
#: codes it passed at speed
PASSES = [
    *("F1200", "M62 P0", "M63 P0", "M67 E0 Q1", "M48", "M70", "G10 L2 P2 X1", "G54", "G17"),
    *("T2", "M61 Q2"),
]


def _speed_at_x10(p) -> float:
    """The reference's slowest speed [mm/s] within 0.01 mm of X10, the junction (sampled every
    10 us; two moves in line may be one move, G64 Q merging them)."""
    t = np.arange(0.0, p.duration_s, 1e-5)
    pos, vel, _ = p.curve.evaluate(t)
    near = np.abs(pos[:, 0] - 10.0) < 0.01
    return float(np.linalg.norm(vel[near], axis=1).min())


def _at_rest_at_x10(p) -> bool:
    """Whether the move after X10 starts from rest there."""
    t = float(p.move_start_s[-1])
    pos, vel, _ = p.curve.evaluate(np.array([t]))
    return bool(np.allclose(pos[0], (10.0, 0.0, 0.0)) and not np.any(vel[0]))


@pytest.mark.parametrize("code", STOPS)
def test_a_command_linuxcnc_runs_at_rest_stops_the_moves_before_its_block(machine, code):
    p = plan(list(interpret_events(HEAD + code + "\n" + TAIL)), machine)
    if not code.startswith(("G92 X", "G10")):  # (those move on from another X)
        assert _at_rest_at_x10(p)
    else:
        assert len(p.move_start_s) == 2 and not np.any(p.curve.evaluate(p.move_start_s)[1])
    passed = plan(list(interpret_events(HEAD + TAIL)), machine)
    assert _speed_at_x10(passed) > 15.0
    # the G92 X0 and G10 programs move elsewhere after it: only the stop is compared there
    if not code.startswith(("G92 X", "G10")):
        assert p.duration_s > passed.duration_s + 0.01


@pytest.mark.parametrize("code", PASSES)
def test_the_others_pass_at_speed(machine, code):
    p = plan(list(interpret_events(HEAD + code + "\n" + TAIL)), machine)
    passed = plan(list(interpret_events(HEAD + TAIL)), machine)
    assert p.duration_s == passed.duration_s
    assert _speed_at_x10(p) > 15.0


def test_the_stop_comes_before_the_blocks_motion_where_the_tool_is():
    """An S on a G1 line stops before that line's move (rs274 sets the speed first)."""
    items = list(interpret_events(HEAD + "G1 X15 S600\n" + TAIL))
    stops = [(k, e) for k, e in enumerate(items) if isinstance(e, Stop) and e.line == 5]
    assert len(stops) == 1
    k, stop = stops[0]
    assert stop.code == "S" and stop.position == (10.0, 0.0, 0.0)
    after = items[k + 1]
    assert isinstance(after, Linear) and after.line == 5 and after.start == (10.0, 0.0, 0.0)


def test_under_compensation_the_stop_follows_the_move_held_back(machine):
    """As a G4 there: rs274 queues the command behind the move it holds, so the stop comes
    where that move's tool path ends."""
    text = (
        "G21 G90 G17 G64 P0.01\nT1 M6\nG10 L1 P1 R1\nF600\nG0 X-5 Y-5\nG41 D1\nG1 X0 Y0\n"
        "G1 X20\nM8\nG1 X40\nG40\nM2\n"
    )
    items = list(interpret_events(text))
    at = next(k for k, e in enumerate(items) if isinstance(e, Dwell))
    assert items[at].seconds == 0.0
    before = items[at - 1]  # the tool path to X20, offset by the tool radius
    assert isinstance(before, Linear) and before.end == (20.0, 1.0, 0.0)
    assert not any(isinstance(e, Stop) and e.code == "M8" for e in items)
    without = list(interpret_events(text.replace("M8\n", "")))
    assert plan(items, machine).duration_s > plan(without, machine).duration_s


def test_gantry_parse_lists_motions_only():
    """The stops are events of the planner's input: the parsed motions are the same."""

    def motions(text: str) -> list[tuple]:
        return [(m.kind, m.start, m.end) for m in parse_program(text)]

    assert motions(HEAD + "M8\nS100\n" + TAIL) == motions(HEAD + TAIL)


GRBL_HEAD = "G21 G90 G17\nF1200\nM3 S500\nG1 X10\n"


@pytest.mark.parametrize(
    ("code", "stops"),
    [
        ("M8", True),  # a coolant change
        ("M7\nM7", True),  # (the first M7 stops; see the next case for the second)
        ("M5", True),  # a spindle change
        ("M4", True),
        ("M3", False),  # the spindle on already: nothing changes, nothing syncs
        ("S2000", True),  # a new S on a line of its own, the spindle on
        ("S500", False),  # the same S
        ("G1 X15 S600", False),  # S on a motion line: a laser's power (laser mode)
        ("G92 X0", True),  # the work coordinate offsets change
        ("G55", True),
        ("G54", False),  # in use already
        ("G10 L2 P2 X1", True),  # an EEPROM write, whatever the system
        ("G28.1", True),
        ("F600", False),
        # laser mode, M3: a line without motion that leaves G1/G2/G3 (or comes back) syncs so
        # the power follows (gcode.c GC_PARSER_LASER_FORCE_SYNC; the host-built grbl 1.1h
        # with its syncs reported agreed on 11 such programs, 2026-11-30)
        ("G0", True),
        ("G80", True),
        ("G1", False),
    ],
)
def test_grbl_syncs_its_planner_where_its_source_does(machine, code, stops):
    """grbl 1.1 empties its planner buffer before a change of spindle or coolant state, a new
    S on a line without motion, G10/G28.1/G30.1 (EEPROM writes) and any change of the work
    coordinate offsets (controller/gcode/motion_waits.py, read in gnea/grbl's source)."""
    text = GRBL_HEAD + code + "\n" + TAIL
    items = list(interpret_events(text, dialect="grbl"))
    # (line 3 starts M3; the TAIL's M2 syncs too, and grbl reads on after it)
    waits = [e for e in items if isinstance(e, Stop) and e.line >= 5 and e.code != "M2"]
    assert bool(waits) == stops, waits
    if stops:
        assert waits[0].line == 5 and waits[0].position == (10.0, 0.0, 0.0)
        assert sum(1 for e in waits if e.line == 6) == 0  # a second M7 changes nothing
    p = plan(items, machine)
    if stops:  # every move starts from rest (after G92 X0 the last one goes elsewhere)
        assert len(p.move_start_s) == 2 and not np.any(p.curve.evaluate(p.move_start_s)[1])
    else:  # the plan of the same moves without that line (F600: on the move's own line)
        same = GRBL_HEAD + ("G1 X20 F600\nM2\n" if code == "F600" else TAIL)
        assert (
            p.duration_s == plan(list(interpret_events(same, dialect="grbl")), machine).duration_s
        )


@pytest.mark.parametrize(
    ("code", "stops"),
    [
        ("S500", True),  # the S in effect already: the spindle toolhead still asks for a stop
        ("G1 X15 S600", True),
        ("M3", True),
        ("M5", True),
        ("M7", True),
        ("M9", True),
        ("T2", True),
        ("M6", True),
        ("G92 X0", False),  # the model only
        ("G55", False),
        ("G10 L2 P2 X1", False),
        ("G21", False),
        ("F600", False),
    ],
)
def test_g2core_stops_at_its_queued_commands(code, stops):
    """g2core's back-planning forces a zero exit speed on every command block in its planner
    queue (planner.cpp ``mp_queue_command``, plan_line.cpp "TEMPORARY force PTZ"): S
    (spindle.cpp ``spindle_set_speed``, the default toolhead's set_speed returns true), T
    (canonical_machine.cpp ``cm_select_tool``), M6 (``cm_change_tool``), M3-M5
    (``spindle_set_direction``), M7-M9 (coolant.cpp ``coolant_control_sync``); G92, G5x, G10,
    units change the model only."""
    text = "G21 G90 G64\nF1200\nM3 S500\nG1 X10\n" + code + "\nG1 X20\n"
    items = list(interpret_events(text, dialect="g2core"))
    waits = [e for e in items if isinstance(e, Stop) and e.line == 5]
    assert bool(waits) == stops, waits
    if stops:
        assert waits[0].position == (10.0, 0.0, 0.0)
        assert items.index(waits[0]) == next(i for i, e in enumerate(items) if e.line == 5)
