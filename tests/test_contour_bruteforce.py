"""The bounded, vectorised contour-error search against a brute force over ALL commanded moves.

The brute force samples every move densely (every SPACING_MM of path) and takes, per point, the
nearest sample of the whole program: it can only overestimate the true distance, by at most
half a spacing. The bounded search must therefore lie within [brute - SPACING_MM / 2, brute] for
every point (up to NEWTON_TOL_MM, the helix refinement's own precision) -- above it would mean
a nearer move was missed (a junction's neighbour, a lagging tool's move several short moves
back); below it, a point that is not on the geometry.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.moves import Arc
from gantry_sim.sim import contour, program_distance
from gantry_sim.sim.contour import analyse, distance_to_moves, distance_to_program
from gantry_sim.sim.move_table import move_table

SPACING_MM = 0.002
NEWTON_TOL_MM = 1e-7

#: lines, arcs and helices in all three planes, a two-turn helix, a spiral arc (end radius off
#: by 1.5 um, which LinuxCNC accepts), short moves and a sharp corner; the path never comes back
#: within a millimetre of an earlier, non-adjacent part of itself
PROGRAM = """G21 G90 G94 G17
G0 X0 Y0 Z0
G1 X10 F1000
G3 X20 Y0 I5 J0
G2 X30 Y0 Z-2 I5 J0
G18 G2 X40 Y3 Z-2 I5 K0
G19 G3 X42 Y13 Z-2 J5 K0
G1 X50
G17 G2 X50 Y13 Z-8 I5 J0 P2
G1 X60 Y13.5
G1 X60.05 Y13.52
G1 X60.1 Y13.5
G1 X60.1 Y20
G3 X70 Y20.0015 I4.95 J0
G18 G3 X80 Z-8 I5 K0
G0 X80 Y20 Z5
"""


def _moves(text: str):
    return tuple(interpret(text + "M2\n", "linuxcnc", "t.ngc"))


def _point_at(move, u: np.ndarray) -> np.ndarray:
    if isinstance(move, Arc):
        return arc_points(move, u)
    a, b = np.asarray(move.start), np.asarray(move.end)
    return a + u[:, None] * (b - a)


def _dense(moves) -> np.ndarray:
    return np.concatenate(
        [
            _point_at(mv, np.linspace(0.0, 1.0, math.ceil(mv.length_mm / SPACING_MM) + 2))
            for mv in moves
        ]
    )


def _brute(samples: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance [mm] from each point to the nearest sample."""
    sq = np.einsum("ij,ij->i", samples, samples)
    return np.array(
        [math.sqrt(max(0.0, float(np.min(sq - 2.0 * samples @ p + p @ p)))) for p in pts]
    )


