"""Chains: runs of moves planned as one speed profile (controller/planner/chains.py).

The polygons here run in G64 P0.01 Q0: without Q0, G64 P0.01 also merges moves within 0.01 mm
of a line first (LinuxCNC's naive-CAM rule), and the 360 segments would become about 70.

A circle written as short blended G1 segments must run about as fast as the same circle as one
G3 (one profile, not one ramp per segment), keep every limit and the feed, and the profile cut
at the moves' ends must be the same motion as the whole.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import chains
from gantry_sim.controller.planner.chains import chain_limits, chain_spans, split_profile
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from tests.plan_helpers import assert_within_limits, blending


def _polygon(n: int, mode: str, r: float = 10.0, feed: float = 3000.0) -> str:
    pts = [
        (r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n + 1)
    ]
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in pts[1:])
    return f"G21 G90 G17 {mode}\nG0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nF{feed:g}\n{body}M2\n"


def _block(length: float, cap: float, acc: float = 1000.0, jerk: float = 5e4) -> BlockLimits:
    return BlockLimits(length, cap, acc, jerk)


def test_chain_spans_join_equal_caps_across_junctions_that_do_not_bind():
    blocks = [_block(1, 50), _block(1, 50), _block(1, 50), _block(1, 30), _block(1, 30)]
    caps = np.array([0.0, 60.0, 49.0, 30.0, np.inf, 0.0])
    # junction 2 binds (49 < 50); junction 3 joins caps 50 and 30: neither is a chain joint
    assert chain_spans(blocks, caps) == [(0, 2), (2, 3), (3, 5)]
    assert chain_spans(blocks[:1], caps[:2]) == [(0, 1)]
    assert chain_spans([], np.zeros(1)) == []


def test_a_long_chain_is_cut_where_its_part_is_two_braking_distances_long(monkeypatch):
    """Cut after SPLIT_MOVES moves once they are SPLIT_BRAKING braking distances long (v^2 /
    2a + v a / j with the part's lowest limits: 1.25 + 1 mm here), counted again from each cut;
    a junction that binds starts the count again too."""
    monkeypatch.setattr(chains, "SPLIT_MOVES", 3)
    braking = 50.0**2 / (2 * 1000.0) + 50.0 * 1000.0 / 5e4  # 2.25 mm
    short, long_ = 0.5, 2.0
    # 3 moves of 0.5 mm are 1.5 mm < 4.5 mm: the cut waits for 9 moves; then 3 of 0.5 mm and
    # one of 2 mm are 3.5 mm, 5.5 with the next; 3 of 2 mm cut at once
    blocks = [_block(short, 50)] * 12 + [_block(long_, 50)] * 7
    caps = np.full(len(blocks) + 1, np.inf)
    assert chains.SPLIT_BRAKING * braking == 4.5
    assert chain_spans(blocks, caps) == [(0, 9), (9, 14), (14, 17), (17, 19)]
    caps[5] = 10.0  # binds: from 5 on, 7 moves of 0.5 mm are 3.5 mm, 5.5 with one of 2 mm
    assert chain_spans(blocks, caps) == [(0, 5), (5, 13), (13, 16), (16, 19)]
    # the lowest acceleration of the part counts: at 400 mm/s^2 twice the braking is 7.05 mm
    slow = [_block(long_, 50)] * 2 + [_block(long_, 50, acc=400.0)] + [_block(long_, 50)] * 4
    assert chain_spans(slow, np.full(8, np.inf)) == [(0, 4), (4, 7)]
    # however short, a part is cut after SPLIT_MOVES_ALWAYS moves
    monkeypatch.setattr(chains, "SPLIT_MOVES_ALWAYS", 4)
    assert chain_spans(blocks, np.full(20, np.inf)) == [
        (0, 4),
        (4, 8),
        (8, 12),
        (12, 15),
        (15, 18),
        (18, 19),
    ]
    monkeypatch.setattr(chains, "SPLIT_MOVES", 2_000)
    assert chain_spans(blocks, np.full(len(blocks) + 1, np.inf)) == [(0, 19)]


def test_a_long_chain_cut_in_parts_is_the_same_motion_as_one_profile(machine, monkeypatch):
    """Parts long enough to reach the cap from rest and stop from it meet cruising: the plan of
    200 collinear moves cut every 40 moves (its look-ahead gives each cut the feed) is the plan
    of one chain, to rounding, within every limit."""
    text = "G21 G91 F3000\n" + "G1 X0.25\n" * 200 + "M2\n"
    moves = parse_program(text)
    monkeypatch.setattr(chains, "SPLIT_MOVES", 40)
    cut = plan(moves, machine)
    monkeypatch.setattr(chains, "SPLIT_MOVES", 10**9)
    whole = plan(moves, machine)
    assert cut.duration_s == pytest.approx(whole.duration_s, rel=1e-12, abs=0.0)
    a, b = cut.sample(1e-4), whole.sample(1e-4)
    assert a.pos.shape == b.pos.shape
    np.testing.assert_allclose(a.pos, b.pos, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-6)
    np.testing.assert_allclose(a.acc, b.acc, rtol=0, atol=1e-3)
    assert_within_limits(a, machine, moves)


def test_a_chain_of_moves_too_short_to_cruise_is_cut_all_the_same(machine, monkeypatch):
    """Parts of moves too short to reach the feed are cut after SPLIT_MOVES_ALWAYS moves: each
    cut meets at the look-ahead's speed with no tangential acceleration, a step in the ramp
    that costs time (here, six parts of 0.1 mm, all ramp: 0.0737 s against 0.0577 s; at the
    real 32,000 moves a part, one step in tens of thousands of moves), never a stop, and keeps
    every limit."""
    text = "G21 G91 F3000\n" + "G1 X0.001\n" * 600 + "M2\n"
    moves = parse_program(text)
    monkeypatch.setattr(chains, "SPLIT_MOVES", 50)
    monkeypatch.setattr(chains, "SPLIT_MOVES_ALWAYS", 100)
    cut = plan(moves, machine)
    monkeypatch.setattr(chains, "SPLIT_MOVES", 10**9)
    whole = plan(moves, machine)
    assert whole.duration_s < cut.duration_s
    tr = cut.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    speed = np.linalg.norm(tr.vel, axis=1)
    inner = tr.t[(tr.t > 0.01) & (tr.t < cut.duration_s - 0.01)]
    assert inner.size and speed[np.isin(tr.t, inner)].min() > 1.0  # [mm/s]: no stop at a cut


def test_chain_limits_are_the_lowest_of_its_moves():
    lim = chain_limits([_block(2, 50, 900, 6e4), _block(3, 50, 1200, 4e4)])
    assert lim == BlockLimits(5.0, 50.0, 900.0, 4e4)


def test_a_profile_cut_at_the_moves_ends_is_the_same_motion(machine):
    lengths = [0.7, 2.3, 0.05, 4.0, 1.1]
    solver = RuckigSolver(machine.limits)
    prof = solver.profile(sum(lengths), 3.0, 0.0, 40.0, 800.0, 3e4)
    parts, speeds, accs = split_profile(prof, lengths)
    assert len(parts) == len(lengths) and speeds.shape == accs.shape == (len(lengths) - 1,)
    assert sum(p.duration_s for p in parts) == pytest.approx(prof.duration_s, rel=1e-12)
    t_end = np.cumsum([p.duration_s for p in parts])
    for k, part in enumerate(parts):
        assert part.s[0] == 0.0
        # each part ends at its move's length, with the whole profile's speed there
        end_t = np.array([part.duration_s * (1 - 1e-12)])
        s_end, v_end, a_end = _state(part, end_t)
        assert s_end == pytest.approx(lengths[k], abs=1e-9)
        if k < len(speeds):
            assert v_end == pytest.approx(speeds[k], abs=1e-6)
            assert a_end == pytest.approx(accs[k], abs=1e-3)
            s_whole, v_whole, _ = _state(prof, np.array([t_end[k]]))
            assert s_whole == pytest.approx(sum(lengths[: k + 1]), abs=1e-9)
            assert v_whole == pytest.approx(speeds[k], abs=1e-6)


def test_a_chain_of_thousands_of_tiny_moves_splits_into_its_moves(machine):
    """5,000 moves of 1e-6 mm and some longer ones (and moves passed in no time): each part
    is its move's rows alone, the parts' durations add up to the profile's (the split took
    moves x rows masks, 3 s a chain of 12,000 tiny moves; now one slice per move)."""
    lengths = [1e-6] * 5000 + [0.5, 1e-12, 2.0] + [1e-6] * 100
    solver = RuckigSolver(machine.limits)
    prof = solver.profile(sum(lengths), 0.0, 0.0, 40.0, 800.0, 3e4)
    parts, speeds, _ = split_profile(prof, lengths)
    assert len(parts) == len(lengths) and speeds.shape == (len(lengths) - 1,)
    assert sum(p.duration_s for p in parts) == pytest.approx(prof.duration_s, rel=1e-9)
    assert all(p.s[0] == 0.0 and (p.dur >= 0).all() for p in parts)
    ends = [float(_state(p, np.array([p.duration_s * (1 - 1e-12)]))[0]) for p in parts[-105:]]
    assert ends[2] == pytest.approx(0.5, abs=1e-9) and ends[4] == pytest.approx(2.0, abs=1e-9)


def _state(prof, t):
    dur, s, v, a, j = prof.rows.T
    t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
    k = int(np.searchsorted(t0, t[0], side="right") - 1)
    h = t[0] - t0[k]
    return (
        s[k] + h * (v[k] + h * (0.5 * a[k] + h * j[k] / 6.0)),
        v[k] + h * (a[k] + 0.5 * h * j[k]),
        a[k] + h * j[k],
    )


def test_a_circle_of_360_blended_segments_runs_nearly_as_fast_as_one_arc(machine):
    circle = plan(parse_program("G21 G17 G90\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F3000\nM2"), machine)
    moves = parse_program(_polygon(360, "G64 P0.01 Q0"))
    p = plan(moves, machine)
    # one profile along the chain: before chains each segment ramped alone (1.147 x)
    assert p.duration_s <= 1.05 * circle.duration_s
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    speed = np.linalg.norm(tr.vel, axis=1)[tr.t >= p.move_start_s[1]]  # after the G0
    assert speed.max() <= 50.0 * (1 + 1e-9)
    # most of the way at the feed, not in a staircase of ramps
    assert np.mean(speed > 0.99 * 50.0) > 0.8


def test_a_chain_passes_its_inner_junctions_accelerating(machine):
    machine = blending(machine)  # the blends' chain (a fit has no blends to pass)
    moves = parse_program(_polygon(360, "G64 P0.01 Q0"))
    p = plan(moves, machine)
    t = p.move_start_s[3:40]  # junctions inside the chain of segments and blends
    _, vel, acc = p.curve.evaluate(t)
    speed = np.linalg.norm(vel, axis=1)
    along = np.einsum("ij,ij->i", vel, acc) / speed
    ramping = speed < 0.9 * 50.0
    assert ramping.sum() >= 5
    # one profile through them: the tangential acceleration does not drop to 0 at each one
    # (each move's own profile would end with a_t = 0)
    assert np.all(along[ramping] > 100.0)
