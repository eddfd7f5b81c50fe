"""Planner: limits on the samples, exact ends, straight lines, arcs within tolerance, junctions,
travel checks and error paths. Moves are built directly (tests/plan_helpers.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.controller.moves import Linear, Rapid
from gantry_sim.controller.planner.limits import s_curve_time
from gantry_sim.controller.planner.move_geometry import FEED_MARGIN_REL, move_geometry
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import arc, arc_deviation, assert_within_limits, helix, limit_ratios

TOL = 0.001  # the bundled machine's chord tolerance [mm]


def _sample(moves, machine, **kw):
    p = plan(moves, machine, **kw)
    return p, p.sample(machine.servo.period_s)


def _speed_at(p, traj, t):
    """Path speed of the planned reference at time ``t`` exactly (not at the nearest sample)."""
    return float(np.linalg.norm(p.curve.evaluate(np.array([t]))[1]))


def test_mixed_program_keeps_every_limit_and_ends_exactly_at_rest(machine):
    moves = [
        Rapid(1, (0.0, 0.0, 0.0), (20.0, 10.0, 5.0)),
        Linear(2, (20.0, 10.0, 5.0), (20.0, 10.0, 0.0), 600.0),
        Linear(3, (20.0, 10.0, 0.0), (30.0, 0.0, 0.0), 6000.0),
        arc(4, (30.0, 0.0, 0.0), (20.0, 0.0, 0.0), math.pi, direction="cw", feed=6000.0),
        helix(5, (10.0, 0.0, 0.0), (15.0, 0.0, 0.0), dz=-2.0, turns=2, feed=4000.0),
        arc(6, (10.0, 0.0, -2.0), (10.0, 0.0, 3.0), math.pi, plane="XZ", feed=5000.0),
        arc(7, (10.0, 0.0, 8.0), (10.0, -4.0, 8.0), 1.5 * math.pi, plane="YZ", feed=5000.0),
    ]
    p, tr = _sample(moves, machine)
    assert_within_limits(tr, machine, moves)
    assert np.array_equal(tr.pos[-1], moves[-1].end)
    assert not tr.vel[-1].any() and not tr.acc[-1].any()
    assert tr.t[-1] >= p.duration_s > tr.t[-2]
    assert np.allclose(tr.t, np.arange(tr.t.size) * machine.servo.period_s)
    assert set(np.unique(tr.line)) == {m.line for m in moves}
    assert p.segment_count == sum(len(v) - 1 for v in p.vertices)
    for m, v in zip(moves, p.vertices, strict=True):
        assert tuple(v[0]) == m.start and tuple(v[-1]) == m.end
    for m in moves[3:]:
        assert arc_deviation(tr, m) <= 0.25 * TOL


@pytest.mark.parametrize("feed", [12000.0, 60000.0])
def test_feed_is_a_path_speed_limit_and_lines_are_straight(machine, feed):
    start, end = np.array([0.0, 0.0, 0.0]), np.array([100.0, 80.0, 30.0])
    moves = [Linear(1, tuple(start), tuple(end), feed)]
    _, tr = _sample(moves, machine)
    assert_within_limits(tr, machine, moves)
    d = (end - start) / np.linalg.norm(end - start)
    off = tr.pos - start
    deviation = np.linalg.norm(off - np.outer(off @ d, d), axis=1)
    assert deviation.max() < 1e-9
    # the diagonal runs at F (per-axis limits alone would allow more), or at the speed where its
    # first axis reaches its limit when F is beyond that
    axis_bound = np.min(np.asarray(machine.limits.max_velocity_mm_per_s) / np.abs(d))
    expected = min(feed / 60.0, axis_bound)
    assert np.linalg.norm(tr.vel, axis=1).max() == pytest.approx(expected, rel=1e-9)


def test_rapid_runs_at_the_axis_limit(machine):
    moves = [Rapid(1, (0.0, 0.0, 0.0), (250.0, 0.0, 0.0))]
    _, tr = _sample(moves, machine)
    assert tr.vel[:, 0].max() == pytest.approx(500.0, rel=1e-9)
    assert np.abs(tr.pos[:, 1:]).max() == 0.0
    assert limit_ratios(tr, machine)["jerk"] <= 1 + 1e-6


@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
@pytest.mark.parametrize("radius,feed", [(1.0, 3000.0), (20.0, 6000.0)])
def test_circles_within_quarter_tolerance_in_every_plane(machine, plane, radius, feed):
    start = {"XY": (radius, 0.0, 0.0), "XZ": (0.0, 0.0, radius), "YZ": (0.0, radius, 0.0)}[plane]
    a = arc(1, start, (0.0, 0.0, 0.0), 2 * math.pi, plane=plane, feed=feed)
    _, tr = _sample([a], machine)
    assert_within_limits(tr, machine, [a])
    assert arc_deviation(tr, a) <= 0.25 * TOL


@pytest.mark.parametrize("radius", [1.0, 2.0, 5.0])
def test_small_circles_from_rest_ramp_faster_than_their_worst_case_limits(machine, radius):
    """Curvature-limited circles: the block's limits hold at the cap's speed and acceleration
    at once; the profile actually used is checked point by point, so it ramps faster."""
    a = arc(1, (radius, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=6000.0)
    p, tr = _sample([a], machine)
    assert_within_limits(tr, machine, [a])
    assert arc_deviation(tr, a) <= 0.25 * TOL
    lim = move_geometry(a, machine.limits, machine.segmentation, 1.0).limits
    worst_case = a.length_mm / lim.cap_mm_per_s + s_curve_time(
        lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
    )
    assert p.duration_s < 0.92 * worst_case


def test_p_turn_helix(machine):
    h = helix(3, (4.0, 0.0, 0.0), (0.0, 0.0, 0.0), dz=-3.0, turns=3, feed=3000.0)
    p, tr = _sample([h], machine)
    assert_within_limits(tr, machine, [h])
    assert arc_deviation(tr, h) <= 0.25 * TOL
    assert tr.pos[-1, 2] == -3.0 and p.segment_count == len(p.vertices[0]) - 1


def test_tangent_arc_junctions_keep_their_speed(machine):
    r, feed = 10.0, 6000.0
    quarters = [
        arc(
            k + 1,
            (r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0.0),
            (0.0, 0.0, 0.0),
            math.pi / 2,
            feed=feed,
        )
        for k in range(4)
    ]
    p, tr = _sample(quarters, machine)
    cruise = feed / 60.0 * (1.0 - FEED_MARGIN_REL)  # arcs cruise this margin below the feed
    for t in p.move_start_s[1:]:
        assert _speed_at(p, tr, t) == pytest.approx(cruise, rel=1e-6)
    for q in quarters:
        assert arc_deviation(tr, q) <= 0.25 * TOL


def test_curvature_jumps_slow_down_without_stopping(machine):
    lead_in = Linear(1, (0.0, -10.0, 0.0), (10.0, -10.0, 0.0), 6000.0)
    half = arc(2, (10.0, -10.0, 0.0), (10.0, 0.0, 0.0), math.pi, feed=6000.0)
    s_bend = arc(3, (10.0, 10.0, 0.0), (10.0, 15.0, 0.0), math.pi, direction="cw", feed=6000.0)
    moves = [lead_in, half, s_bend]
    # G61: the jumps smoothed within a chord (G64 puts G2 transitions there: test_transitions)
    machine = machine.with_changes("path", mode="G61")
    p, tr = _sample(moves, machine)
    assert_within_limits(tr, machine, moves)
    for t in p.move_start_s[1:]:
        assert 5.0 < _speed_at(p, tr, t) < 100.0
    for m in moves[1:]:
        assert arc_deviation(tr, m) <= 0.25 * TOL


def test_corner_is_an_exact_stop_and_collinear_lines_are_not(machine):
    moves = [
        Linear(1, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0), 3000.0),
        Linear(2, (10.0, 0.0, 0.0), (20.0, 0.0, 0.0), 3000.0),
        Linear(3, (20.0, 0.0, 0.0), (20.0, 10.0, 0.0), 3000.0),
    ]
    machine = machine.with_changes("path", mode="G61")  # G61: exact path, exact stops
    p, tr = _sample(moves, machine)
    assert _speed_at(p, tr, p.move_start_s[1]) == pytest.approx(50.0, rel=1e-9)
    assert _speed_at(p, tr, p.move_start_s[2]) < 1e-6
    assert_within_limits(tr, machine, moves)


def test_feed_override_scales_the_path_speed(machine):
    moves = [Linear(1, (0.0, 0.0, 0.0), (200.0, 0.0, 0.0), 6000.0)]
    p100, _tr100 = _sample(moves, machine)
    p50, tr50 = _sample(moves, machine, feed_override_pct=50.0)
    assert np.linalg.norm(tr50.vel, axis=1).max() == pytest.approx(50.0, rel=1e-9)
    assert p50.duration_s == pytest.approx(2 * p100.duration_s, rel=0.02)
    for bad in (0.0, -5.0, math.nan):
        with pytest.raises(ConfigError, match="> 0"):
            plan(moves, machine, feed_override_pct=bad)


def test_ruckig_pieces_mode_also_keeps_the_limits(machine):
    a = arc(1, (5.0, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=3000.0)
    _p, tr = _sample([a], machine, arc_pieces="ruckig")
    # per-axis limits only: Ruckig pieces bound each axis, not the path speed (measured ~0.06 %
    # over F mid-chord), which is why "jerk3" is the default
    r = limit_ratios(tr, machine)
    assert r["vel"] <= 1 + 1e-9 and r["acc"] <= 1 + 1e-9 and r["jerk"] <= 1 + 1e-6
    assert np.array_equal(tr.pos[-1], a.end)
    with pytest.raises(ConfigError, match="jerk3"):
        plan([a], machine, arc_pieces="spline")


def test_travel_is_checked_before_planning_with_line_axis_and_range(machine):
    ok = Linear(1, (0.0, 0.0, 0.0), (100.0, 0.0, 0.0), 3000.0)
    out = Linear(2, (100.0, 0.0, 0.0), (100.0, 0.0, -80.0), 3000.0)
    with pytest.raises(PlanningError) as exc:
        plan([ok, out], machine)
    assert exc.value.line == 2 and "Z" in exc.value.message and "-75..75" in exc.value.message
    # both ends inside, but the arc's top quadrant point (Y = 201) is not
    bulge = arc(7, (-5.0, 196.0, 0.0), (0.0, 196.0, 0.0), math.pi, direction="cw")
    with pytest.raises(PlanningError) as exc:
        plan([bulge], machine)
    assert exc.value.line == 7 and "Y201.0000" in exc.value.message


def test_absurd_helix_is_refused_not_planned(machine):
    h = helix(9, (10.0, 0.0, 0.0), (0.0, 0.0, 0.0), dz=1.0, turns=1_000_000)
    with pytest.raises(PlanningError) as exc:
        plan([h], machine)
    assert exc.value.line == 9


def test_empty_and_zero_length_programs(machine):
    p = plan([], machine)
    tr = p.sample(0.001)
    assert p.duration_s == 0.0 and tr.t.size == 1 and not tr.pos.any()
    p = plan([Linear(4, (1.0, 2.0, 3.0), (1.0, 2.0, 3.0), 100.0)], machine)
    assert p.duration_s == 0.0 and np.array_equal(p.sample(0.001).pos[-1], (1.0, 2.0, 3.0))
    with pytest.raises(ConfigError):
        p.sample(0.0)


@pytest.mark.parametrize("changes", [{"method": "fixed"}, {"chord_tolerance_mm": 0.05}])
def test_other_segmentations_keep_limits_and_the_arc(machine, changes):
    # G61: the exact-path promise (0.25 x chord tolerance; G64 may use its P instead)
    m = machine.with_changes("segmentation", **changes).with_changes("path", mode="G61")
    a = arc(1, (3.0, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=4000.0)
    lead = Linear(2, (3.0, 0.0, 0.0), (3.0, 10.0, 0.0), 4000.0)  # tangent: a curvature jump
    p, tr = _sample([a, lead], m)
    assert_within_limits(tr, m, [a, lead])
    assert arc_deviation(tr, a) <= 0.25 * m.segmentation.chord_tolerance_mm
    assert _speed_at(p, tr, p.move_start_s[1]) > 1.0  # tangent: no stop
    if changes.get("method") == "fixed":
        # 18.8 mm of circle: Marlin's 72 segments per circle outnumber the 1 mm chords; + the line
        assert p.segment_count == 1 + max(math.floor(2 * math.pi * 3.0), 72)
