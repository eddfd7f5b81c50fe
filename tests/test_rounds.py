"""Re-planning rounds: the round that is kept is whole and has no offending junction, however
few rounds are allowed."""

from __future__ import annotations

import importlib
import math
import random
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import plan
from gantry_sim.controller.planner.limits import BlockLimits

rounds = importlib.import_module("gantry_sim.controller.planner.rounds")
BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def _program() -> str:
    import sys

    sys.path.insert(0, str(BENCH))
    try:
        from programs import program
    finally:
        sys.path.remove(str(BENCH))
    return program("arcs", 60)  # tangent arcs with S-bends: junctions come down over rounds


@pytest.mark.parametrize("max_rounds", [0, 1, 2])
def test_the_round_kept_is_whole_and_stops_where_junctions_still_offend(
    max_rounds: int, machine, monkeypatch: pytest.MonkeyPatch
) -> None:  # type: ignore[no-untyped-def]
    # G61: in G64 its S-bends get G2 transitions (planner/transition.py), and no junction offends
    machine = machine.with_changes("path", mode="G61")
    moves = parse_program(_program())
    free = plan(moves, machine)
    calls: list[int] = []
    real = rounds._plan_round

    def spy(*args):  # type: ignore[no-untyped-def]
        out = real(*args)
        calls.append(sum(1 for c in out[0] if c.bad))
        return out

    monkeypatch.setattr(rounds, "MAX_ROUNDS", max_rounds)
    monkeypatch.setattr(rounds, "_plan_round", spy)
    cut = plan(moves, machine)
    assert len(calls) >= max_rounds + 1  # the allowed rounds, then any adding stops
    assert all(c > 0 for c in calls[:-1]) and calls[-1] == 0  # no junction kept offending
    assert cut.move_start_s.size == free.move_start_s.size
    assert np.all(np.diff(cut.move_start_s) >= 0.0) and cut.duration_s > cut.move_start_s[-1]
    tr = cut.sample(machine.servo.period_s)
    assert np.allclose(tr.pos[-1], moves[-1].end, atol=1e-9)
    assert not tr.vel[-1].any()


# Three tangent arcs cut from benchmarks/programs.py's "arcs" program (seed 1): at the first
# moving junction Ruckig stretches an end piece by less than 2 % (its closed-form piece breaks a
# limit), which used to lower that junction's speed by 0.9 for a round of its own. G64 P0.01:
# the curvature jumps at its tangent junctions may take the reference 0.01 mm off the arcs, and
# are smoothed within a chord as where no G2 transition pays (transitions are kept off here).
SLIGHTLY_STRETCHED = """G21 G17 G90 G94 G64 P0.01
G0 X29.2744 Y13.3973 Z-2
F3000
G3 X33.1196 Y16.9127 I-2.243 J6.3142
G2 X40.1502 Y24.4636 I14.9527 J-6.8737
G2 X41.5977 Y24.7517 I1.18 J-2.1485
M2
"""


def test_an_end_piece_stretched_slightly_keeps_its_junction_speed(
    machine, monkeypatch: pytest.MonkeyPatch
) -> None:  # type: ignore[no-untyped-def]
    from tests.plan_helpers import arc_deviation, assert_within_limits

    pieces = importlib.import_module("gantry_sim.controller.planner.pieces")
    transition = importlib.import_module("gantry_sim.controller.planner.transition")
    monkeypatch.setattr(transition, "GAIN", math.inf)  # no transition pays: chord smoothing
    moves = parse_program(SLIGHTLY_STRETCHED)
    kept = plan(moves, machine)
    monkeypatch.setattr(pieces, "END_STRETCH_MAX", 1.001)  # every stretch lowers the junction
    lowered = plan(moves, machine)
    assert kept.duration_s < lowered.duration_s - 1e-3
    tr = kept.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    for a in moves[1:]:
        assert arc_deviation(tr, a) <= 0.01


