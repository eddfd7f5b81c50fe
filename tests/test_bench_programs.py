"""benchmarks/programs.py writes programs the interpreter accepts, of the length and kind asked
(the scaling benchmarks' figures are per block of these programs)."""

from __future__ import annotations

import itertools

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


def test_adaptive_clearing_is_short_loops_joined_by_rapids_at_depth():
    moves = parse_program(program("adaptive", 2000))[1:]  # after the opening G0
    rapids = [k for k, m in enumerate(moves) if isinstance(m, Rapid)]
    # two rapids before each loop, of at most 300 degrees of R 1 in chords of 0.05 mm or more
    assert max(b - a for a, b in itertools.pairwise(rapids)) <= 2 + 105
    assert {m.end[2] for m in moves} == {-2.0}  # no lift between loops
    chords = [m.length_mm for m in moves if isinstance(m, Linear)]
    assert 0.045 <= min(chords) and max(chords) <= 0.125  # 0.05-0.12 mm, rounded to 0.1 um
    assert {m.feed_mm_per_min for m in moves if isinstance(m, Linear)} == {420.0}
