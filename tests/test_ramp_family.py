"""The ramps of controller/planner/ramp_family.py: sharing the up steps changes nothing.

The reference integrates each switch time on its own, every step from the start (what the
saturated ramps did before the up steps were shared): same peaks, distances and durations, and
the same failures (NaN), for switch times on and between the steps' starts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.planner.ramp_bounds import CircleLimits, NormLimits
from gantry_sim.controller.planner.ramp_family import MAX_RAMP_S, RampFamily, advance
from gantry_sim.controller.planner.saturated_ramp import SHARE, STEP_S


def _alone(v0, tau1, lim, dt):
    """Each switch time integrated from the start: up at the highest jerk the bounds leave
    until tau1 (the last step shorter), then down at the lowest until a = 0."""
    out = []
    tiny = 1e-9 * lim.jerk_min
    for tau in tau1:
        t, s, v, a, up, res = 0.0, 0.0, v0, 0.0, True, (np.nan, np.nan, np.nan)
        while t < MAX_RAMP_S:
            j_lo, j_hi, a_hi = (
                float(x[0]) for x in lim.bounds(*(np.array([y]) for y in (s, v, a)))
            )
            up = t < tau
            h = min(dt, tau - t) if up else dt
            j = min(j_hi, max(a_hi - a, 0.0) / h) if up else j_lo
            last = not up and a + j * h <= 0.0
            if last:
                h = a / max(-j, tiny)
            if j_lo > j_hi or (not up and j >= -tiny):
                break
            s1, v1, a1 = advance(h, s, v, a, j)
            if last:
                res = (v1, s1, t + h)
                break
            t, s, v, a = t + h, s1, v1, a1
        out.append(res)
    return tuple(np.array(col) for col in zip(*out, strict=True))


def _limits():
    acc, jerk = (SHARE * 3000.0, SHARE * 2500.0), (SHARE * 1e5, SHARE * 8e4)
    r = 1.0
    yield CircleLimits(math.radians(30.0), -1.0, r, 2 * math.pi * r, False, acc, jerk)
    yield CircleLimits(math.radians(30.0), -1.0, r, 2 * math.pi * r, True, acc, jerk)
    yield CircleLimits(2.9983, -1.0, 0.21, 0.27, False, (470.0, 470.0), (94000.0, 75200.0))
    yield NormLimits(1 / 5.0, 1 / 25.0, SHARE * 2500.0, SHARE * 8e4)


@pytest.mark.parametrize("lim", list(_limits()))
@pytest.mark.parametrize("v0", [0.0, 3.0])
def test_shared_up_steps_give_each_ramp_as_alone(lim, v0):
    reach = 0.08
    fam = RampFamily(v0, lim, STEP_S, reach)
    grid = fam.grid[fam.grid <= reach]
    tau = np.concatenate(
        [grid[::7], np.linspace(0.0, reach, 23), grid[5:9] + 0.37 * STEP_S, [grid[-1]]]
    )
    got = fam.ramps(tau)
    want = _alone(v0, tau, lim, STEP_S)
    assert np.isfinite(want[0]).any()  # not a comparison of failures only
    for g, w in zip(got, want, strict=True):
        np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-12, equal_nan=True)


def test_rows_are_the_ramps_phases():
    """The phases recorded for the first switch time join up and end where its ramp ends."""
    lim = next(_limits())
    fam = RampFamily(0.0, lim, STEP_S, 0.08)
    rows: list = []
    vp, d, dur = fam.ramps(np.array([0.0123]), rows)
    ph = np.array(rows)
    h, s, v, a, j = ph.T
    s1, v1, a1 = advance(h, s, v, a, j)
    np.testing.assert_allclose(s1[:-1], s[1:], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(v1[:-1], v[1:], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a1[:-1], a[1:], rtol=1e-12, atol=1e-12)
    assert (v1[-1], s1[-1]) == pytest.approx((vp[0], d[0]), rel=1e-12)
    assert abs(a1[-1]) <= 1e-9 * lim.acc_min
    assert h.sum() == pytest.approx(dur[0], rel=1e-12)
