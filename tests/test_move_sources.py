"""Which program moves each sample executes (Plan.move_sources, Trajectory.source), and the
contour search bounded by them: linear in the moves of a line that holds hundreds (an O-word
loop), with the numbers of the search by line."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.moves import Arc, Dwell, Linear
from gantry_sim.controller.planner.plan import plan
from gantry_sim.sim import program_distance
from gantry_sim.sim.blend_parts import known_path_sources, path_windows, planning_distance_mm
from gantry_sim.sim.contour import analyse
from gantry_sim.sim.move_table import move_table
from gantry_sim.sim.program_distance import path_window
from tests.plan_helpers import blending

#: a spiral of 120 incremental polar moves (radius 2.5 mm shrinking by 0.012 mm, 5 degrees
#: clockwise each), all on line 6
LOOP = """G21 G90 G64 F600
G0 X0 Y2.5 Z1
G1 Z0
G91
o7 repeat [120]
G1 @-0.012 ^-5
o7 endrepeat
G90 G0 Z1
M2
"""

#: blends (G64 P, corners of 11 degrees), a dwell between two moves, and a G64 Q merge of
#: the four collinear steps after it (G64 P without Q merges within P, as LinuxCNC)
MIXED = """G21 G90 G17 F1200
G64 P0.05
G0 X0 Y0 Z0
G1 X5
G1 X10 Y1
G1 X15 Y1
G4 P0.2
G1 X15 Y5
G64 P0.05 Q0.01
G1 X15 Y6
G1 X15 Y7
G1 X15 Y8
G1 X18 Y8
M2
"""


def _planned(text, machine):
    items = list(interpret_events(text))
    return items, plan(items, machine)


def test_every_planned_move_names_the_program_moves_it_executes(machine):
    items, planned = _planned(MIXED, machine)
    moves = planned.moves
    src, lines = planned.move_sources, planned.move_lines
    assert src.shape == (len(lines), 2) and src.dtype == np.int64
    kinds = {}
    for (a, b), line in zip(src.tolist(), lines.tolist(), strict=True):
        assert 0 <= a <= b < len(moves)
        kinds.setdefault(line, set()).add((a, b))
        if a == b:  # a move, or part of one (a blended line's rest)
            assert moves[a].line == line
    dwell_line = next(i.line for i in items if isinstance(i, Dwell))
    ((before, after),) = kinds[dwell_line]
    assert (moves[before].end, moves[after].start) == ((15.0, 1.0, 0.0), (15.0, 1.0, 0.0))
    # the path: blend arcs between their corner's moves, the G64 Q run as one move
    path_src = planned.path_sources
    assert path_src.shape == (len(planned.path_moves), 2)
    blend_rows = [k for k, m in enumerate(planned.path_moves) if isinstance(m, Arc)]
    assert blend_rows and all(path_src[k, 1] == path_src[k, 0] + 1 for k in blend_rows)
    merged = [
        (a, b)
        for (a, b), m in zip(path_src.tolist(), planned.path_moves, strict=True)
        if isinstance(m, Linear) and b > a
    ]
    assert [(moves[a].start, moves[b].end) for a, b in merged] == [
        ((15.0, 1.0, 0.0), (15.0, 8.0, 0.0))
    ]
    assert np.all(np.diff(path_src, axis=0) >= 0)  # both columns grow along the path


def test_samples_carry_their_moves_and_loop_moves_are_told_apart(machine):
    # blended corner by corner: each move its own path move (a G64 fit's piece stands for the
    # moves its length meets: tests/test_polyline_fit.py)
    _, planned = _planned(LOOP, blending(machine))
    traj = planned.sample(machine.servo.period_s)
    assert traj.source is not None and traj.source.shape == (len(traj.t), 2)
    on_loop = traj.line == 6
    executed = np.unique(traj.source[on_loop, 0])
    assert len(executed) == 120  # each of the loop's moves, not the line as a whole
    assert np.all(np.diff(traj.source[:, 0]) >= 0)  # in program order
    piece = planned.sample_range(machine.servo.period_s, 500, 900)
    assert np.array_equal(piece.source, traj.source[500:900])


@pytest.fixture(scope="module")
def loop_run(machine):
    from gantry_sim.sim.api import run_program

    return run_program(LOOP, machine=machine)


def test_contour_search_on_a_loop_line_measures_a_few_moves_per_sample(
    loop_run, machine, monkeypatch
):
    """With the moves each sample executes, the search measures a handful of moves per
    sample; by line too, since each sample measures the move whose box is nearest first and
    then only the moves whose boxes are as near (it measured every move of the loop line,
    137 a sample, when it began with the line's first move). The errors are the same."""
    tr, moves = loop_run.trace, loop_run.moves
    _, planned = _planned(LOOP, machine)
    traj = planned.sample(machine.servo.period_s)
    assert np.array_equal(traj.pos, tr.ref)
    measured = []
    real = program_distance.nearest_on_moves

    def counting(tab, idx, pts):
        measured.append(len(idx))
        return real(tab, idx, pts)

    monkeypatch.setattr(program_distance, "nearest_on_moves", counting)
    by_moves = analyse(moves, tr.line, tr.ref, tr.pos, source=traj.source)
    per_sample_by_moves = sum(measured) / len(tr.t)
    measured.clear()
    by_line = analyse(moves, tr.line, tr.ref, tr.pos)
    per_sample_by_line = sum(measured) / len(tr.t)
    assert np.array_equal(by_moves.err_um, by_line.err_um)
    assert np.array_equal(by_moves.nearest, by_line.nearest)
    assert per_sample_by_moves < 8
    assert per_sample_by_line < 8


def test_the_planning_part_searches_the_path_moves_of_each_sample(loop_run, machine):
    _, planned = _planned(LOOP, machine)
    traj = planned.sample(machine.servo.period_s)
    window = path_windows(known_path_sources(planned), traj.source)
    assert window is not None and window.shape == (len(traj.t), 2)
    tab = move_table(planned.path_moves)
    feed = loop_run.trace.feed
    by_moves = planning_distance_mm(tab, traj.line, traj.pos, feed, window)
    by_line = planning_distance_mm(tab, traj.line, traj.pos, feed)
    assert by_moves == by_line
    # at most a blend arc's corner (i, i + 1): moves i and i + 1 and the blends at their ends
    assert np.all(window[:, 1] - window[:, 0] <= 4)


def test_path_window_maps_program_moves_to_path_moves():
    # path: move 0, blend (0, 1), move 1, merged run (2, 4), move 6 (5: a zero-length move)
    path_src = np.array([[0, 0], [0, 1], [1, 1], [2, 4], [6, 6]])
    windows = np.array([[0, 0], [1, 1], [3, 3], [0, 1], [4, 6], [5, 5], [-1, -1], [6, 6]])
    got = path_window(path_src, windows)
    assert got.tolist() == [
        [0, 1],  # move 0: itself and the blend that starts at its end
        [1, 2],  # move 1: the blend that ends at its start, and itself
        [3, 3],  # inside the merged run
        [0, 2],  # the blend's own sources
        [3, 4],  # a dwell between the run and move 6
        [3, 4],  # only a zero-length move: the path moves either side
        [-1, -1],
        [4, 4],
    ]


def test_marlin_limit_changes_keep_the_sources_of_each_part(machine):
    text = "G21 G90\nG1 X5 F1200\nG1 X5 Y5\nM201 X500\nG1 X0 Y5\nG1 X0 Y0\n"
    items = list(interpret_events(text, dialect="marlin"))
    planned = plan(items, machine)
    moves = planned.moves
    overlaps = 0
    for (a, b), line in zip(
        planned.move_sources.tolist(), planned.move_lines.tolist(), strict=True
    ):
        # a move, or the overlapped stop between two (planner/stop_overlap.py: the line of
        # the move ending there)
        assert b in (a, a + 1) and moves[a].line == line
        overlaps += b == a + 1
    assert overlaps == len(planned.overlaps_s) == 2  # X5 -> Y5, and X0 Y5 -> X0 Y0
    assert sorted({a for a, _ in planned.move_sources.tolist()}) == list(range(len(moves)))


def test_a_canned_cycles_plunges_count_as_feed_and_its_rapids_do_not(machine):
    """Per move, not per line: the G81 line's feed plunges are in the feed statistics (by
    line they were not: the line's last move is the rapid retract)."""
    text = "G21 G90 G17 G98\nG0 X0 Y0 Z5\nG81 X5 Y5 Z-2 R1 F300\nX10\nG80\nM2\n"
    from gantry_sim.sim.contour import feed_samples

    _, planned = _planned(text, machine)
    traj = planned.sample(machine.servo.period_s)
    tab = move_table(planned.moves)
    feed = feed_samples(tab, traj.line, traj.source)
    executing = traj.source[:, 0]
    assert np.array_equal(feed, tab.feed[executing])
    assert feed[traj.line == 3].any() and feed[traj.line == 4].any()
    assert not feed_samples(tab, traj.line)[(traj.line == 3) | (traj.line == 4)].any()


def _tangent_arcs() -> str:
    out, x = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1", "F3000"], 0.0
    for k in range(30):
        r = 2.0 + k % 3
        out.append(f"G{2 + k % 2} X{x + 2 * r:.4f} Y0 I{r:.4f} J0")
        x += 2 * r
    return "\n".join([*out, "G0 Z2", "M2"]) + "\n"


def test_the_planning_distance_measures_the_move_a_sample_is_on_first(machine, monkeypatch):
    """A reference sample's window of path moves starts with the transition before its arc;
    the move whose box is nearest is measured first, so the others are mostly skipped, and
    the largest distance is the one measured on every move of every window."""
    _, planned = _planned(_tangent_arcs(), machine)
    assert sum(b.kind == "transition" for b in planned.blends) >= 20
    traj = planned.sample(machine.servo.period_s)
    tab = move_table(planned.path_moves)
    window = path_windows(known_path_sources(planned), traj.source)
    assert window is not None and (window[:, 1] - window[:, 0] >= 2).mean() > 0.5
    feed = np.ones(len(traj.t), dtype=bool)
    measured = []
    real = program_distance.nearest_on_moves

    def counting(t, idx, pts):  # type: ignore[no-untyped-def]
        measured.append(len(idx))
        return real(t, idx, pts)

    monkeypatch.setattr(program_distance, "nearest_on_moves", counting)
    got = planning_distance_mm(tab, traj.line, traj.pos, feed, window)
    assert sum(measured) / len(traj.t) < 2.0
    monkeypatch.setattr(program_distance, "nearest_on_moves", real)
    lo = np.maximum(window[:, 0] - 1, 0)
    hi = np.minimum(window[:, 1] + 1, len(tab) - 1)
    every = np.full(len(traj.t), np.inf)
    for k in range(int((hi - lo).max()) + 1):  # each move of each window, measured alone
        on = lo + k <= hi
        q = real(tab, (lo + k)[on], traj.pos[on])
        every[on] = np.minimum(every[on], np.linalg.norm(q - traj.pos[on], axis=1))
    assert got == float(every.max()) and 0.0 < got < 0.01
