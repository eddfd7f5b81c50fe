"""Splines of thousands of control points: the checks along a curve work a block of samples at
a time, with the same numbers, and a chord count that cannot be reached is refused without
measuring it all.

A hostile G5.2 of 5,000 zigzag control points (a contract fuzz's find) asked for a million
chords: their arc-length inversion evaluated 135 million points at once and ended in a
MemoryError (exit 3) after 9.6 GB; its speed caps and its extent held 1.8 GB more. It is now
refused (exit 2) in a bounded memory.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller import nurbs
from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Spline
from gantry_sim.controller.planner import segment, spline_geometry, spline_split

#: a weighted quadratic NURBS zigzagging through 13 control points (cusp-free here: the
#: chord count is what is checked), a G5 whose start has zero speed, and a cubic G5.2
PROGRAMS = {
    "zigzag": "G21 G17 G90\nG0 X0 Y0\nF600\nG5.2 X0 Y1 P1 L3\n"
    + "".join(
        f"X{x} Y{y} P{p}\n"
        for x, y, p in zip(
            range(1, 13), [0, 1.5, 0.5, 2, 0, 1, 2.5, 0.5, 1, 0, 2, 1], [1, 2, 3] * 4, strict=True
        )
    )
    + "G5.3\nM2\n",
    "zero-speed start": "G21 G17 G90\nG0 X0 Y0\nF600\nG1 X0.023 Y0.0261\n"
    "G5 P0.4704 Q0.0581 X-0.371 Y-0.0238\nM2\n",
    "cubic": "G21 G17 G90\nG0 X0 Y0\nF600\nG5.2 X0 Y0 P1 L4\nX2 Y3 P1\nX5 Y-1 P2\n"
    "X8 Y2 P1\nX9 Y0 P1\nG5.3\nM2\n",
}


def _spline(name: str) -> Spline:
    (s,) = [m for m in parse_program(PROGRAMS[name]) if isinstance(m, Spline)]
    return s


def _small_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(segment, "CHECK_CHORDS", 3)
    monkeypatch.setattr(nurbs, "ORDERS_CHUNK", 7)
    monkeypatch.setattr(spline_split, "CAP_CHUNK", 5)
    monkeypatch.setattr(spline_geometry, "EXTENT_CHUNK", 11)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_blocks_of_samples_give_the_whole_curves_numbers(name, machine, monkeypatch):
    s = _spline(name)
    u = np.linspace(s.curve.nurbs.t_min, s.curve.nurbs.t_max, 1001)
    t = np.linspace(s.curve.nurbs.t_min, s.curve.nurbs.t_max, 257)

    def figures() -> tuple:
        return (
            [segment.chord_deviation_mm(s, n) for n in (1, 5, 40)],
            s.curve.nurbs.poly.orders(u, 3),
            spline_split._cap_profile(s, t, machine.limits, 1.0),
            spline_geometry.curvature_bounds(s, 40),
            spline_geometry.spline_extent_points(s),
        )

    whole = figures()
    _small_blocks(monkeypatch)
    blocks = figures()
    assert blocks[0] == whole[0]  # the chords' deviations, bit for bit
    for a, b in zip(blocks[1], whole[1], strict=True):
        assert np.array_equal(a, b)
    for a, b in zip(blocks[2], whole[2], strict=True):
        assert np.array_equal(a, b)
    assert blocks[3] == whole[3]
    # the extent: the same box (each block keeps its lowest and highest samples)
    assert np.array_equal(blocks[4].min(axis=0), whole[4].min(axis=0))
    assert np.array_equal(blocks[4].max(axis=0), whole[4].max(axis=0))
    assert len(whole[4]) == 2 + 6  # the ends, and one block's lowest and highest


def test_a_cusp_between_two_blocks_is_found(monkeypatch):
    text = "G21 G17 G90 F600\nG0 X0 Y0\nG1 X1 Y0\nG5 I0 J0 P1 Q0 X9 Y0\nM2\n"  # X overshoots 9
    (s,) = [m for m in parse_program(text) if isinstance(m, Spline)]
    with pytest.raises(PlanningError, match="cusp"):
        spline_geometry.curvature_bounds(s, 40)
    # with blocks of one sample, every pair of neighbouring samples straddles two blocks
    monkeypatch.setattr(spline_geometry, "EXTENT_CHUNK", 1)
    with pytest.raises(PlanningError, match="cusp"):
        spline_geometry.curvature_bounds(s, 40)


def test_a_chord_count_beyond_the_most_allowed_is_refused_after_one_block(monkeypatch):
    s = _spline("zigzag")
    fits = segment._chord_count(s, "chord", 0.001, 1.0)
    assert fits > 100
    monkeypatch.setattr(segment, "CHECK_CHORDS", 8)
    measured: list[int] = []  # samples measured per block
    points = segment.spline_points

    def counted(spline: Spline, sigma: np.ndarray) -> np.ndarray:
        measured.append(len(sigma))
        return points(spline, sigma)

    monkeypatch.setattr(segment, "spline_points", counted)
    # a limit the curve fits in: the same count as without one, found as before
    monkeypatch.setattr(segment, "MAX_SEGMENTS_PER_ARC", fits)
    assert segment._chord_count(s, "chord", 0.001, 1.0) == fits
    # a limit just above the second count tried: whatever that count's deviation beyond the
    # tolerance, the count after it passes the limit, so the first block beyond it decides
    k, tol = segment.CHECK_SAMPLES, segment.SPLINE_TOLERANCE_SHARE * 0.001
    second = math.ceil((segment.chord_deviation_mm(s, 1) / tol) ** 0.5 * 1.02)
    assert second > 16  # four blocks of 8 chords at least
    monkeypatch.setattr(segment, "MAX_SEGMENTS_PER_ARC", second + 1)
    measured.clear()
    with pytest.raises(PlanningError, match=f"more than {second + 1} segments"):
        segment._chord_count(s, "chord", 0.001, 1.0)
    assert measured == [k + 1, 8 * k + 1]  # one chord; then one block of the second count
