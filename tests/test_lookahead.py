"""Look-ahead: S-curve reachability, the passes, junction and arc caps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.config import Limits
from gantry_sim.controller.planner.chains import chain_limits, chain_spans
from gantry_sim.controller.planner.junctions import junction_cap
from gantry_sim.controller.planner.limits import (
    BlockLimits,
    FollowGeometry,
    arc_limits,
    arc_limits_many,
    s_curve_time,
)
from gantry_sim.controller.planner.lookahead import (
    junction_speeds_again,
    max_reachable_speed,
    plan_junction_speeds,
)
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.speedup import FOLLOW_MARGIN, follow_ok


def _distance(v0, v1, acc, jerk):
    """Distance of the fastest zero-acceleration-to-zero-acceleration speed change."""
    return 0.5 * (v0 + v1) * s_curve_time(v1 - v0, acc, jerk)


@pytest.mark.parametrize("v0", [0.0, 5.0, 100.0])
@pytest.mark.parametrize("length", [0.001, 0.1, 5.0, 500.0])
def test_reachable_speed_inverts_the_s_curve_distance(v0, length):
    acc, jerk = 2500.0, 80000.0
    v1 = max_reachable_speed(v0, length, acc, jerk)
    assert v1 > v0
    # rel 1e-6: for a tiny length at high speed, v1 - v0 (~1e-8) loses digits in the check itself
    assert _distance(v0, v1, acc, jerk) == pytest.approx(length, rel=1e-6)


def test_s_curve_time_regimes():
    acc, jerk = 1000.0, 10000.0  # a^2/j = 100 mm/s
    assert s_curve_time(400.0, acc, jerk) == pytest.approx(0.4 + 0.1)
    assert s_curve_time(25.0, acc, jerk) == pytest.approx(2 * math.sqrt(25.0 / 1e4))


def test_passes_respect_stops_caps_and_reachability():
    blocks = [
        BlockLimits(L, cap, 2000.0, 50000.0)
        for L, cap in [(1.0, 100.0), (50.0, 200.0), (0.2, 50.0), (30.0, 100.0)]
    ]
    caps = np.array([0.0, np.inf, np.inf, 30.0, 0.0])
    v = plan_junction_speeds(blocks, caps)
    assert v[0] == 0.0 and v[-1] == 0.0 and v[3] <= 30.0
    for b, blk in enumerate(blocks):
        assert max(v[b], v[b + 1]) <= blk.cap_mm_per_s
        lo, hi = sorted((v[b], v[b + 1]))
        assert _distance(lo, hi, blk.acc_mm_per_s2, blk.jerk_mm_per_s3) <= blk.length_mm
    # the long block's exit is limited by the short block after it, not only by its cap
    assert v[2] <= max_reachable_speed(v[3], 0.2, 2000.0, 50000.0) + 1e-9


def test_junction_cap_falls_with_kink_and_curvature_jump():
    args = dict(deviation_mm=1e-4, jerk_mm_per_s3=80000.0, chord_mm=0.3)
    assert junction_cap(0.0, 0.0, **args) == math.inf
    assert junction_cap(1e-3, 0.0, **args) > junction_cap(1e-2, 0.0, **args)
    assert junction_cap(0.0, 0.01, **args) > junction_cap(0.0, 1.0, **args)


@pytest.mark.parametrize("radius", [1.0, 10.0, 100.0])
def test_arc_limits_keep_axis_acceleration_and_jerk_bounds(radius):
    vmax, amax, jmax = (500.0, 400.0, 200.0), (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5)
    k, dk = 1 / radius, 1 / radius**2
    lim = arc_limits(FollowGeometry((0, 1, 2), 0.0, k, dk, 1e9), 10.0, Limits(vmax, amax, jmax))
    v, a_t, j_t = lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
    assert v <= math.sqrt(2500.0 * radius) and v <= (8e4 * radius**2) ** (1 / 3) and v <= 400.0
    assert math.hypot(a_t, v * v * k) <= 2500.0 * (1 + 1e-12)
    assert math.hypot(j_t + v**3 * dk, 3 * v * a_t * k) <= 8e4 * (1 + 1e-12)
    assert a_t > 0 and j_t > 0


@pytest.mark.parametrize("radius", [1.0, 5.0])
def test_follow_ok_checks_the_exact_following_point_by_point(radius):
    amax, jmax = (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5)
    fg = FollowGeometry((0, 1, 2), 0.0, 1 / radius, 1 / radius**2, 1e9)
    v_jerk = (FOLLOW_MARGIN * 8e4 * radius**2) ** (1 / 3)  # cruising: v^3 / R^2 is the jerk
    v_acc = math.sqrt(FOLLOW_MARGIN * 2500.0 * radius)  # v^2 / R is the acceleration
    v_top = min(v_jerk, v_acc)

    def cruise(v, a=0.0, j=0.0):
        return Profile1D(np.array([[0.01, 0.0, v, a, j]]))

    assert follow_ok(cruise(0.999 * v_top), fg, 1e9, amax, jmax)
    assert not follow_ok(cruise(1.001 * v_top), fg, 1e9, amax, jmax)
    assert not follow_ok(cruise(0.5 * v_top), fg, 0.4 * v_top, amax, jmax)  # the speed cap
    # slow, but the tangential jerk adds to the centripetal one: 3 v a_t / R
    slow = 0.5 * v_top
    a_bad = 1.01 * FOLLOW_MARGIN * 8e4 * radius / (3 * slow)
    assert a_bad < 2400.0 and not follow_ok(cruise(slow, a=a_bad), fg, 1e9, amax, jmax)
    # a phase whose end (not its start) breaks the jerk limit is caught
    ramp = Profile1D(np.array([[0.01, 0.0, 0.9 * v_jerk, 0.2 * v_jerk / 0.01, 0.0]]))
    assert not follow_ok(ramp, fg, 1e9, amax, jmax)


def test_arc_inside_a_tangent_chain_cruises_closer_to_its_curvature_cap():
    """A short arc between stops keeps jerk for its ramps (lower cap); inside a chain whose
    junctions keep their speed it has nothing to ramp, so it cruises near the curvature cap."""
    vmax, amax, jmax = (500.0, 400.0, 200.0), (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5)
    radius = 4.0
    follow = FollowGeometry((0, 1, 2), 0.0, 1 / radius, 1 / radius**2, 1e9)
    length, limits = 0.5 * math.pi * radius, Limits(vmax, amax, jmax)
    v_curv = min(math.sqrt(2500.0 * radius), (8e4 * radius**2) ** (1 / 3))
    alone = arc_limits(follow, length, limits)
    chained = arc_limits(follow, length, limits, (math.inf, math.inf))
    assert alone.cap_mm_per_s < 0.9 * v_curv
    assert chained.cap_mm_per_s >= 0.98 * v_curv


def _passes_oracle(blocks: list[BlockLimits], caps: np.ndarray) -> list[float]:
    """The look-ahead's two passes written plainly: every value computed, nothing reused."""
    v = [float(c) for c in caps]
    for b, blk in enumerate(blocks):
        v[b] = min(v[b], blk.cap_mm_per_s)
        v[b + 1] = min(v[b + 1], blk.cap_mm_per_s)
    shrink = 1.0 - 1e-9
    for b in range(len(blocks) - 1, -1, -1):
        blk = blocks[b]
        reach = max_reachable_speed(
            v[b + 1], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3
        )
        v[b] = min(v[b], reach)
    for b, blk in enumerate(blocks):
        reach = max_reachable_speed(
            v[b], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3
        )
        v[b + 1] = min(v[b + 1], reach)
    return v


