"""Arcs of many chords: their closed-form pieces are made and checked a block of pieces at a
time, and a large arc's are made when its chain is planned rather than with its whole batch.

Ten tangent helices of 6,000 turns (6 million chords at 1 um) held 7.3 GB at once when every
piece of the chain was made in one go; with the blocks they plan in 1.4 GB. The plan must be
the same bit for bit whatever the blocks.
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import chain_plan, pieces, plan
from gantry_sim.controller.planner.jerk3 import jerk3_pairs, piece_limits_ok

#: tangent helices (one chain), a line, a G18 arc, a blended polyline corner and a short arc
#: after a corner: batches mixing arcs above and below the blocks' sizes
PROGRAM = """G21 G90 G17 G64 P0.01 F1500
G0 X2 Y0 Z0
G3 X2 Y0 I-2 J0 Z-0.4 P3
G3 X0 Y2 I-2 J0 Z-0.5
G1 X-3 Y2
G18 G2 X-6 Z-0.5 I-1.5 K0
G17 G1 X-6 Y5
G1 X-4 Y6
G1 X-1 Y6.2
G3 X1 Y6.2 R1.2
G1 X1 Y9
M2
"""


def _figures(p) -> list[bytes]:
    out = [np.float64(p.duration_s).tobytes(), p.move_start_s.tobytes()]
    out += [np.ascontiguousarray(col).tobytes() for axis in p.curve.axes for col in axis]
    return out


def test_blocks_of_pieces_give_the_same_plan(machine, monkeypatch):
    moves = parse_program(PROGRAM)
    whole = plan(moves, machine)
    monkeypatch.setattr(pieces, "PIECE_BLOCK", 7)
    monkeypatch.setattr(chain_plan, "BATCH_ARC_CHORDS", 50)
    blocks = plan(moves, machine)
    assert blocks.ruckig_piece_count == whole.ruckig_piece_count
    assert _figures(blocks) == _figures(whole)


def test_the_arcs_span_both_sides_of_the_blocks(machine):
    """The program above does what the test needs: arcs of more chords than the test's
    BATCH_ARC_CHORDS and fewer, and far more pieces than its PIECE_BLOCK."""
    p = plan(parse_program(PROGRAM), machine)
    chords = [len(v) - 1 for v in p.vertices]
    assert max(chords) > 50 and 0 < min(c for c in chords if c > 1) < 50
    assert sum(chords) > 40 * 7


def test_pieces_between_in_blocks_is_the_whole_batch(machine, monkeypatch):
    """Pieces along sinusoids whose jerk, acceleration and speed lie either side of the
    bundled machine's limits and the feeds (a part of them fail): every phase and verdict bit
    for bit, in blocks or not."""
    rng = np.random.default_rng(7)
    n = 300
    w = 43.0 * rng.uniform(0.3, 3.0, (n, 1)) ** (1 / 3)  # A w^3 about the jerk limits [1/s]
    phase = rng.uniform(0.0, 2 * np.pi, (n, 3))
    dur = rng.uniform(2e-3, 2e-2, n)
    t = np.stack([np.zeros(n), dur], axis=1)[:, :, None]  # (n, 2 ends, 1)
    arg = w[:, None, :] * t + phase[:, None, :]
    pos = np.sin(arg).reshape(-1, 3)  # 1 mm amplitude; piece k: rows 2k -> 2k + 1
    vel = (w[:, None, :] * np.cos(arg)).reshape(-1, 3)
    acc = (-(w[:, None, :] ** 2) * np.sin(arg)).reshape(-1, 3)
    start = 2 * np.arange(n)
    feed = rng.uniform(30.0, 90.0, n)
    b = start + 1
    whole_phases = jerk3_pairs(pos[start], vel[start], acc[start], pos[b], vel[b], acc[b], dur)
    per_axis = machine.limits.per_axis()
    whole_ok = piece_limits_ok(*whole_phases[1:], dur, acc[b], *per_axis, feed)
    assert 0.2 < whole_ok.mean() < 0.8
    monkeypatch.setattr(pieces, "PIECE_BLOCK", 7)
    phases, ok = pieces.pieces_between(pos, vel, acc, start, dur, machine.limits, feed)
    assert np.array_equal(ok, whole_ok)
    for got, want in zip(phases, whole_phases, strict=True):
        assert got.tobytes() == want.tobytes()
