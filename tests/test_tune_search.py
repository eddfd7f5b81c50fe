"""The tune search (bracket + bisection) on exact error functions of the feed."""

from __future__ import annotations

import pytest

from gantry_sim.sim.circular.tune import max_feed_for_radius


def quadratic(limit: float, tol: float):
    """error(feed) = tol * (feed / limit)^2: within tolerance exactly up to ``limit``."""
    return lambda feed: (tol * (feed / limit) ** 2, feed)


@pytest.mark.parametrize("limit", [137.0, 950.0, 1000.0, 3333.0, 11800.0])
def test_finds_the_limit_within_the_resolution(limit):
    row = max_feed_for_radius(10.0, 5.0, quadratic(limit, 5.0), cap_mm_per_min=24000.0)
    assert row.limited_by == "tolerance"
    assert limit - 20.0 <= row.max_feed_mm_per_min <= limit
    assert row.max_error_um <= 5.0
    assert row.max_error_um == pytest.approx(5.0 * (row.max_feed_mm_per_min / limit) ** 2)
    # Every feed tried above the answer failed; none below it was skipped past.
    assert all(e > 5.0 for f, e in row.tried if f > row.max_feed_mm_per_min)
    assert len(row.tried) < 20


def test_cap_when_even_the_max_velocity_passes():
    row = max_feed_for_radius(10.0, 5.0, quadratic(1e6, 5.0), cap_mm_per_min=24000.0)
    assert row.limited_by == "machine_limits"
    assert row.max_feed_mm_per_min == 24000.0
    assert max(f for f, _ in row.tried) == 24000.0


def test_unreachable_when_the_minimum_feed_fails():
    row = max_feed_for_radius(10.0, 5.0, lambda feed: (6.0, feed), cap_mm_per_min=24000.0)
    assert row.limited_by == "unreachable"
    assert row.max_feed_mm_per_min is None
    assert min(f for f, _ in row.tried) == 100.0
    assert row.to_json()["max_feed_mm_per_min"] is None


def test_resolution_is_respected():
    row = max_feed_for_radius(10.0, 5.0, quadratic(2345.0, 5.0), 24000.0, resolution_mm_per_min=1.0)
    assert 2344.0 <= row.max_feed_mm_per_min <= 2345.0


def test_highest_passing_feed_when_the_error_falls_with_feed():
    # Friction-dominated: the error is largest at low feed, and passes above 3000 mm/min.
    row = max_feed_for_radius(10.0, 5.0, lambda f: (4.0 if f > 3000 else 6.0, f), 24000.0)
    assert row.limited_by == "machine_limits" and row.max_feed_mm_per_min == 24000.0
    assert len(row.tried) == 1


def test_highest_passing_feed_in_a_window():
    # Passes only between 2000 and 7000 mm/min: the answer is the window's top.
    row = max_feed_for_radius(10.0, 5.0, lambda f: (4.0 if 2000 <= f <= 7000 else 6.0, f), 24000.0)
    assert row.limited_by == "tolerance"
    assert 7000 - 20 <= row.max_feed_mm_per_min <= 7000


def test_reports_the_feed_actually_run():
    # A planner that caps the circle at 6000 mm/min: the row says so.
    row = max_feed_for_radius(10.0, 5.0, lambda f: (1.0, min(f, 6000.0)), 24000.0)
    assert row.circle_feed_mm_per_min == 6000.0
