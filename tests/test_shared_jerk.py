"""G64 stops whose moves share an axis: the ramps' jerk shared so that the profiles overlap
(controller/planner/shared_jerk.py), where that gains time, within every limit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.config import Limits
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner import plan, shared_jerk
from gantry_sim.controller.planner.blend_judge import ramp_s
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.shared_jerk import ramp_lost_s, ramp_reach_s
from tests.overlap_helpers import check_overlaps


def _plan(text: str, machine):
    return plan(list(interpret_events(text)), machine)


def _zigzag(length_mm: float, feed: float, turn_deg: float, moves: int = 6) -> str:
    """``moves`` lines of ``length_mm`` alternating +-turn/2 about X: stops turning by
    ``turn_deg`` between them (G64 P0.01)."""
    x = y = 0.0
    out = ["G21 G90 G17 G64 P0.01", f"F{feed:g}"]
    half = math.radians(turn_deg / 2.0)
    for k in range(moves):
        ang = half if k % 2 == 0 else -half
        x, y = x + length_mm * math.cos(ang), y + length_mm * math.sin(ang)
        out.append(f"G1 X{x:.4f} Y{y:.4f}")
    return "\n".join(out) + "\nM2\n"


def _unshared(monkeypatch: pytest.MonkeyPatch, text: str, machine):
    """The plan of ``text`` where no jerk is shared (no overlap counted on)."""
    with monkeypatch.context() as mp:
        mp.setattr(shared_jerk, "OVERLAP_TAKEN", 0.0)
        return _plan(text, machine)


@pytest.mark.parametrize(
    ("length_mm", "feed", "turn_deg"),
    [(1.0, 600, 60), (1.0, 900, 40), (2.0, 600, 45)],
)
def test_short_moves_sharing_an_axis_overlap_their_stops_and_run_shorter(
    machine, monkeypatch, length_mm, feed, turn_deg
):
    """Engraving-like corners (both moves mostly along X): every stop overlapped within the
    limits and P, and the program shorter than with its plain stops (which is how they ran
    before: the two moves' full jerks add past X's limit in any overlap). (Longer, faster
    zigzags, 5 mm at F3000, keep their stops: each stop's estimate also pays for the ramps at
    its moves' other ends, below.)"""
    text = _zigzag(length_mm, feed, turn_deg)
    shared = _plan(text, machine)
    stops = _unshared(monkeypatch, text, machine)
    assert len(stops.overlaps_s) == 0 and not stops.blends
    assert len(shared.overlaps_s) == 5
    check_overlaps(shared, machine)
    assert shared.duration_s < stops.duration_s - 5 * 0.003  # over 3 ms a corner


def test_a_lone_corner_between_short_moves_from_and_to_rest_keeps_its_stop(machine, monkeypatch):
    """Sharing lengthens each move's ramps at both ends, and here the other ends are the
    program's start and end, plain stops that nothing overlaps: shared (its estimate counting
    only the ramps at the corner), a 45 degree corner of a slicer's infill ran 0.1272 s
    against 0.1196 s stopping. Counting the far ramps too, it stops."""
    text = "G21 G90 G64 P0.01\nG0 X0 Y0\nG1 X0.562 Y0.563 F3600\nG1 X0.562 Y1.069\nM2\n"
    shared = _plan(text, machine)
    stops = _unshared(monkeypatch, text, machine)
    assert len(shared.overlaps_s) == 0
    assert shared.duration_s == stops.duration_s


@pytest.mark.parametrize(("length_mm", "feed"), [(25.0, 6000), (25.0, 20000)])
def test_long_fast_moves_keep_their_full_jerk_and_stop(machine, monkeypatch, length_mm, feed):
    """At 100-333 mm/s on 25 mm moves a ramp under half the jerk loses more than the overlap
    gains (sharing made these 0.3 % and 5 % slower): the stops stay plain, the plan is the
    unshared one."""
    text = _zigzag(length_mm, feed, 30)
    shared = _plan(text, machine)
    stops = _unshared(monkeypatch, text, machine)
    assert len(shared.overlaps_s) == 0
    assert shared.duration_s == stops.duration_s


@settings(max_examples=20, deadline=None)
@given(
    turn_deg=st.floats(5.0, 175.0),
    length_a=st.floats(0.2, 8.0),
    length_b=st.floats(0.2, 8.0),
    feed=st.integers(200, 6000),
    plane=st.sampled_from(["XY", "XZ", "YZ"]),
    tolerance=st.sampled_from([0.005, 0.01, 0.05]),
)
def test_any_corner_with_shared_jerk_keeps_every_limit_and_its_tolerance(
    machine, turn_deg, length_a, length_b, feed, plane, tolerance
):
    axes = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}[plane]
    turn = math.radians(turn_deg)
    a_end = np.zeros(3)
    a_end[axes[0]] = round(length_a, 4)
    b_end = a_end.copy()
    b_end[axes[0]] += round(length_b * math.cos(turn), 4)
    b_end[axes[1]] += round(length_b * math.sin(turn), 4)
    words = lambda p: " ".join(f"{n}{v:.4f}" for n, v in zip("XYZ", p, strict=True))  # noqa: E731
    text = f"G21 G90 G64 P{tolerance}\nG1 {words(a_end)} F{feed}\nG1 {words(b_end)}\nM2\n"
    check_overlaps(_plan(text, machine), machine, tolerance)


