"""benchmarks/programs.py writes programs the interpreter accepts, of the length and kind asked
(the scaling benchmarks' figures are per block of these programs)."""

from __future__ import annotations

import pytest

from benchmarks.programs import KINDS, program
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Linear, Rapid


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_parses_to_the_blocks_asked_for(kind):
    text = program(kind, 300)
    moves = parse_program(text)
    assert len(moves) == 301  # the opening G0 and 300 motion blocks
    assert program(kind, 300) == text  # seeded: the same program every run


def test_the_finishing_raster_is_a_polyline_in_g64_p0001():
    moves = parse_program(program("finish", 400))
    feeds = [m for m in moves if not isinstance(m, Rapid)]
    assert all(isinstance(m, Linear) for m in feeds)
    assert {m.path.mode for m in feeds} == {"G64"}
    assert {m.path.tolerance_mm for m in feeds} == {0.001}
    steps = [m.length_mm for m in feeds[1:] if m.start[1] == m.end[1]]
    assert 0.2 <= min(steps) and max(steps) <= 0.55  # 0.2-0.5 mm along X, plus the Z change


def test_an_overlap_at_a_stop_corner_holds_where_the_moves_share_no_axis():
    """benchmarks/stop_corner_overlap.py's measure: a stop between X and Y moves can overlap
    the two profiles (the jerk of each axis is one move's), a 30 degree turn cannot (both
    moves' jerk lies along X), and a straight run has no stop to overlap."""
    from benchmarks.stop_corner_overlap import overlap_savings

    head = "G21 G90 G64 P0.01\nG1 X5 F1200\n"
    _, stops, saved = overlap_savings(head + "G1 X5 Y5\nM2\n")
    assert stops == 1 and 0.010 <= saved[0] <= 0.020  # a 20 mm/s stop's ramps last 32 ms
    _, stops, saved = overlap_savings(head + "G1 X9.33 Y2.5\nM2\n")
    assert stops == 1 and saved == [0.0]
    assert overlap_savings(head + "G1 X10\nM2\n")[1:] == (0, [])
