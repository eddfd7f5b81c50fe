"""Blend or exact stop (controller/planner/blend_judge.py, prepare.slow_blends): the estimate's
ramps in closed form, and the planner's choice against both plans made whole."""

from __future__ import annotations

import math
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import prepare
from gantry_sim.controller.planner.blend_judge import (
    STOP_GAIN_MIN,
    blend_faster,
    half_move_s,
    ramp_s,
)
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.plan import plan
from tests.test_corner_transitions import zigzag

LIMITS = BlockLimits(10.0, 50.0, 3000.0, 100000.0)  # length, cap, acceleration, jerk


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
    assert not blend_faster((0.0, 20.0), 20.0, 0.1, LIMITS, LIMITS)


def _forced(monkeypatch, rule):
    for mod in (prepare, sys.modules["gantry_sim.controller.planner.plan"]):
        monkeypatch.setattr(mod, "slow_blends", rule)


@pytest.mark.parametrize(
    ("turn_deg", "feed"),
    [(6, 3000), (14, 3000), (30, 3000), (18, 6000), (40, 1200), (14, 6000)],
)
def test_the_planner_keeps_the_faster_of_blend_and_stop(machine, monkeypatch, turn_deg, feed):
    """Planned with the judge, with every blend kept, and with every corner an exact stop: the
    judge's plan is the faster one, or a blend at most STOP_GAIN_MIN slower (the program asks
    for blends)."""
    moves = parse_program(zigzag(turn_deg, feed=feed))
    judged = plan(moves, machine)
    _forced(monkeypatch, lambda path, prepared: frozenset())
    blended = plan(moves, machine)
    _forced(monkeypatch, lambda path, prepared: frozenset(path.blend_junction.values()))
    stopped = plan(moves, machine)
    assert len(blended.blends) == 11 and not stopped.blends
    best = min(blended.duration_s, stopped.duration_s)
    if judged.blends:
        assert judged.duration_s == blended.duration_s
        assert judged.duration_s <= (1 + STOP_GAIN_MIN) * best
    else:
        assert judged.duration_s == stopped.duration_s == best
