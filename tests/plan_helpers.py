"""Helpers for the planning tests: build moves directly and measure sampled references.

Moves are built here (not by the interpreter) so the planner's tests stand alone; G-code
programs several planner tests share are kept here too.
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES

#: Hypothesis settings of the planner's property tests: seeded (every run tests the same
#: programs), no example database, no deadline (a plan takes tenths of a second), 40 programs.
PLAN_PROPERTY_SETTINGS = settings(
    derandomize=True,
    database=None,
    deadline=None,
    max_examples=40,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
#: Relative slack on the limits for rounding; jerk is a finite difference of the sampled
#: acceleration (exact for piecewise-linear acceleration, up to rounding).
REL = 1e-9
JERK_REL = 1e-6

# One loop of a rounded rectangle at F6000: line -> R1 corner arc junctions (curvature jumps).
ROUNDED_RECTANGLE = """G21 G17 G90 F6000
G0 X-4 Y-3
G1 X4
G3 X5 Y-2 R1
G1 Y2
G3 X4 Y3 R1
G1 X-4
G3 X-5 Y2 R1
G1 Y-2
G3 X-4 Y-3 R1
M2
"""


def arc(line, start, center, angle, plane="XY", direction="ccw", feed=3000.0):
    """An arc (no helix) from ``start`` about ``center`` sweeping ``angle`` [rad]."""
    i1, i2, _ = PLANE_AXES[plane]
    r = math.hypot(start[i1] - center[i1], start[i2] - center[i2])
    th = math.atan2(start[i2] - center[i2], start[i1] - center[i1])
    th += angle if direction == "ccw" else -angle
    end = list(start)
    end[i1] = center[i1] + r * math.cos(th)
    end[i2] = center[i2] + r * math.sin(th)
    if abs(angle - 2 * math.pi) < 1e-12:
        end = list(start)
    turns = max(1, math.ceil(angle / (2 * math.pi) - 1e-9))
    return Arc(
        line, tuple(start), tuple(end), feed, plane, direction, tuple(center), r, turns, angle
    )


def helix(line, start, center, dz, plane="XY", direction="ccw", turns=1, feed=3000.0):
    """A helix of ``turns`` full turns rising ``dz`` along the plane's normal."""
    n = PLANE_AXES[plane][2]
    i1, i2, _ = PLANE_AXES[plane]
    r = math.hypot(start[i1] - center[i1], start[i2] - center[i2])
    end = list(start)
    end[n] += dz
    angle = 2 * math.pi * turns
    return Arc(
        line, tuple(start), tuple(end), feed, plane, direction, tuple(center), r, turns, angle
    )


def limit_ratios(traj, machine) -> dict[str, float]:
    """Largest |v|/vmax, |a|/amax and finite-difference |j|/jmax over all axes."""
    lim = machine.limits
    jerk = np.diff(traj.acc, axis=0) / traj.period_s
    return {
        "vel": float(np.max(np.abs(traj.vel) / lim.max_velocity_mm_per_s)),
        "acc": float(np.max(np.abs(traj.acc) / lim.max_acceleration_mm_per_s2)),
        "jerk": float(np.max(np.abs(jerk) / lim.max_jerk_mm_per_s3)) if jerk.size else 0.0,
    }


def assert_within_limits(traj, machine, moves) -> None:
    """Per-axis velocity/acceleration/jerk limits, and path speed <= each feed move's F."""
    r = limit_ratios(traj, machine)
    assert r["vel"] <= 1 + REL, r
    assert r["acc"] <= 1 + REL, r
    assert r["jerk"] <= 1 + JERK_REL, r
    speed = np.linalg.norm(traj.vel, axis=1)
    for m in moves:
        feed = getattr(m, "feed_mm_per_min", None)
        sel = traj.line == m.line
        if feed is not None and sel.any():
            assert speed[sel].max() <= feed / 60.0 * (1 + REL), (
                m.line,
                speed[sel].max(),
                feed / 60,
            )


def polyline_distance(points: np.ndarray, moves) -> np.ndarray:
    """Distance [mm] of each point (k, 3) from the nearest programmed straight move."""
    a = np.array([m.start for m in moves], float)
    b = np.array([m.end for m in moves], float)
    d = b - a
    out = np.full(len(points), np.inf)
    for i in range(len(a)):
        t = np.clip((points - a[i]) @ d[i] / (d[i] @ d[i]), 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(points - (a[i] + t[:, None] * d[i]), axis=1))
    return out


