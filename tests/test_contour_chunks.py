"""The analysis in pieces (what a streaming run does) gives the whole trace's numbers exactly."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gantry_sim.sim.api import run_program
from gantry_sim.sim.contour import (
    TRACKING_WINDOW,
    analyse,
    analyse_chunk,
    combine,
    reference_context,
)
from gantry_sim.sim.move_table import move_table

# rapids, a plunge, lines with a corner, a helix and a sub-millimetre zig-zag: ~1.6 s simulated
PROGRAM = """G21 G17 G90 G94
G0 X2 Y0 Z1
G1 Z0 F600
G1 X6 F3000
G1 Y3
G3 X2 Y3 Z-0.5 I-2 J0
G1 X2.2 Y3.1
G1 X2.4 Y3
G1 X2.6 Y3.1
G0 Z2
M2
"""


@pytest.fixture(scope="module")
def run(machine):
    return run_program(PROGRAM, machine=machine)


@pytest.mark.parametrize("seed", [0, 1])
def test_chunks_of_any_size_combine_to_the_whole_analysis(run, seed):
    tr, moves = run.trace, run.moves
    n = len(tr.t)
    whole = analyse(moves, tr.line, tr.ref, tr.pos)
    rng = np.random.default_rng(seed)
    # cuts anywhere: single samples, chunks shorter than the tracking window, long ones
    sizes = rng.choice([1, 7, TRACKING_WINDOW - 1, 2 * TRACKING_WINDOW + 3], size=n)
    sizes[rng.integers(0, 4)] = 400
    cuts = np.concatenate([[0], np.cumsum(sizes)])
    cuts = np.unique(np.minimum(cuts, n))
    tab = move_table(moves)
    chunks = []
    for lo, hi in itertools.pairwise(cuts.tolist()):
        start, stop = reference_context(lo, hi, n)
        chunks.append(
            analyse_chunk(tab, tr.line[lo:hi], tr.pos[lo:hi], tr.ref[start:stop], lo - start)
        )
    assert len(chunks) > 10
    pieces = combine(tab, tr.line, chunks, whole.parts.chord_max_um)
    assert np.array_equal(pieces.err_um, whole.err_um)
    assert np.array_equal(pieces.nearest, whole.nearest)
    assert np.array_equal(pieces.feed, whole.feed)
    assert pieces.contour == whole.contour
    assert pieces.parts == whole.parts
    assert pieces.blocks == whole.blocks
    assert whole.parts.tracking_max_um > 0 and whole.parts.reference_max_um > 0


def test_the_run_reports_the_whole_analysis(run):
    tr = run.trace
    whole = analyse(run.moves, tr.line, tr.ref, tr.pos)
    assert np.array_equal(tr.err_um, whole.err_um)
    assert run.run_report.blocks == whole.blocks
    assert run.report["contour_error_um"] == whole.contour.to_json()


def test_chord_part_is_the_same_checked_in_small_batches(machine, monkeypatch):
    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.controller.planner import plan
    from gantry_sim.sim import contour

    arcs = PROGRAM.replace("M2\n", "G2 X6.6 Y3.1 I2 J0\nG3 X2.6 Y3.1 I-2 J0\nM2\n")
    moves = parse_program(arcs)
    vertices = plan(moves, machine).vertices
    at_once = contour.chord_max_um(moves, vertices)
    monkeypatch.setattr(contour, "CHORD_BATCH", 3)  # many batches, cut inside and between arcs
    assert contour.chord_max_um(moves, vertices) == at_once > 0


def test_passes_bound_the_pairs_measured_at_once_and_cover_every_point(monkeypatch):
    """A line with many moves (an O-word loop: 400 on one line took 2.8 GB) or a dwell's line
    (compared with every move) makes a point's window large; the passes hold fewer points."""
    from gantry_sim.sim import program_distance as pd

    monkeypatch.setattr(pd, "PAIRS_PER_PASS", 100)
    monkeypatch.setattr(pd, "TICKS_PER_PASS", 16)
    counts = np.array([3] * 40 + [402] * 5 + [3] * 40 + [250])
    passes = pd._passes(counts)
    assert passes[0].start == 0 and passes[-1].stop == len(counts)
    assert all(a.stop == b.start for a, b in itertools.pairwise(passes))
    for sl in passes:
        assert sl.stop - sl.start <= 16
        assert counts[sl].sum() <= 100 or sl.stop - sl.start == 1


def test_small_passes_give_the_same_distances(monkeypatch):
    """Bounding the pairs per pass changes how the work is cut, never a number: 150 moves on
    one line (an O-word loop) and a dwell, measured in passes of at most 64 pairs."""
    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.sim import program_distance as pd

    text = (
        "G21 G90 G17 F2000\nG1 X1\n#1=0\no1 while [#1 LT 150]\n"
        "G1 X[2 + COS[#1 * 0.2] * [1 + #1 * 0.02]] Y[SIN[#1 * 0.2] * [1 + #1 * 0.02]]\n"
        "#1=[#1+1]\no1 endwhile\nG4 P1\nG1 X0 Y0\nM2\n"
    )
    tab = move_table(parse_program(text))
    rng = np.random.default_rng(3)
    lines = rng.choice([2, 5, 8, 9], size=500)  # 8: the dwell's line, which has no move
    pts = rng.uniform(-4.0, 6.0, size=(500, 3)) * [1.0, 1.0, 0.0]
    reach = rng.uniform(0.0, 2.0, size=500)
    whole = pd.distance_to_moves(tab, lines, pts, reach)
    monkeypatch.setattr(pd, "PAIRS_PER_PASS", 64)
    cut = pd.distance_to_moves(tab, lines, pts, reach)
    assert np.array_equal(whole[0], cut[0]) and np.array_equal(whole[1], cut[1])


def test_a_plans_vertices_read_in_blocks_are_its_vertices_one_by_one(machine, monkeypatch):
    """ChordVertices.block makes the arcs' vertices in batches (the run's chord check): the
    same arrays bit for bit as reading each move's, for lines, arcs, helices and a spline, and
    the same chord part with blocks cut anywhere."""
    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.controller.planner import plan
    from gantry_sim.sim import contour

    text = PROGRAM.replace(
        "M2\n",
        "G2 X6.6 Y3.1 I2 J0\nG3 X2.6 Y3.1 I-2 J0 Z-1\nG1 X0\nG3 X0 Y0 I1 J-1.55 P3 Z-3\n"
        "G5 X4 Y2 I1 J1 P1 Q-1\nM2\n",
    )
    moves = parse_program(text)
    vertices = plan(moves, machine).vertices
    one_by_one = [vertices[i] for i in range(len(moves))]
    for lo, hi in ((0, len(moves)), (1, 4), (2, len(moves) - 1)):
        block = vertices.block(lo, hi)
        assert len(block) == hi - lo
        assert all(np.array_equal(a, b) for a, b in zip(block, one_by_one[lo:hi], strict=True))
    at_once = contour.chord_max_um(moves, vertices)
    assert at_once == contour.chord_max_um(moves, one_by_one) > 0
    monkeypatch.setattr(contour, "CHORD_MOVES", 3)  # blocks of 3 moves
    assert contour.chord_max_um(moves, vertices) == at_once
