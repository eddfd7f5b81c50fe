"""A spline whose curvature varies a lot is planned as parts of itself at their own speeds
(controller/planner/spline_split.py, knot insertion in controller/nurbs.py), and the analysis
finds the nearest point on a curve that passes close to itself twice (controller/spline_curve.py).
"""

from __future__ import annotations

import dataclasses
import itertools
import weakref
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Spline
from gantry_sim.controller.nurbs import Nurbs, linuxcnc_knots, split_bspline
from gantry_sim.controller.planner import path_stream, spline_split
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.segment import spline_segment_count
from gantry_sim.controller.planner.spline_split import split_slow_parts
from gantry_sim.sim.nearest import nearest_on_move
from tests.plan_helpers import assert_phases_within_limits, assert_within_limits

DATA = Path(__file__).resolve().parent / "data" / "rs274_splines" / "programs"

#: A cubic whose control points P0 (0, 0), P1 (3, 3), P2 (0.1, 3), P3 (3, 0) make it slow almost
#: to a stop near its middle and turn back on itself there (P2 at (0, 3): an exact cusp).
NEAR_CUSP = "G21 G17 G90 {mode}\nG0 X0 Y0\nF1200\nG5 I3 J3 P-2.9 Q3 X3 Y0\nG1 X6\nM2\n"


