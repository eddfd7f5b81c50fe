"""Short arcs from rest under the tangent's per-axis limits
(controller/planner/tangent_limits.py), and when the saturated ramps are built instead.

An arc-fitted 3D print (Bambu Studio, arc fitting on) turns its infill with thousands of short
arcs (a few degrees of a few mm of radius) between straight lines, each passed from near rest.
The saturated ramps took 0.6-2 s to build for each, so 3,000 lines of such a print planned in
about 5 minutes; their gain over the tangent's profile there was 2 ms of a 228 s cycle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner import speedup
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.tangent_limits import follows_per_axis, tangent_profile
from tests.plan_helpers import arc_deviation, assert_within_limits

#: Infill U-turns as an arc-fitting slicer writes them (relative extrusion, 4 decimals of I J).
INFILL_TURNS = """G21
G90
M83
G1 X168.076 Y150.826 Z.2 F6300
G1 X167.922 Y150.347 E.01878
G3 X167.896 Y150.082 I.623 J-.194 E.01003
G1 X142.906 Y125.092 E1.31915
G2 X142.134 Y124.968 I-1.713 J8.218 E.02917
G1 X174.257 Y157.09 E1.69563
G3 X173.877 Y157.358 I-2.169 J-2.67 E.01736
G1 X142.983 Y126.465 E1.63077
G3 X142.908 Y127.037 I-1.546 J.088 E.02168
G1 X173.477 Y157.606 E1.61364
"""


def _ideal_axes(profile, frame, n: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis acceleration and jerk [mm/s^2], [mm/s^3] of following the circle exactly with
    the profile, on a fine time grid (independent of the 9-point check)."""
    t = np.linspace(0.0, profile.duration_s, n)
    ends = np.concatenate(([0.0], np.cumsum(profile.dur)))
    k = np.clip(np.searchsorted(ends, t, side="right") - 1, 0, profile.dur.size - 1)
    tau = t - ends[k]
    s0, v0, a0, j = profile.s[k], profile.v[k], profile.a[k], profile.j[k]
    s = s0 + tau * (v0 + tau * (0.5 * a0 + tau * j / 6.0))
    v = v0 + tau * (a0 + 0.5 * tau * j)
    a = a0 + tau * j
    r, sg = frame.r0_mm, frame.sigma
    th = frame.theta0_rad + sg * s / r
    tang = np.stack([-sg * np.sin(th), sg * np.cos(th)])
    norm = np.stack([-np.cos(th), -np.sin(th)])
    acc = a * tang + v * v / r * norm
    jerk = (j - v**3 / r**2) * tang + 3.0 * v * a / r * norm
    return np.abs(acc).max(axis=1), np.abs(jerk).max(axis=1)


@pytest.mark.parametrize(
    ("radius", "theta0_deg", "sweep_deg", "word", "short"),
    [
        (8.4, 10.0, 5.3, "G2", True),
        (3.4, 230.0, 7.7, "G3", True),
        (1.0, 80.0, 40.0, "G3", True),
        (0.6, 0.0, 90.0, "G2", False),  # 3 v a / R takes most of the jerk: lowered to fit
    ],
)
def test_the_tangent_profile_keeps_each_axis_limit_along_the_arc(
    radius, theta0_deg, sweep_deg, word, short, machine
) -> None:  # type: ignore[no-untyped-def]
    th0, sweep = math.radians(theta0_deg), math.radians(sweep_deg)
    sg = 1.0 if word == "G3" else -1.0
    x0, y0 = radius * math.cos(th0), radius * math.sin(th0)
    x1, y1 = radius * math.cos(th0 + sg * sweep), radius * math.sin(th0 + sg * sweep)
    text = f"G21 G90 G17\nG0 X{x0:.6f} Y{y0:.6f}\n{word} X{x1:.6f} Y{y1:.6f} I{-x0:.6f} J{-y0:.6f} F6000\nM2\n"
    move = next(m for m in parse_program(text) if isinstance(m, Arc))
    frame = arc_frame(move)
    amax, jmax = machine.limits.max_acceleration_mm_per_s2, machine.limits.max_jerk_mm_per_s3
    acc, jerk = (amax[0], amax[1]), (jmax[0], jmax[1])
    prof = tangent_profile(
        frame, move.length_mm, 0.0, 0.0, 100.0, acc, jerk, RuckigSolver(machine.limits)
    )
    assert prof is not None
    assert follows_per_axis(prof, frame, acc, jerk)
    h, s, v, a, j = prof.rows.T
    end = s[-1] + h[-1] * (v[-1] + h[-1] * (0.5 * a[-1] + h[-1] * j[-1] / 6.0))
    assert end == pytest.approx(move.length_mm, abs=1e-9)
    got_acc, got_jerk = _ideal_axes(prof, frame)
    assert np.all(got_acc <= np.array(acc)) and np.all(got_jerk <= np.array(jerk)), (
        got_acc,
        got_jerk,
    )
    if not short:
        return
    # faster than the orientation-free limits would allow (the tangent is near one axis)
    slow = RuckigSolver(machine.limits).profile(
        move.length_mm, 0.0, 0.0, 100.0, 0.94 * min(acc), 0.94 * min(jerk)
    )
    assert prof.duration_s < slow.duration_s


@pytest.fixture
def saturated_builds(monkeypatch) -> list[float]:  # type: ignore[no-untyped-def]
    """The lengths [mm] of the arcs the planner builds saturated ramps for, in order."""
    built: list[float] = []
    real = speedup.saturated_profile

    def counted(length, *args):  # type: ignore[no-untyped-def]
        built.append(length)
        return real(length, *args)

    monkeypatch.setattr(speedup, "saturated_profile", counted)
    return built


def test_infill_turns_plan_within_limits_without_building_saturated_ramps(
    machine, saturated_builds
) -> None:  # type: ignore[no-untyped-def]
    items = list(interpret_events(INFILL_TURNS, "marlin"))
    p = plan(items, machine)
    assert (
        saturated_builds == []
    )  # each turn peaks far below its curvature cap: the tangent's is enough
    tr = p.sample(machine.servo.period_s)
    moves = [m for m in items if hasattr(m, "end")]
    assert_within_limits(tr, machine, moves)
    for m in items:
        if isinstance(m, Arc):
            assert arc_deviation(tr, m) <= 0.25 * machine.segmentation.chord_tolerance_mm, m.line


def test_a_full_circle_from_rest_still_builds_the_saturated_ramps(
    machine, saturated_builds
) -> None:  # type: ignore[no-untyped-def]
    plan(parse_program("G21 G90 G17\nG0 X1 Y0\nG3 I-1 J0 F3000\nM2\n"), machine)
    assert saturated_builds and saturated_builds[0] == pytest.approx(2 * math.pi)