_move = st.builds(
    BlockLimits,
    st.sampled_from([0.01, 0.05, 0.3, 2.0, 10.0]),
    st.sampled_from([20.0, 50.0, 100.0]),
    st.sampled_from([1000.0, 3000.0]),
    st.sampled_from([5e4, 1e5]),
)
# one round's change: (junction index (taken modulo the junctions), what happens to it)
_change = st.tuples(
    st.integers(0, 10_000), st.sampled_from(["back off", "stop", "raise", "soften"])
)


@given(
    moves=st.lists(_move, min_size=0, max_size=30),
    caps=st.lists(st.sampled_from([0.0, 5.0, 30.0, 80.0, math.inf]), min_size=31, max_size=31),
    rounds=st.lists(st.lists(_change, max_size=4), min_size=1, max_size=6),
)
@settings(max_examples=300, deadline=None)
def test_passes_again_are_the_passes_of_every_round(moves, caps, rounds):
    """The planner's rounds lower junction caps (chains split where a cap falls below theirs),
    replay a window's first speed (raised or lowered) and soften moves; the look-ahead
    computed again from the round before's gives every round the passes' numbers, bit for
    bit."""
    n = len(moves)
    junction_caps = np.array(caps[: n + 1])
    junction_caps[0] = junction_caps[-1] = 0.0
    memo: dict = {}
    chain_memo: dict[tuple[int, int], BlockLimits] = {}
    before = None
    for changes in [[], *rounds]:
        for at, what in changes:
            b = at % (n + 1)
            if what == "back off":
                junction_caps[b] = 0.9 * min(junction_caps[b], 100.0)
            elif what == "stop":
                junction_caps[b] = 0.0
            elif what == "raise":
                junction_caps[0] = junction_caps[0] + 7.0
            elif n:  # soften: the move is a new object, as the rounds make it
                m = min(b, n - 1)
                lim = moves[m]
                moves[m] = BlockLimits(
                    lim.length_mm,
                    lim.cap_mm_per_s,
                    0.7 * lim.acc_mm_per_s2,
                    0.7 * lim.jerk_mm_per_s3,
                )
                chain_memo = {s: c for s, c in chain_memo.items() if not s[0] <= m < s[1]}
        spans = chain_spans(moves, junction_caps)
        chained = [chain_memo.setdefault(s, chain_limits(moves[s[0] : s[1]])) for s in spans]
        ends = np.array([first for first, _ in spans] + [n])
        got = junction_speeds_again(chained, junction_caps[ends], ends, memo, before)
        assert got.speeds == _passes_oracle(chained, junction_caps[ends])
        before = got