def _random_curve(
    rng: np.random.Generator, trial: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    p = int(rng.integers(1, 5))
    n = int(rng.integers(p + 1, p + 8))
    ctrl = rng.normal(size=(n, 3))
    w = rng.uniform(0.3, 3.0, n) if trial % 2 else np.ones(n)
    if trial % 3:
        knots = np.array(linuxcnc_knots(n, p + 1))
    else:
        inner = np.sort(rng.uniform(0.0, 1.0, n - p - 1))
        knots = np.concatenate([np.zeros(p + 1), inner, np.ones(p + 1)])
    return ctrl, w, knots, p


def test_a_cut_b_spline_is_the_same_curve_in_two_parts() -> None:
    rng = np.random.default_rng(7)
    for trial in range(200):
        ctrl, w, knots, p = _random_curve(rng, trial)
        whole = Nurbs.build(ctrl, w, knots, p)
        inner_knots = knots[(knots > whole.t_min) & (knots < whole.t_max)]
        at_knot = trial % 4 == 0 and inner_knots.size
        u = float(inner_knots[0]) if at_knot else float(rng.uniform(whole.t_min, whole.t_max))
        (qa, ta), (qb, tb) = split_bspline(np.column_stack([ctrl * w[:, None], w]), knots, p, u)
        assert np.array_equal(qa[-1], qb[0])  # one control point shared, on the curve at u
        parts = [Nurbs.build(q[:, :3] / q[:, 3:], q[:, 3], t, p) for q, t in ((qa, ta), (qb, tb))]
        assert (parts[0].t_min, parts[0].t_max) == (whole.t_min, u)
        assert (parts[1].t_min, parts[1].t_max) == (u, whole.t_max)
        at_u = whole.points(np.array([u]))[0]
        assert np.allclose(
            qa[-1, :3] / qa[-1, 3], at_u, rtol=0, atol=1e-12 * (1 + np.abs(at_u).max())
        )
        for part in parts:
            uu = np.linspace(part.t_min, part.t_max, 41)[1:-1]  # (a knot's sides may differ)
            for mine, theirs in zip(part.derivatives(uu, 3), whole.derivatives(uu, 3), strict=True):
                scale = 1.0 + np.abs(theirs).max()
                assert np.abs(mine - theirs).max() <= 1e-9 * scale, (trial, p, u)


def test_a_cut_outside_the_open_range_is_refused() -> None:
    knots = np.array(linuxcnc_knots(4, 4))
    with pytest.raises(ValueError, match="outside"):
        split_bspline(np.ones((4, 4)), knots, 3, float(knots[-1]))


def test_a_near_cusp_is_planned_in_parts_at_their_own_speeds(machine, monkeypatch) -> None:
    text = NEAR_CUSP.format(mode="G61")
    items = list(interpret_events(text))
    (spline,) = [m for m in items if isinstance(m, Spline)]
    p = plan(items, machine)
    parts = [m for m in p.path_moves if isinstance(m, Spline)]
    assert len(parts) >= 5
    assert parts[0].start == spline.start and parts[-1].end == spline.end
    assert all(a.end == b.start for a, b in itertools.pairwise(parts))
    assert {m.line for m in parts} == {spline.line}
    (index,) = [k for k, m in enumerate(p.moves) if isinstance(m, Spline)]
    mine = [k for k, m in enumerate(p.path_moves) if isinstance(m, Spline)]
    assert np.all(np.asarray(p.path_sources)[mine] == index)
    # uncut, the whole curve was followed at its slowest point's speed: 29 s instead of 0.75
    monkeypatch.setattr(path_stream, "split_slow_parts", lambda move, *_: [move])
    uncut = plan(items, machine)
    assert p.duration_s < 0.05 * uncut.duration_s
    traj = p.sample(1e-4)
    assert_within_limits(traj, machine, [m for m in items if hasattr(m, "kind")])
    assert_phases_within_limits(p, machine)
    on = traj.pos[traj.line == spline.line]
    deviation = np.linalg.norm(nearest_on_move(spline, on) - on, axis=1).max()
    assert deviation <= 0.25 * machine.segmentation.chord_tolerance_mm


def test_the_parts_of_a_g61_1_spline_meet_at_speed(machine) -> None:
    """Exact stops at the program's junctions only: the parts are one programmed move."""
    p = plan(list(interpret_events(NEAR_CUSP.format(mode="G61.1"))), machine)
    starts = np.asarray(p.move_start_s)
    lines = np.asarray(p.move_lines)
    inner = starts[1:][(lines[1:] == 4) & (lines[:-1] == 4)]
    assert inner.size >= 4
    speed = np.linalg.norm(p.curve.evaluate(inner)[1], axis=1)
    assert speed.min() > 0.0
    at_program_junction = starts[1:][(lines[1:] == 5) & (lines[:-1] == 4)]
    assert np.abs(p.curve.evaluate(at_program_junction)[1]).max() < 1e-12  # at rest


def test_a_spline_of_even_curvature_is_not_cut(machine) -> None:
    even = NEAR_CUSP.format(mode="").replace("I3 J3 P-2.9 Q3", "I0 J1.5 P0 Q1.5")  # an arch
    (s,) = [m for m in parse_program(even) if isinstance(m, Spline)]
    assert split_slow_parts(s, machine.limits, machine.segmentation) == [s]
    # nor a NURBS with a weight of 0 or less (rs274's first G5.2 point without P)
    (cusp,) = [m for m in parse_program(NEAR_CUSP.format(mode="")) if isinstance(m, Spline)]
    assert len(split_slow_parts(cusp, machine.limits, machine.segmentation)) > 1
    negative = dataclasses.replace(cusp, weights=(1.0, -0.5, 1.0, 1.0))
    assert split_slow_parts(negative, machine.limits, machine.segmentation) == [negative]


def test_the_nearest_point_of_a_curve_passing_close_to_itself_is_found() -> None:
    """LinuxCNC G5 test data: the second G5 turns back near (9, 5) and passes 56 um from a
    later part of itself; its points there were seeded on the wrong pass (gantry run reported
    a 57 um contour error and a 56 um chord error on a 0.7 um reference)."""
    text = (DATA / "gen_bezier_003.ngc").read_text()
    s = [m for m in parse_program(text) if isinstance(m, Spline)][1]
    c = s.curve
    t = np.linspace(c.nurbs.t_min, c.nurbs.t_max, 301)
    rng = np.random.default_rng(3)
    q = c.nurbs.points(t) + rng.normal(scale=1e-3, size=(len(t), 3)) * [1.0, 1.0, 0.0]
    found = np.linalg.norm(nearest_on_move(s, q) - q, axis=1)
    dense = c.nurbs.points(np.linspace(c.nurbs.t_min, c.nurbs.t_max, 200_001))
    brute = np.array([np.linalg.norm(dense - x, axis=1).min() for x in q])
    assert np.all(found <= brute + 1e-9)  # (the samples' distances bound the true one above)
    assert found.max() < 5e-3  # every point lies within 5 um of the curve


#: A random NURBS (a fuzz's find) with a loop far smaller than the chord tolerance: with parts
#: of at least 1 um, one cut around the loop found, its bounds sampled along it alone, the spike
#: of curvature there that the uncut move's samples miss, and crawled 8.2 s over 1 um (the
#: whole program 9.9 s; uncut 7.6 s).
TINY_LOOP = """G21 G17 G90
G0 X0 Y0
F3000
G5 P-14.0460 Q6.9135 X-0.8431 Y-19.3059
G5.2 X-0.8573 Y-19.3255 P0.835 L3
X-0.8417 Y-19.3261 P2.983
X-0.7970 Y-19.2565 P3.937
X-0.8600 Y-19.3175 P4.513
X-0.8025 Y-19.3271 P1
G5.3
G5 I2.2977 J18.3856 P13.5796 Q-6.0264 X-10.9884 Y-21.4121
M2
"""


def test_a_tiny_loop_does_not_make_a_part_crawl(machine, monkeypatch) -> None:
    items = list(interpret_events(TINY_LOOP))
    p = plan(items, machine)
    monkeypatch.setattr(path_stream, "split_slow_parts", lambda move, *_: [move])
    assert p.duration_s < 0.5 * plan(items, machine).duration_s  # 1.7 s against 7.6


def test_a_cut_is_kept_only_where_the_planners_own_caps_gain(machine, monkeypatch) -> None:
    (s,) = [m for m in parse_program(NEAR_CUSP.format(mode="")) if isinstance(m, Spline)]
    args = (machine.limits, machine.segmentation)
    assert len(split_slow_parts(s, *args)) > 1
    planner_cap = spline_split._planner_cap

    def slower_parts(move, *rest):  # the planner's bounds find what the profile missed
        cap = planner_cap(move, *rest)
        return cap if move is s else cap / 1000.0

    monkeypatch.setattr(spline_split, "_planner_cap", slower_parts)
    monkeypatch.setattr(spline_split, "_PARTS", weakref.WeakKeyDictionary())  # (made anew)
    assert split_slow_parts(s, *args) == [s]
    # a part the planner would refuse (a cap of 0: reversing at a cusp) keeps it whole
    monkeypatch.setattr(spline_split, "_planner_cap", lambda move, *r: 1.0 if move is s else 0.0)
    monkeypatch.setattr(spline_split, "_PARTS", weakref.WeakKeyDictionary())
    assert split_slow_parts(s, *args) == [s]


def test_a_splines_parts_are_made_once(machine, monkeypatch) -> None:
    """The planner makes its path again where blends are slower than stops: the parts are
    kept, not cut again (each time, the profile and the parts' bounds)."""
    monkeypatch.setattr(spline_split, "_PARTS", weakref.WeakKeyDictionary())
    made = []
    make = spline_split._made_parts
    monkeypatch.setattr(spline_split, "_made_parts", lambda *a: made.append(a) or make(*a))
    (s,) = [m for m in parse_program(NEAR_CUSP.format(mode="")) if isinstance(m, Spline)]
    args = (machine.limits, machine.segmentation)
    first = split_slow_parts(s, *args)
    assert len(first) > 1 and split_slow_parts(s, *args) is first and len(made) == 1
    (even,) = [
        m
        for m in parse_program(
            NEAR_CUSP.format(mode="").replace("I3 J3 P-2.9 Q3", "I0 J1.5 P0 Q1.5")
        )
        if isinstance(m, Spline)
    ]
    assert split_slow_parts(even, *args) == [even] == split_slow_parts(even, *args)
    assert len(made) == 2


def test_traverse_s_is_the_s_curve_rest_to_rest_time_on_one_stretch() -> None:
    from gantry_sim.controller.planner.limits import s_curve_time
    from gantry_sim.controller.planner.spline_split import traverse_s

    acc, jerk = 2500.0, 80000.0
    for cap in (1.0, 20.0, 200.0):
        ramp = s_curve_time(cap, acc, jerk)
        long = 10.0 * cap * ramp  # long enough to cruise
        assert traverse_s([long], [cap], acc, jerk) == pytest.approx(long / cap + ramp, rel=1e-12)
    # two stretches at one cap run as one; a slower middle one costs its ramps
    assert traverse_s([5.0, 5.0], [20.0, 20.0], acc, jerk) == pytest.approx(
        traverse_s([10.0], [20.0], acc, jerk), rel=1e-12
    )
    assert traverse_s([5.0, 0.1, 5.0], [20.0, 1.0, 20.0], acc, jerk) > 10.1 / 20.0 + 0.1


#: A G5 without I J (its start has zero speed), then two G5.1 (a fuzz's find, G61.1).
ZERO_SPEED_START = """G21 G17 G90 G61.1
G0 X0 Y0
F1500
G5 P0.0513 Q-0.1611 X-0.0562 Y0.0287
G5.1 I-0.2360 J0.1557 X-0.4842 Y0.0896
G5.1 I0.0237 J-0.0365 X-0.5086 Y0.0556
M2
"""


def test_no_part_with_a_zero_speed_end_is_one_chord_long(machine, monkeypatch) -> None:
    """The planner follows such a chord state by state and caps the junction at its other end
    by the end's unbounded curvature: cut there, the G5 ran at 0.01 mm/s through that junction
    and the program took 0.274 s against 0.264 s uncut."""
    items = list(interpret_events(ZERO_SPEED_START))
    p = plan(items, machine)
    parts = [m for m in p.path_moves if isinstance(m, Spline) and m.line == 4]
    assert len(parts) > 1
    seg = machine.segmentation
    first = spline_segment_count(
        parts[0], seg.method, seg.chord_tolerance_mm, seg.segment_length_mm
    )
    assert first >= 2
    monkeypatch.setattr(path_stream, "split_slow_parts", lambda move, *_: [move])
    assert p.duration_s < 0.9 * plan(items, machine).duration_s  # 0.221 s against 0.264
