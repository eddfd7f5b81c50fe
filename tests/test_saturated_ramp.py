"""Saturated ramps on small arcs from rest (controller/saturated_ramp.py) and their use."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.boost import FollowGeometry, follow_ok
from controller.lookahead import s_curve_time
from controller.planner import plan
from controller.saturated_ramp import saturated_profile
from tests.plan_helpers import arc, arc_deviation, assert_within_limits

AMAX, JMAX = (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5)


def _end_state(ph):
    h, s, v, a, j = ph[-1]
    return s + h * (v + h * (0.5 * a + h * j / 6.0)), v + h * (a + 0.5 * h * j), a + h * j


@pytest.mark.parametrize(
    ("radius", "v_in", "v_out"), [(1.0, 0.0, 0.0), (2.0, 3.0, 0.0), (5.0, 0.0, 2.0)]
)
def test_profile_is_continuous_ends_exactly_and_follows_the_arc(radius, v_in, v_out):
    length = 2 * math.pi * radius
    ph = saturated_profile(length, v_in, v_out, 100.0, 1 / radius, 1 / radius**2, 2500.0, 8e4)
    assert ph is not None
    h, s, v, a, j = ph.T
    assert (h > 0).all()
    nxt = np.column_stack(
        [s + h * (v + h * (0.5 * a + h * j / 6.0)), v + h * (a + 0.5 * h * j), a + h * j]
    )
    np.testing.assert_allclose(nxt[:-1], ph[1:, 1:4], atol=1e-9)  # phases join exactly
    np.testing.assert_allclose(_end_state(ph), (length, v_out, 0.0), atol=1e-9)
    assert (s[0], v[0], a[0]) == (0.0, v_in, 0.0)
    fg = FollowGeometry((0, 1, 2), 0.0, 1 / radius, 1 / radius**2, 100.0)
    assert follow_ok(ph, fg, 100.0, AMAX, JMAX)


def test_small_circle_from_rest_runs_close_to_the_bound(machine):
    """R 1 at F6000: the curvature caps the speed at (J R^2)^(1/3) = 43 mm/s; constant-limit
    profiles took 1.31 x (length / cap + the S-curve to the cap), the saturated ramps 1.12."""
    r = 1.0
    moves = [arc(1, (r, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=6000.0)]
    p = plan(moves, machine)
    cap = min(100.0, math.sqrt(2500.0 * r), (8e4 * r * r) ** (1 / 3))
    bound = 2 * math.pi * r / cap + s_curve_time(cap, 3000.0, 1e5)
    assert p.duration_s <= 1.13 * bound
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    assert arc_deviation(tr, moves[0]) <= 0.25 * machine.segmentation.chord_tolerance_mm
    np.testing.assert_allclose(tr.pos[-1], moves[0].end, atol=1e-9)
