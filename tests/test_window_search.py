"""The window search behind every distance of the analysis (sim/program_distance.py) gives,
bit for bit, what measuring every move of each point's window gives: the smallest distance,
the first move of the window on a tie, and inf and the point itself where no distance is
finite. Its shortcuts (the move with the nearest box measured first, a move measured only where
its box is not farther than the nearest so far, short windows position by position, long ones
pair by pair) must never change a number."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.sim.move_table import MoveTable, move_table
from gantry_sim.sim.nearest import nearest_on_moves
from gantry_sim.sim.program_distance import SLOTS, _closest_in_window

#: a zig-zag of short lines, a corner revisited, a full circle, a helix, arcs in G18 and G19, a
#: zero-length line and a rapid: windows whose moves touch, overlap and tie
PROGRAM = """G21 G90 G17
G0 X0 Y0 Z0
G1 X1 F1000
G1 X1.2 Y0.1
G1 X1.4 Y0
G1 X1.6 Y0.1
G1 X1.6 Y0.1
G1 X1.6 Y1
G1 X0 Y1
G1 X0 Y0
G2 X0 Y0 I0.5 J0
G3 X1 Y1 Z-0.5 I0.5 J0.5
G18 G2 X2 Z-0.5 I0.5 K0
G19 G3 Y2 Z-0.5 J0.5 K0
G0 X0 Y0 Z0
M2
"""


def _oracle(
    tab: MoveTable, lo: np.ndarray, hi: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every move of every window measured, one point at a time."""
    best = np.full(len(pts), np.inf)
    nearest = np.array(pts, dtype=float, copy=True)
    for i, p in enumerate(pts):
        moves = np.arange(lo[i], hi[i] + 1)
        q = nearest_on_moves(tab, moves, np.repeat(p[None], len(moves), axis=0))
        d = np.linalg.norm(q - p, axis=1)
        d = np.where(np.isnan(d), np.inf, d)
        if d.size and d.min() < np.inf:
            k = int(np.argmin(d))  # the first of the smallest
            best[i], nearest[i] = d[k], q[k]
    return best, nearest


TAB = move_table(parse_program(PROGRAM))
VERTICES = np.concatenate([TAB.start, TAB.end])


@st.composite
def _points(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points near the moves (on vertices, so that moves tie, or off them), each with a
    window lo..hi (up to the whole table, past SLOTS) and a move of it measured first."""
    m = len(TAB)
    n = draw(st.integers(1, 40))
    lo, hi, first, pts = [], [], [], []
    for _ in range(n):
        a = draw(st.integers(0, m - 1))
        b = draw(st.integers(a, min(m - 1, a + draw(st.sampled_from([0, 2, 4, SLOTS, m])))))
        lo.append(a)
        hi.append(b)
        first.append(draw(st.integers(a, b)))
        base = VERTICES[draw(st.integers(0, len(VERTICES) - 1))]
        off = draw(st.sampled_from([0.0, 1e-9, 0.05, 0.3, 2.0]))
        direction = np.array(draw(st.tuples(*[st.floats(-1, 1)] * 3)))
        pts.append(base + off * direction)
    if draw(st.booleans()):
        pts[0] = np.array([np.nan, 0.0, 0.0])  # no finite distance: inf and the point itself
    return np.array(lo), np.array(hi), np.array(first), np.array(pts, dtype=float)


@given(case=_points())
@settings(max_examples=100, deadline=None)
def test_the_window_search_is_every_move_measured(
    case: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    lo, hi, first, pts = case
    best, nearest = _closest_in_window(TAB, lo, hi, first, pts)
    want_best, want_nearest = _oracle(TAB, lo, hi, pts)
    assert best.tobytes() == want_best.tobytes()
    assert np.array_equal(nearest, want_nearest, equal_nan=True)


def test_a_point_on_a_shared_vertex_takes_the_first_move_of_its_window() -> None:
    # the end of line 1 (X1) is the start of line 2: both at distance 0, whichever is its own
    at = TAB.end[1][None]
    for first in (1, 2):
        best, nearest = _closest_in_window(TAB, np.array([1]), np.array([2]), np.array([first]), at)
        assert best[0] == 0.0 and np.array_equal(nearest[0], TAB.end[1])
    # a point off both, nearer the second: the second's point, whichever is measured first
    p = np.array([[1.3, 0.2, 0.0]])
    for first in (1, 2):
        best, nearest = _closest_in_window(TAB, np.array([1]), np.array([2]), np.array([first]), p)
        want = nearest_on_moves(TAB, np.array([2]), p)
        assert np.array_equal(nearest, want)
