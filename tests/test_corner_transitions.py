"""G2 transitions at the ends of G64 corner blend arcs (controller/planner/corner_transitions.py):
where they go and where not, within P with the arc's deviation, curvature-continuous at both
ends, within every limit and the feed, and faster than the blend arc alone."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc, Linear, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.move_geometry import move_geometry
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import (
    assert_phases_within_limits,
    assert_within_limits,
    polyline_distance,
)

P = 0.01  # mm
WORDS = {"XY": ("G17", "X", "Y"), "XZ": ("G18", "Z", "X"), "YZ": ("G19", "Y", "Z")}


def zigzag(turn_deg: float, plane: str = "XY", mode: str = f"G64 P{P}", feed: int = 3000) -> str:
    """12 moves of 5 mm from the origin, turning ``turn_deg`` back and forth in ``plane`` at
    ``feed``."""
    g, a, b = WORDS[plane]
    out, u, w = [f"G21 G90 {g} {mode}", f"F{feed}"], 0.0, 0.0
    for k in range(12):
        th = math.radians(turn_deg / 2) * (1 if k % 2 == 0 else -1)
        u, w = u + 5 * math.cos(th), w + 5 * math.sin(th)
        out.append(f"G1 {a}{u:.4f} {b}{w:.4f}")
    return "\n".join([*out, "M2"]) + "\n"


def _kinds(p) -> str:
    return "".join(type(m).__name__[0] for m in p.path_moves)


@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
def test_small_turns_get_transitions_within_p_every_limit_and_the_feed(machine, plane):
    moves = parse_program(zigzag(5.0, plane))
    p = plan(moves, machine)
    path = list(p.path_moves)
    # every corner: line, transition, blend arc, transition, line
    assert _kinds(p) == "L" + "TATL" * 11
    n = PLANE_AXES[plane][2]
    assert all(c[n] == 0.0 for m in path if isinstance(m, Transition) for c in m.control_points)
    budget = P - 0.25 * machine.segmentation.chord_tolerance_mm
    assert len(p.blends) == 11
    assert all(b.kind == "corner" and b.transitions == 2 for b in p.blends)
    # the arc's 0.8 of the budget, then its transitions' share of the rest
    assert all(0.8 * budget < b.deviation_mm <= budget for b in p.blends)
    fine = p.sample(1e-4)
    assert polyline_distance(fine.pos, moves).max() <= P
    assert_within_limits(p.sample(machine.servo.period_s), machine, moves)
    assert_phases_within_limits(p, machine)


def test_curvature_is_continuous_where_a_corner_transition_meets_its_moves(machine):
    p = plan(parse_program(zigzag(10.0)), machine)
    lim, seg = machine.limits, machine.segmentation
    path = list(p.path_moves)
    seen = 0
    for k, m in enumerate(path):
        if not isinstance(m, Transition):
            continue
        seen += 1
        before, after = (move_geometry(x, lim, seg, 1.0) for x in (path[k - 1], path[k + 1]))
        own = move_geometry(m, lim, seg, 1.0)
        assert path[k - 1].end == m.start and m.end == path[k + 1].start  # the same points
        np.testing.assert_allclose(own.tangent_in, before.tangent_out, atol=1e-12)
        np.testing.assert_allclose(own.tangent_out, after.tangent_in, atol=1e-12)
        np.testing.assert_allclose(own.curv_in, before.curv_out, atol=1e-10)  # [1/mm]
        np.testing.assert_allclose(own.curv_out, after.curv_in, atol=1e-10)
        assert {type(path[k - 1]), type(path[k + 1])} == {Linear, Arc}
        assert np.linalg.norm(before.curv_out - after.curv_in) > 0.1  # a jump it replaces
    assert seen == 22


def test_corner_transitions_pass_the_corners_faster(machine, monkeypatch):
    """Without them a 5 degree corner's blend arc met its lines with a curvature jump smoothed
    within its first chord: passed at 27 of 50 mm/s; with them, at the feed."""
    from gantry_sim.controller.planner import blend

    moves = parse_program(zigzag(5.0))
    p = plan(moves, machine)
    t = np.arange(0.2, 0.8, 1e-4) * p.duration_s
    assert np.linalg.norm(p.curve.evaluate(t)[1], axis=1).min() >= 0.999 * 50.0
    monkeypatch.setattr(blend, "add_corner_transitions", lambda made, machine: None)
    plain = plan(moves, machine)
    assert "T" not in _kinds(plain) and len(plain.blends) == 11
    t = np.arange(0.2, 0.8, 1e-4) * plain.duration_s
    assert np.linalg.norm(plain.curve.evaluate(t)[1], axis=1).min() < 0.6 * 50.0
    assert p.duration_s < 0.85 * plain.duration_s


@pytest.mark.parametrize("mode", ["G61", "G61.1", "G64 P0"])
def test_no_corner_transition_outside_g64_with_a_tolerance(machine, mode):
    p = plan(parse_program(zigzag(5.0, mode=mode)), machine)
    assert "T" not in _kinds(p) and not p.blends


def test_blends_that_meet_get_no_transitions(machine):
    """A polygon whose blends meet is one chain of equal arcs: none at its ends either (a
    transition there lowers the limits the whole chain ramps with)."""
    n, r = 72, 10.0
    pts = [(r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n)]
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in [*pts[1:], pts[0]])
    text = f"G21 G90 G17 G64 P{P}\nG0 X{r} Y0\nF3000\n{body}M2\n"
    p = plan(parse_program(text), machine)
    assert len(p.blends) == n - 1
    assert "T" not in _kinds(p)


def test_gantry_plan_counts_the_corner_transitions(write_program, capsys, machine):
    from gantry_sim.sim.cli import main

    budget = P - 0.25 * machine.segmentation.chord_tolerance_mm
    assert main(["plan", str(write_program(zigzag(5.0)))]) == 0
    blends = json.loads(capsys.readouterr().out)["blends"]
    assert blends["count"] == 11 and blends["transitions"] == 0
    assert blends["corner_transitions"] == 22
    assert 0.8 * budget < blends["max_deviation_mm"] <= budget