@pytest.mark.parametrize(
    ("v", "a", "j"),
    [(20.0, 3000.0, 100_000.0), (100.0, 3105.8, 51_763.8), (300.0, 2500.0, 80_000.0)],
)
def test_the_ramp_estimates_are_ruckigs_ramps(machine, v, a, j):
    """Against Ruckig's own profile from rest to rest over 200 mm under the same limits (one
    ramp up, a cruise, one down, symmetric): its duration less cruising the length is twice
    :func:`ramp_lost_s`, and at :func:`ramp_reach_s` of a distance its position is that
    distance (both regimes: the jerk limiting the acceleration, and reaching it)."""
    solver = RuckigSolver(Limits((500.0,) * 3, (3000.0,) * 3, (100_000.0,) * 3))
    prof = solver.profile(200.0, 0.0, 0.0, v, a, j)
    assert prof.duration_s - 200.0 / v == pytest.approx(2.0 * ramp_lost_s(v, a, j), rel=1e-9)
    rows = prof.rows
    starts = np.concatenate(([0.0], np.cumsum(rows[:, 0])))
    for d in (0.001, 0.02, 0.5, 5.0):
        t = ramp_reach_s(d, v, a, j)
        k = int(np.searchsorted(starts, t, side="right")) - 1
        dt = t - starts[k]
        _, s0, v0, a0, jk = rows[k]
        s = s0 + dt * (v0 + dt * (0.5 * a0 + dt * jk / 6.0))
        assert s == pytest.approx(d, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("length_mm", [1e-4, 0.05, 1.0, 30.0, 500.0])
@pytest.mark.parametrize(("a", "j"), [(3000.0, 100_000.0), (2500.0, 80_000.0), (500.0, 1e6)])
def test_the_top_speed_of_a_short_move_fills_it_with_its_two_ramps(length_mm, a, j):
    """A move too short for its cap reaches the speed whose two ramps (up, then down) cover
    it: v ramp_s(v) = length, on both branches of ramp_s (the acceleration reached or not);
    one long enough reaches its cap."""
    v = shared_jerk._top_speed(length_mm, 1e9, a, j)
    assert v * ramp_s(v, a, j) == pytest.approx(length_mm, rel=1e-12)
    assert shared_jerk._top_speed(length_mm, 0.5 * v, a, j) == 0.5 * v


def test_the_judge_credits_a_stop_only_where_it_will_share_and_its_far_ramps_are_paid():
    """The blend judge's credit (shared_jerk.stop_credit_s): none for a stop whose share the
    planner would not take (gain less all four ramps under MIN_GAIN_S: a Marlin part of
    three moves had its blends judged into plain stops); else the gain less each far ramp
    that nothing beyond pays for; a stop that needs no share keeps its whole gain."""
    e = shared_jerk.Estimate(5e-3, 0.5, (1.5e-3, 2e-3))
    assert shared_jerk.stop_credit_s(e, (True, True)) == 5e-3
    assert shared_jerk.stop_credit_s(e, (False, True)) == pytest.approx(3.5e-3)
    assert shared_jerk.stop_credit_s(e, (False, False)) == pytest.approx(1.5e-3)
    lean = shared_jerk.Estimate(5e-3, 0.5, (2.5e-3, 2e-3))  # 0.5 ms left: no share taken
    assert shared_jerk.stop_credit_s(lean, (True, True)) == 0.0
    plain = shared_jerk.Estimate(4e-3, 1.0, (0.0, 0.0))
    assert shared_jerk.stop_credit_s(plain, (False, False)) == 4e-3
    assert shared_jerk.stop_credit_s(shared_jerk.NO_SHARE, (True, True)) == 0.0