def _queries(moves, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points off every move by up to 30 um, each with the line executing it; near both ends of
    a move also with the neighbouring move's line (the line has switched, the tool is not yet
    at the junction -- or already past it)."""
    pts, lines = [], []
    ends = np.array([1e-6, 1e-4, 1e-2, 1 - 1e-2, 1 - 1e-4, 1 - 1e-6])
    for j, mv in enumerate(moves):
        u = np.concatenate([rng.uniform(0, 1, 8), ends])
        off = rng.normal(size=(len(u), 3))
        off *= (rng.uniform(0, 0.03, len(u)) / np.linalg.norm(off, axis=1))[:, None]
        p = _point_at(mv, u) + off
        pts.append(p)
        lines.append(np.full(len(u), mv.line))
        if j > 0:  # the first points, still executing the move before
            pts.append(p[u < 0.5])
            lines.append(np.full(int(np.count_nonzero(u < 0.5)), moves[j - 1].line))
        if j + 1 < len(moves):  # the last points, already executing the next move
            pts.append(p[u > 0.5])
            lines.append(np.full(int(np.count_nonzero(u > 0.5)), moves[j + 1].line))
    return np.concatenate(pts), np.concatenate(lines)


@pytest.fixture(scope="module")
def program():
    moves = _moves(PROGRAM)
    assert {mv.plane for mv in moves if isinstance(mv, Arc)} == {"XY", "XZ", "YZ"}
    return moves, _dense(moves)


def test_bounded_search_finds_the_nearest_commanded_point_of_the_whole_program(program):
    moves, samples = program
    pts, lines = _queries(moves, np.random.default_rng(3))
    dist, nearest = distance_to_program(moves, lines, pts)
    brute = _brute(samples, pts)
    assert np.all(dist <= brute + NEWTON_TOL_MM), "a nearer move was missed"
    assert np.all(dist >= brute - SPACING_MM / 2)
    assert np.linalg.norm(nearest - pts, axis=1) == pytest.approx(dist, abs=1e-12)
    # the nearest points lie on the commanded geometry
    assert _brute(samples, nearest).max() <= SPACING_MM / 2


def test_a_tool_lagging_several_short_moves_is_measured_to_the_move_it_is_on():
    # 0.05 mm chords of an R 10 circle, as CAM writes it; the tool is 4 chords (0.2 mm) behind
    # the reference, 2 um off the path: a PD-only servo at 3 m/min lags this much
    ang = np.radians(np.arange(0, 120.01, 0.2865))
    xy = np.column_stack([10 * np.cos(ang), 10 * np.sin(ang)])
    text = "G21 G90 G17 G0 X10 Y0\n" + "".join(f"G1 X{x:.4f} Y{y:.4f} F3000\n" for x, y in xy[1:])
    moves = _moves(text)
    tab = move_table(moves)
    j = np.arange(5, len(moves) - 6)
    mid = 0.5 * (tab.start[j] + tab.end[j])
    normal = np.column_stack([mid[:, 0], mid[:, 1], np.zeros(len(j))])
    pos = mid + 0.002 * normal / np.linalg.norm(normal, axis=1)[:, None]
    lag = 4
    ref = 0.5 * (tab.start[j + lag] + tab.end[j + lag])
    lines = tab.line[j + lag]
    res = analyse(moves, lines, ref, pos)
    brute = _brute(_dense(moves), pos)
    assert np.all(res.err_um <= (brute + NEWTON_TOL_MM) * 1000)
    assert np.all(res.err_um >= (brute - SPACING_MM / 2) * 1000)
    assert res.err_um == pytest.approx(np.full(len(j), 2.0), abs=1e-4)  # chords rounded to 0.1 um
    # the one-move window alone measures the lag along the path instead (~0.1 mm)
    window_only = distance_to_moves(tab, lines, pos)[0]
    assert window_only.min() > 0.09


def test_results_do_not_depend_on_how_the_trace_is_cut(program, monkeypatch):
    moves, _ = program
    pts, lines = _queries(moves, np.random.default_rng(5))
    tab = move_table(moves)
    reach = np.full(len(pts), 0.05)
    whole = distance_to_moves(tab, lines, pts, reach)
    monkeypatch.setattr(program_distance, "TICKS_PER_PASS", 7)
    cut = distance_to_moves(tab, lines, pts, reach)
    assert np.array_equal(whole[0], cut[0]) and np.array_equal(whole[1], cut[1])
    order = np.random.default_rng(6).permutation(len(pts))  # and not on the order of the points
    shuffled = distance_to_moves(tab, lines[order], pts[order], reach[order])
    assert np.array_equal(shuffled[0], whole[0][order])
    assert np.array_equal(shuffled[1], whole[1][order])


def test_block_statistics_equal_a_direct_scan_per_block():
    moves = _moves("G1 X5 F1000\nG0 X6\nG1 X8\nG2 X10 I1 J0\nG1 X12\n")
    rng = np.random.default_rng(7)
    line = np.sort(rng.choice([1, 2, 3, 4, 5], size=3000, p=[0.3, 0.1, 0.2, 0.4, 0.0]))
    line = np.concatenate([line, [4, 4, 1]])  # a line executed again later
    err = rng.gamma(2.0, 1.5, size=len(line))
    got = contour.block_stats(move_table(moves), line, err)
    expect = []
    for mv in moves:
        if mv.kind == "rapid":
            continue
        e = err[line == mv.line]
        rms = float(np.sqrt(np.mean(e**2))) if e.size else 0.0
        peak = float(e.max()) if e.size else 0.0
        expect.append(contour.BlockError(mv.line, mv.kind, peak, rms, e.size))
    assert got == tuple(expect)  # exactly: the same pairwise sums as np.mean
    assert [b.line for b in got] == [1, 3, 4, 5] and got[-1].max_error_um == 0.0