def test_softened_moves_drop_the_chains_and_chain_limits_that_hold_them() -> None:
    """rounds._soften lowers the moves' acceleration and jerk and forgets every cached chain
    and every memoised chain limit whose span holds one of them (they would be stale)."""
    blocks = [BlockLimits(1.0, 50.0, 1000.0, 1e5) for _ in range(8)]
    cache = {(0, 3, 1.0, 2.0): "a", (3, 5, 2.0, 0.0): "b", (5, 8, 0.0, 0.0): "c"}
    memo = {(0, 3): blocks[0], (3, 5): blocks[3], (5, 8): blocks[5], (2, 4): blocks[2]}
    rounds._soften(blocks, {3}, cache, memo)  # type: ignore[arg-type]
    assert sorted(cache) == [(0, 3, 1.0, 2.0), (5, 8, 0.0, 0.0)]
    assert sorted(memo) == [(0, 3), (5, 8)]
    assert blocks[3].acc_mm_per_s2 == rounds.SOFTEN * 1000.0
    assert blocks[3].jerk_mm_per_s3 == rounds.SOFTEN * 1e5
    assert blocks[2].acc_mm_per_s2 == 1000.0


def _engraving(seed: int, curves: int = 10, size_mm: float = 0.05) -> str:
    """``curves`` G5.1 curves at F100, each leaving along the last one's end tangent (to the
    4 decimals written), 0.025-0.075 mm long and turning by up to 2 rad: the letters of a
    small engraving. Their curvature changes severalfold along one chord."""
    r = random.Random(seed)
    x = y = 0.0
    dx, dy = 1.0, 0.0
    out = ["G21 G17 G90 G64", "G0 X0 Y0", "G1 Z-0.01 F100"]
    for _ in range(curves):
        a = r.uniform(0.2, 0.8) * size_mm
        cx, cy = x + a * dx, y + a * dy
        turn = math.atan2(dy, dx) + r.uniform(-2.0, 2.0)
        reach = r.uniform(0.5, 1.5) * size_mm
        ex, ey = cx + reach * math.cos(turn), cy + reach * math.sin(turn)
        out.append(f"G5.1 X{ex:.4f} Y{ey:.4f} I{cx - x:.4f} J{cy - y:.4f}")
        d = math.hypot(ex - cx, ey - cy)
        dx, dy, x, y = (ex - cx) / d, (ey - cy) / d, ex, ey
    return "\n".join([*out, "G0 Z1", "M2", ""])


@pytest.mark.parametrize("seed", [0, 6, 37])
def test_pieces_passing_the_feed_inside_a_curve_slow_its_profile_not_its_junctions(
    seed: int, machine, monkeypatch: pytest.MonkeyPatch
) -> None:  # type: ignore[no-untyped-def]
    """The profile cruises just below the feed between the curves' junctions, and Ruckig's
    pieces between chord vertices pass it there. Lowering the junctions' speeds left that
    cruise where it was: they were backed off for MAX_ROUNDS rounds, softened, and became
    exact stops (20-26 rounds on these programs). The chain's profile is slowed instead, and
    the reference passes every junction between the curves moving."""
    from tests.plan_helpers import assert_within_limits

    calls: list[int] = []
    real = rounds._plan_round

    def spy(*args):  # type: ignore[no-untyped-def]
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(rounds, "_plan_round", spy)
    moves = parse_program(_engraving(seed))
    p = plan(moves, machine)
    assert len(calls) <= 10
    tr = p.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    curves = [m for m in moves if m.kind == "spline"]
    speed = np.linalg.norm(tr.vel, axis=1)
    for m in curves[1:]:  # each junction between two curves: at its move's start
        k = int(np.flatnonzero(np.asarray(p.move_lines) == m.line)[0])
        at = round(float(p.move_start_s[k]) / tr.period_s)
        assert speed[at] > 0.1 * m.feed_mm_per_min / 60.0, (m.line, speed[at])