def arc_deviation(traj, a: Arc) -> float:
    """Largest distance [mm] of the samples of ``a``'s line from the true arc/helix.

    Each sample is compared with the arc point at the sample's own polar angle (unwrapped along
    time): an upper bound on its distance to the curve.
    """
    i1, i2, _n = PLANE_AXES[a.plane]
    sel = traj.line == a.line
    p = traj.pos[sel]
    th = np.unwrap(np.arctan2(p[:, i2] - a.center[i2], p[:, i1] - a.center[i1]))
    th0 = math.atan2(a.start[i2] - a.center[i2], a.start[i1] - a.center[i1])
    th = th - 2 * math.pi * np.round((th[0] - th0) / (2 * math.pi))
    sigma = 1.0 if a.direction == "ccw" else -1.0
    u = np.clip(sigma * (th - th0) / a.angle, 0.0, 1.0)
    return float(np.max(np.linalg.norm(p - arc_points(a, u), axis=1)))


def program_deviation(traj, moves) -> float:
    """Largest distance [mm] of the feed samples from the programmed moves they execute (the
    contour error's reference part: sim.program_distance, with the plan's move sources), for
    G64, where a blend or a G2 transition between two moves carries the first one's line."""
    from gantry_sim.sim.program_distance import distance_to_program

    program = [m for m in moves if m.kind in ("rapid", "linear", "arc", "spline")]
    feed = np.isin(traj.line, [m.line for m in program if m.kind != "rapid"])
    window = None if traj.source is None else traj.source[feed]
    dist, _ = distance_to_program(program, traj.line[feed], traj.pos[feed], window=window)
    return float(dist.max()) if dist.size else 0.0


def plan_with_chunks(text: str):
    """The plan of the program ``text`` on the bundled machine and a copy of the chunks (the
    reference's segments, stretch by stretch) its curve was built of."""
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.controller.planner import plan
    from gantry_sim.controller.planner import segmented_curve as sc
    from gantry_sim.models import DEFAULT_MACHINE

    seen: list = []
    real = sc.CurveBuilder.extend

    def keep(self, chunks):
        seen.extend(chunks)
        return real(self, chunks)

    sc.CurveBuilder.extend = keep  # type: ignore[method-assign]
    try:
        p = plan(list(interpret_events(text)), load_machine_config(DEFAULT_MACHINE))
    finally:
        sc.CurveBuilder.extend = real  # type: ignore[method-assign]
    return p, seen


def count_fork_map_parts(monkeypatch: pytest.MonkeyPatch, module: ModuleType) -> list[int]:
    """Spy on ``module.fork_map`` (the real one still runs): the list returned gets each
    call's number of parts, so a test can tell the work was split over processes."""
    calls: list[int] = []
    real = module.fork_map

    def spy(fn, parts):  # type: ignore[no-untyped-def]
        calls.append(len(parts))
        return real(fn, parts)

    monkeypatch.setattr(module, "fork_map", spy)
    return calls


def count_fork_runs(monkeypatch: pytest.MonkeyPatch, module: ModuleType) -> list[tuple[int, bool]]:
    """Spy on ``module.fork_runs`` (the real one still runs): the list returned gets each
    call's number of runs and whether this process had a job of its own to do first."""
    calls: list[tuple[int, bool]] = []
    real = module.fork_runs

    def spy(fn, runs, processes, before=None):  # type: ignore[no-untyped-def]
        calls.append((len(runs), before is not None))
        return real(fn, runs, processes, before)

    monkeypatch.setattr(module, "fork_runs", spy)
    return calls


def assert_phases_within_limits(p, machine) -> None:
    """Every axis within its velocity, acceleration and jerk limit on every planned
    constant-jerk phase, exactly (a phase's ends and its velocity's stationary point)."""
    lim = machine.limits
    for i, (t0, _, v, a, j) in enumerate(p.curve.axes):
        dur = np.diff(np.append(t0, p.duration_s))
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.clip(np.where(j != 0, -a / j, 0.0), 0.0, dur)
        v_top = max(np.abs(v).max(), np.abs(v + tau * (a + 0.5 * tau * j)).max())
        a_top = max(np.abs(a).max(), np.abs(a + dur * j).max())
        assert v_top <= lim.max_velocity_mm_per_s[i] * (1 + REL), (i, v_top)
        assert a_top <= lim.max_acceleration_mm_per_s2[i] * (1 + REL), (i, a_top)
        assert np.abs(j).max() <= lim.max_jerk_mm_per_s3[i] * (1 + REL), i


def move_entry_starts(p) -> np.ndarray:
    """``p.move_start_s`` without the entries of stops overlapped (planner/stop_overlap.py:
    an entry of their own between two moves), for a plan without dwells: each active path
    move's start [s]."""
    return np.delete(np.asarray(p.move_start_s), p.overlap_entries())


def blending(machine):
    """``machine`` with ``[path] short_moves = "blend"``: runs of short straight moves blended
    corner by corner, as before the G64 fit (controller/planner/polyline_fit.py), for the tests
    of the blends themselves on polylines."""
    from dataclasses import replace

    return replace(machine, path=replace(machine.path, short_moves="blend"))


def blend_arcs(p) -> list:
    """The blend arcs of plan ``p``: its ``blends`` less the stops overlapped (kind
    "overlap"), which it lists there too."""
    return [b for b in p.blends if b.kind != "overlap"]
