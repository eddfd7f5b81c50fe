"""Canned cycles (G73, G74, G81-G89): the motions rs274 makes, their lines, events and errors.

The differential corpus (tests/test_rs274_corpus.py, gen_cyc_* and cyc_* programs) checks every
cycle against rs274 program by program; these tests pin the rules a reader can check by hand.
"""

from __future__ import annotations

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.canned_cycles import MAX_CYCLE_STEPS
from gantry_sim.controller.gcode.interpreter import interpret, interpret_events, parse_program
from gantry_sim.controller.moves import Dwell, Linear, Rapid, Stop


def moves(text: str, dialect: str = "linuxcnc") -> list:
    return list(interpret(text, dialect=dialect))


def path(text: str) -> list[tuple[str, int, tuple[float, float, float]]]:
    return [(m.kind, m.line, m.end) for m in moves(text)]


def error_of(text: str, dialect: str = "linuxcnc") -> GcodeError:
    with pytest.raises(GcodeError) as info:
        moves(text, dialect)
    return info.value


def test_g81_g98_retracts_to_the_initial_level_g99_to_r() -> None:
    text = "G21 F100\nG0 Z10\nG98 G81 X1 Y2 Z-3 R2\nG99 X4\nM2\n"
    assert path(text) == [
        ("rapid", 2, (0.0, 0.0, 10.0)),
        ("rapid", 3, (1.0, 2.0, 10.0)),
        ("rapid", 3, (1.0, 2.0, 2.0)),
        ("linear", 3, (1.0, 2.0, -3.0)),
        ("rapid", 3, (1.0, 2.0, 10.0)),  # G98: back to Z10, where the series started
        ("rapid", 4, (4.0, 2.0, 10.0)),
        ("rapid", 4, (4.0, 2.0, 2.0)),
        ("linear", 4, (4.0, 2.0, -3.0)),
        ("rapid", 4, (4.0, 2.0, 2.0)),  # G99: back to R
    ]


def test_g91_repeats_step_by_x_y_and_r_z_are_relative() -> None:
    # G91: R is measured from the initial level (Z10 - 4 = 6), Z from R (6 - 2 = 4)
    ends = [m.end for m in moves("G21 F100\nG0 Z10\nG91 G99 G81 X5 Z-2 R-4 L3\nM2\n")]
    drilled = [e for e in ends if e[2] == 4.0]
    assert drilled == [(5.0, 0.0, 4.0), (10.0, 0.0, 4.0), (15.0, 0.0, 4.0)]


def test_g83_pecks_back_to_r_and_down_to_0254_mm_above_the_last_depth() -> None:
    got = [m.end[2] for m in moves("G21 F100\nG0 Z5\nG83 Z-2.5 R1 Q1\nM2\n")]
    assert got == pytest.approx([5, 5, 1, 0, 1, 0.254, -1, 1, -0.746, -2, 1, -1.746, -2.5, 1])


def test_planes_drill_along_their_normal_axis() -> None:
    # G19: X is the drilling axis, Y/Z position the hole
    got = path("G21 F100 G19\nG0 X10\nG81 X-1 Y2 Z3 R1\nM2\n")
    assert [m[2] for m in got[1:]] == [
        (10.0, 2.0, 3.0),
        (1.0, 2.0, 3.0),
        (-1.0, 2.0, 3.0),
        (1.0, 2.0, 3.0),
    ]


def test_dwells_and_g88_stop_are_events_in_their_place() -> None:
    text = "G21 F100 M3\nG0 Z5\nG82 X1 Z-1 R1 P0.5\nG88 X2 Z-1 R1 P0.25\nM2\n"
    items = list(interpret_events(text))
    dwells = [(e.line, e.position, e.seconds) for e in items if isinstance(e, Dwell)]
    assert dwells == [(3, (1.0, 0.0, -1.0), 0.5), (4, (2.0, 0.0, -1.0), 0.25)]
    stops = [e for e in items if isinstance(e, Stop)]
    # M3: LinuxCNC starts the spindle with motion stopped (controller/gcode/motion_waits.py)
    assert [(s.line, s.code) for s in stops] == [(1, "M3"), (4, "G88")]
    # G88 leaves the tool at the bottom: the operator retracts by hand
    assert [m for m in items if isinstance(m, Rapid | Linear)][-1].end == (2.0, 0.0, -1.0)
    # a negative P: rs274 prints DWELL(-0.5000), which LinuxCNC ends at once (no time: the
    # duration bound had subtracted it); G89's dwell at the bottom, G82's likewise
    for code in ("G82", "G89"):
        negative = f"G21 F100 M3\nG0 Z5\n{code} X1 Z-1 R1 P-0.5\nM2\n"
        assert [e.seconds for e in interpret_events(negative) if isinstance(e, Dwell)] == [0.0]


