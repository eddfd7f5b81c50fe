"""Blend or exact stop (controller/planner/blend_judge.py, prepare.slow_blends): the estimate's
ramps in closed form, and the planner's choice against both plans made whole."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import prepare
from gantry_sim.controller.planner.blend_judge import (
    blend_faster,
    blend_faster_many,
    half_move_s,
    half_move_s_many,
    ramp_s,
)
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import blend_arcs

LIMITS = BlockLimits(10.0, 50.0, 3000.0, 100000.0)  # length, cap, acceleration, jerk


def zigzag(turn_deg: float, feed: int = 3000, length_mm: float = 5.0) -> str:
    """12 moves of ``length_mm`` from the origin, turning ``turn_deg`` back and forth in XY at
    ``feed``, in G64 P0.01."""
    out, x, y = ["G21 G90 G17 G64 P0.01", f"F{feed}"], 0.0, 0.0
    for k in range(12):
        th = math.radians(turn_deg / 2) * (1 if k % 2 == 0 else -1)
        x, y = x + length_mm * math.cos(th), y + length_mm * math.sin(th)
        out.append(f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join([*out, "M2"]) + "\n"


def test_ramps_in_closed_form():
    a, j = 3000.0, 100000.0
    assert ramp_s(40.0, a, j) == pytest.approx(2.0 * math.sqrt(40.0 / j))  # a never reached
    assert ramp_s(400.0, a, j) == pytest.approx(400.0 / a + a / j)  # a reached
    edge = a * a / j  # the two shapes meet where the peak acceleration is a
    assert ramp_s(edge, a, j) == pytest.approx(edge / a + a / j)
    assert ramp_s(0.0, a, j) == 0.0


def test_a_long_move_ramps_then_cruises():
    d = 8.0
    ramp = ramp_s(50.0 - 10.0, 3000.0, 100000.0)
    ramp_mm = 0.5 * (10.0 + 50.0) * ramp
    assert half_move_s(10.0, d, LIMITS) == pytest.approx(ramp + (d - ramp_mm) / 50.0)


@given(
    v=st.floats(0.0, 50.0),
    dv=st.floats(0.0, 50.0),
    d=st.floats(1e-4, 20.0),
)
def test_entering_faster_is_never_slower(v, dv, d):
    assert half_move_s(min(v + dv, 50.0), d, LIMITS) <= half_move_s(v, d, LIMITS) * (1 + 1e-12)


def test_a_short_move_reaches_its_peak_within_its_half():
    d = 0.05  # far too short to reach the cap from 10 mm/s
    t = half_move_s(10.0, d, LIMITS)
    assert d / 50.0 < t < d / 10.0


def test_a_blend_at_rest_is_never_faster():
    blend = BlockLimits(0.1, 20.0, 3000.0, 100000.0)
    assert not blend_faster((0.0, 20.0), blend, LIMITS, LIMITS)


_speed = st.floats(0.0, 200.0) | st.sampled_from([0.0, 1e-12, 50.0])
_limits = st.builds(
    BlockLimits,
    st.floats(0.0, 20.0) | st.sampled_from([0.0, 1e-6]),
    st.floats(1e-3, 200.0) | st.sampled_from([50.0]),
    st.floats(1.0, 1e5),
    st.floats(10.0, 1e7),
)


@given(st.lists(st.tuples(_speed, st.floats(-1.0, 20.0), _limits), min_size=1, max_size=30))
def test_the_estimates_at_once_are_each_estimate_bit_for_bit(cases):
    v, d = (np.array([c[i] for c in cases]) for i in (0, 1))
    lims = [c[2] for c in cases]
    cap, acc, jerk = (
        np.array([getattr(m, f) for m in lims])
        for f in ("cap_mm_per_s", "acc_mm_per_s2", "jerk_mm_per_s3")
    )
    many = half_move_s_many(v, d, cap, acc, jerk)
    one = [half_move_s(a, b, m) for a, b, m in zip(v.tolist(), d.tolist(), lims, strict=True)]
    assert many.tolist() == one  # the same floats, not approximately


@given(st.lists(st.tuples(_speed, _speed, _limits, _limits, _limits), min_size=1, max_size=20))
def test_the_corners_judged_at_once_are_each_corner_judged_alone(corners):
    ends = [(a, b) for a, b, *_ in corners]
    sides = [[c[k] for c in corners] for k in (2, 3, 4)]
    many = blend_faster_many(ends, *sides).tolist()
    assert many == [blend_faster(e, *c[2:]) for e, c in zip(ends, corners, strict=True)]


def _forced(monkeypatch, rule):
    for mod in (prepare, sys.modules["gantry_sim.controller.planner.plan"]):
        monkeypatch.setattr(mod, "slow_blends", rule)


#: The estimate's largest miss on 63 zigzags (blend_judge.py): blended, 1.7 % slower than
#: the exact stops (2 mm moves turning 10 degrees at F3000).
WORST_MISS = 0.02


@pytest.mark.parametrize(
    ("turn_deg", "feed", "length_mm"),
    [(6, 3000, 5), (14, 3000, 5), (30, 3000, 5), (18, 6000, 5), (40, 1200, 5), (10, 3000, 2)],
)
def test_the_planner_keeps_the_faster_of_blend_and_stop(
    machine, monkeypatch, turn_deg, feed, length_mm
):
    """Planned with the judge, with every blend kept, and with every corner an exact stop: the
    judge's plan is one of the two, the faster one or within the estimate's miss of it."""
    moves = parse_program(zigzag(turn_deg, feed, length_mm))
    judged = plan(moves, machine)
    _forced(monkeypatch, lambda path, prepared, jerk: frozenset())
    blended = plan(moves, machine)
    _forced(monkeypatch, lambda path, prepared, jerk: frozenset(path.blend_junction.values()))
    stopped = plan(moves, machine)
    assert len(blended.blends) == 11 and not blend_arcs(stopped)  # its stops may overlap
    best = min(blended.duration_s, stopped.duration_s)
    assert judged.duration_s in (blended.duration_s, stopped.duration_s)
    assert judged.duration_s <= (1 + WORST_MISS) * best
    if stopped.duration_s < (1 - WORST_MISS) * blended.duration_s:
        assert not blend_arcs(judged)  # a stop clearly faster is taken
    if blended.duration_s < (1 - WORST_MISS) * stopped.duration_s:
        assert len(judged.blends) == 11  # and a blend clearly faster