@pytest.mark.parametrize("sin_pitch", [0.0, 0.3, 0.54])
@pytest.mark.parametrize("normal_curvature", [0.0, 2.3e-3, 0.5])
@pytest.mark.parametrize("plane_share", [None, math.sqrt(1 - 0.1**2)])
def test_arc_limits_keep_every_axis_bound_on_helices_and_spirals(
    sin_pitch, normal_curvature, plane_share
):
    # on a machine whose slow Z bounds them: the normal axis takes a_t sin(pitch) + v^2 k_n of
    # acceleration and j_t sin(pitch) of jerk (a helical spiral's pitch changes with its
    # radius: k_n), the plane's axes the terms of the module docstring, and the in-plane share
    # of the speed is at most plane_share (a spiral's, where its pitch is least; Y's speed
    # bounds the wider arc); batched and alone, the same limits
    limits = Limits((500.0, 30.0, 50.0), (3000.0, 2500.0, 50.0), (1e5, 8e4, 3000.0))
    follows = [
        FollowGeometry((0, 1, 2), sin_pitch, k, 1.1 * k * k, 60.0, normal_curvature, plane_share)
        for k in (0.5, 4.0)
    ]
    lengths, ends = [0.09, 3.0], [(0.0, 0.0), (5.0, 20.0)]
    batch = arc_limits_many(follows, lengths, limits, ends)
    share = plane_share if plane_share is not None else math.sqrt(1 - sin_pitch**2)
    room = 1 + 1e-12
    for f, length, e, b in zip(follows, lengths, ends, batch, strict=True):
        assert arc_limits(f, length, limits, e) == b
        v, a_t, j_t = b.cap_mm_per_s, b.acc_mm_per_s2, b.jerk_mm_per_s3
        k, dk = f.curvature_per_mm, f.dcurv_per_mm2
        assert a_t > 0 and j_t > 0 and v <= 60.0
        assert v * share <= 30.0 * room and v * sin_pitch <= 50.0 * room
        assert math.hypot(a_t, v * v * k) <= 2500.0 * room
        assert math.hypot(j_t + v**3 * dk, 3 * v * a_t * k) <= 8e4 * room
        assert a_t * sin_pitch + v * v * normal_curvature * (sin_pitch > 0) <= 50.0 * room
        assert j_t * sin_pitch <= 3000.0 * room


@pytest.mark.parametrize("dcurv", [0.0, 2.0])
def test_a_straight_arc_gets_the_plane_s_acceleration(dcurv):
    # no curvature (a degenerate arc): no cap from it, a_t the plane's, and the first margin
    # wherever no rate of curvature bounds the speed either
    limits = Limits((500.0, 400.0, 200.0), (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5))
    b = arc_limits(FollowGeometry((0, 1, 2), 0.0, 0.0, dcurv, 60.0), 3.0, limits)
    assert b.acc_mm_per_s2 == 2500.0
    if dcurv == 0.0:
        assert b.cap_mm_per_s == 60.0 and b.jerk_mm_per_s3 == 8e4
    else:
        assert b.cap_mm_per_s <= (0.99 * 8e4 / dcurv) ** (1 / 3)
        assert b.jerk_mm_per_s3 == pytest.approx(8e4 - b.cap_mm_per_s**3 * dcurv, rel=1e-12)