def test_errors_carry_the_cycle_line_and_moves_made_before_them() -> None:
    assert "R clearance plane unspecified" in error_of("F1\nG81 X1 Z-1\nM2\n").message
    assert error_of("F1\nG81 X1 Z-1\nM2\n").line == 2
    assert "Z value unspecified" in error_of("F1\nG81 X1 R1\nM2\n").message
    assert "R less than Z" in error_of("F1\nG81 X1 Z2 R1\nM2\n").message
    assert "zero repeats" in error_of("F1\nG81 X1 Z-1 R1 L0\nM2\n").message
    assert "Q word missing with G83" in error_of("F1\nG83 X1 Z-1 R1\nM2\n").message
    # rs274 positions the tool over the hole before it finds the spindle stopped
    got: list = []
    with pytest.raises(GcodeError) as info:
        got.extend(interpret("F1\nG0 Z5\nG86 X1 Z-1 R1 P1\nM2\n"))
    assert "spindle not turning in G86" in info.value.message and info.value.line == 3
    assert [m.end for m in got] == [(0.0, 0.0, 5.0), (1.0, 0.0, 5.0), (1.0, 0.0, 1.0)]


def test_a_series_ends_with_another_motion_and_r_is_needed_again() -> None:
    assert error_of("F1\nG81 X1 Z-1 R1\nG0 X2\nG81 X3\nM2\n").line == 4
    assert "axis words with G80" in error_of("F1\nG81 X1 Z-1 R1\nG80 X2\nM2\n").message


def test_words_only_the_cycle_uses_are_refused_elsewhere() -> None:
    assert "Q word with no code" in error_of("F1\nG81 X1 Z-1 R1 Q1\nM2\n").message
    assert "P word with no code" in error_of("F1\nG81 X1 Z-1 R1 P1\nM2\n").message
    assert "L word with no code" in error_of("M4\nF1\nG74 X1 Z-1 R1 L2\nM2\n").message


def test_dialects_without_canned_cycles_refuse_them() -> None:
    for dialect in ("grbl", "g2core"):
        message = error_of("G81 X1 Z-1 R1 F10\nM2\n", dialect).message
        assert "G81 is not supported" in message and dialect in message
    # Marlin answers "Unknown command" and goes on: the line does nothing (its F neither)
    got = parse_program("G1 X2 F100\nG81 X1 Z-1 R1 F10\nG1 X3\n", "marlin")
    assert [(m.line, m.end, m.feed_mm_per_min) for m in got] == [
        (1, (2.0, 0.0, 0.0), 100.0),
        (3, (3.0, 0.0, 0.0), 100.0),
    ]


def test_g95_cycle_feeds_are_f_per_revolution_times_s() -> None:
    got = moves("G21 G95 S1000 M3 F0.1\nG0 Z5\nG81 X1 Z-2 R1\nM2\n")
    assert [m.feed_mm_per_min for m in got if isinstance(m, Linear)] == [pytest.approx(100.0)]
    assert "zero spindle speed" in error_of("G21 G95 F0.1\nG0 Z5\nG81 X1 Z-2 R1\nM2\n").message


@pytest.mark.parametrize(
    ("block", "holes", "pecks"),
    [
        ("G91 G81 X0.001 Z-1 R1 L99999999", "99,999,999", "1"),  # 3e8 moves: hours to expand
        ("G73 X1 Y1 Z-50 R1 Q0.00001", "1", "5,100,000"),
        ("G91 G83 X1 Z-2 R1 Q0.001 L501", "501", "2,000"),  # each factor alone is small
    ],
)
def test_a_cycle_of_more_than_a_million_holes_x_pecks_is_refused_at_once(block, holes, pecks):
    with pytest.raises(GcodeError) as info:
        list(interpret(f"G21 F100\nG0 Z5\n{block}\nM2\n"))
    assert info.value.line == 3
    assert f"{holes} hole(s) of {pecks} peck(s)" in info.value.message
    # below the bound a cycle expands peck by peck (one hole here: 500 would take seconds)
    assert MAX_CYCLE_STEPS == 1_000_000
    pecked = list(interpret("G21 F100\nG0 Z5\nG91 G83 X1 Z-2 R1 Q0.001\nM2\n"))
    assert sum(m.kind == "linear" for m in pecked) == 2_000
