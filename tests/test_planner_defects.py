"""Regression tests for defects found on fragments of real programs (issue 12), each planned
alone on the bundled machine: the reference stays within 0.25 x the chord tolerance of the
arc or helix, keeps every limit and never exceeds the feed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import arc_deviation, assert_within_limits, program_deviation

TOL = 0.001  # the bundled machine's chord tolerance [mm]

G18_HELIX = (
    "G21 G90\nG0 X19.730433 Y12.330127 Z-1.007564\nF{feed}\n"
    "G18 G2 I-4.5 K-7.794229 X15.230433 Y15.330127 Z-17.801792\nM2"
)
S_CHAIN = (
    "G21 G17 G90 G94 F3000\nG0 X-126.3893 Y27.1762 Z-2\n"
    "G2 X-121.928 Y22.9388 I-2.2137 J-6.7979\n"
    "G3 X-119.5064 Y18.8541 I13.1901 J5.0597\n"
    "G3 X-112.7401 Y14.6072 I10.0982 J8.5753\nM2"
)
NEAR_FULL_CIRCLE = "G21 G90 G17\nG0 X0 Y-3.7663\nG2 X0.3626 Y-3.7488 I0 J3.7663 F3679\nM2"


def _check(text, machine, bound_mm=0.25 * TOL):
    moves = parse_program(text)
    p = plan(moves, machine)
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    if bound_mm > 0.25 * TOL:  # G64: a G2 transition takes the reference from one arc to the next
        assert program_deviation(tr, moves) <= bound_mm
    for m in moves:
        if isinstance(m, Arc) and bound_mm <= 0.25 * TOL:
            assert arc_deviation(tr, m) <= bound_mm, m.line
    assert not tr.vel[-1].any()
    return p, tr


@pytest.mark.parametrize("feed", [100, 120, 130, 400])
def test_slow_g18_helix_stays_on_the_helix(machine, feed):
    # was 0.93 mm off at F130 (1.19 mm at F120): closed-form pieces overshot the feed by 6e-8,
    # went to Ruckig, whose minimum-duration pieces swung the helix axis by +-26 mm/s
    p, tr = _check(G18_HELIX.format(feed=feed), machine)
    assert p.ruckig_piece_count == 0
    helix_axis = np.abs(tr.vel[tr.line == 4, 1])
    assert helix_axis.max() <= feed / 60.0


def test_s_chain_middle_arc_stays_on_the_arc(machine):
    # the middle arc left the path by 546 um (an unchecked Ruckig piece inside the arc)
    g61 = _check("G61\n" + S_CHAIN, machine)[0]
    g64 = _check("G64 P0.01\n" + S_CHAIN, machine, bound_mm=0.01)[0]
    assert g64.duration_s <= g61.duration_s  # G64's tolerance is the junction budget


def test_near_full_circle_from_rest_keeps_the_feed(machine):
    _check(NEAR_FULL_CIRCLE, machine)


#: From LinuxCNC's trajectory-planner test 51MeanderAve.ngc (a plasma post), which LinuxCNC
#: runs: G64 P0.01 blends leave 1.8 nm of the 0.012 mm G1 on line 5 between two blends, and
#: the look-ahead's speeds at its ends differ by 3e-11 of 52 mm/s. No profile changes speed
#: over 1.8 nm with zero acceleration at both ends; Ruckig's went back 52 mm/s (exit 2, "the
#: speed profile would reverse along the path").
MEANDER = (
    "G21 G90\nG64 P0.01\nG0 X102.882 Y25.888\nG02 F5000 X107.812 Y26.233 I3.440 J-13.762\n"
    "G01 X108.772 Y26.150\nX108.784 Y26.149\nX111.012 Y25.901\nM2\n"
)


def test_nanometres_left_between_two_blends_are_a_cruise(machine):  # type: ignore[no-untyped-def]
    moves = parse_program(MEANDER)
    p = plan(moves, machine)
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    assert np.allclose(tr.pos[-1], moves[-1].end, atol=1e-9)
    assert p.duration_s < 1.0  # 3.2 mm at 83 mm/s: no detour


def _arc_sliver_arc(sliver_mm: float) -> str:
    """G61: a CCW arc of R2, a straight move of ``sliver_mm`` along its end tangent, a CCW arc of
    R5 tangent to it, and a line out: the two tangent junctions keep their speed, each capped by
    its own curvature jump, so the sliver's end speeds differ by what its length allows."""
    c2 = (-sliver_mm, 2.0 - 5.0)
    end = (c2[0] + 5.0 * math.cos(math.radians(150)), c2[1] + 5.0 * math.sin(math.radians(150)))
    return (
        "G21 G90 G17 G61\nG0 X2 Y-3\nG1 X2 Y0 F6000\nG3 X0 Y2 I-2 J0\n"
        f"G1 X{-sliver_mm:.12f} Y2\nG3 X{end[0]:.12f} Y{end[1]:.12f} I0 J-5\n"
        f"G1 X{end[0] - 3:.12f} Y{end[1] - 3:.12f}\nM2\n"
    )


@pytest.mark.parametrize("sliver_mm", [1e-6, 1e-5])
def test_a_sliver_between_two_tangent_arcs_is_passed_not_detoured(machine, sliver_mm):
    """Ruckig's profile from one speed to another 1e-10 of it away over a micrometre has to go
    back along the path (77 ms, 8 um off the program here; 0.1 mm on a Marlin benchy, where an
    arc corner's blend and a line's left 0.1 nm of the line between them). The check for a
    profile going backwards read the speed at each phase's start only; Ruckig's passed 0 there
    and went to -15 mm/s inside a phase. The sliver is now a cruise at one speed."""
    moves = parse_program(_arc_sliver_arc(sliver_mm))
    p = plan(moves, machine)
    tr = p.sample(1e-4)
    assert_within_limits(tr, machine, moves)
    assert program_deviation(tr, p.moves) <= 0.25 * TOL
    # 0.1 nm of line: its end speeds were equal to the last digit, and Ruckig's cruise fitted
    thinner = plan(parse_program(_arc_sliver_arc(1e-7)), machine)
    assert p.duration_s == pytest.approx(thinner.duration_s, abs=1e-3)  # 70 ms longer before


def test_the_lowest_speed_of_a_profile_is_found_inside_its_phases():
    from gantry_sim.controller.planner.ruckig_solver import lowest_speed

    # one phase from 1 mm/s decelerating at 1,600 mm/s^2 with jerk 85,713 mm/s^3 for 37.5 ms:
    # both ends above 0, the turn at t = a / j = 18.7 ms at 1 - 1600^2 / (2 * 85713) < 0
    rows = np.array([[0.0375, 0.0, 1.0, -1600.0, 85713.0]])
    v_end = 1.0 + 0.0375 * (-1600.0 + 0.5 * 0.0375 * 85713.0)
    assert v_end > 0.0
    assert lowest_speed(rows) == pytest.approx(1.0 - 1600.0**2 / (2 * 85713.0), rel=1e-12)
    # a phase whose acceleration does not pass zero inside it: its lower end
    rows = np.array([[0.01, 0.0, 10.0, -100.0, -1000.0]])
    assert lowest_speed(rows) == pytest.approx(10.0 - 1.0 - 0.05, rel=1e-12)


#: A PrusaSlicer perimeter (lines 706-712 of lhalb/evt_v4.gcode, extrusion words dropped) in
#: Marlin: its blend arcs meet, and the last chord of one was a 3-DoF Ruckig piece of 83 ms
#: whose axes switch jerk at different times: a 1 ms bulge of the path speed 0.21 % above the
#: feed at its start, between the 25 samples that checked it.
PERIMETER = (
    "G21\nG90\nG0 X37.214 Y-92.759 Z1.3\nG1 F360\nG1 X38.667 Y-92.257\nG1 X40.339 Y-91.679\n"
    "G1 X40.803 Y-91.501\nG1 X42.806 Y-90.733\nG1 X43.314 Y-90.538\nG1 X44.866 Y-89.882\n"
)


#: Three quadratic G5.1 splines of LinuxCNC's nc_files/systems.ngc (lines 663-665, truetype-tracer
#: text; scaled to mm): 0.03 mm long each at F100, turning sharply. Their closed-form pieces
#: bulged 4.9e-6 of the feed above it between the five points per phase that checked them.
SHARP_SPLINES = (
    "G21 G90 G17\nG0 X1.65964 Y-0.00636 Z-0.01\nG1 F100\nG5.1 X1.61284 Y0.00444 I-0.02904 J0\n"
    "G5.1 X1.5952 Y0.0324 I-0.01764 J0.0108\nG5.1 X1.60324 Y0.05256 I0 J0.01236\nM2\n"
)


@pytest.mark.parametrize(
    ("program", "dialect", "first_feed_line", "feed_mm_per_min", "period_s"),
    [
        (PERIMETER, "marlin", 5, 360.0, 1e-5),  # a bulge of 1 ms
        (SHARP_SPLINES, "linuxcnc", 4, 100.0, 1e-6),  # a bulge of tens of microseconds
    ],
    ids=["ruckig-piece", "closed-form-pieces"],
)
def test_a_speed_bulge_between_the_checked_points_keeps_the_feed(  # type: ignore[no-untyped-def]
    machine, program, dialect, first_feed_line, feed_mm_per_min, period_s
):
    from gantry_sim.controller.gcode.dialects import with_segmentation_default
    from gantry_sim.controller.gcode.interpreter import interpret_events

    m = with_segmentation_default(machine, dialect)
    moves = list(interpret_events(program, dialect))
    p = plan(moves, m)
    tr = p.sample(period_s)  # fine enough to see the bulge
    speed = np.linalg.norm(tr.vel[tr.line >= first_feed_line], axis=1)
    assert speed.max() <= feed_mm_per_min / 60.0 * (1 + 1e-9)
    assert_within_limits(p.sample(m.servo.period_s), m, moves)


def test_a_block_leaving_its_cap_for_its_lowest_reachable_speed_does_not_reverse(machine):
    """A G2 transition of 100,000 generated arcs (benchmarks/programs.py, line 26100): 1.6 mm
    from its cap down to the lowest speed its length allows at 155 mm/s^2; Ruckig took the
    start at its velocity limit for one beyond it and went back 46 mm/s (planning failed)."""
    from gantry_sim.controller.moves import Linear
    from gantry_sim.controller.planner.chain_prep import _path_profile
    from gantry_sim.controller.planner.limits import BlockLimits
    from gantry_sim.controller.planner.ruckig_solver import RuckigSolver

    cap = 49.99749961859769
    lim = BlockLimits(1.5972088800825188, cap, 155.2656895382775, 9982.510318676505)
    move = Linear(1, (0.0, 0.0, 0.0), (1.6, 0.0, 0.0), 3000.0)
    prof = _path_profile(RuckigSolver(machine.limits), move, lim, cap, 47.31569209074107)
    dur, s, v, a, j = prof.rows.T
    v_end = v + dur * (a + 0.5 * dur * j)
    assert v.min() >= 47.3 and v_end.min() >= 47.3  # no reversal, no dip below the end speed
    assert max(v.max(), v_end.max()) <= cap * (1 + 1e-12)
    assert s[-1] + dur[-1] * (v[-1] + dur[-1] * (0.5 * a[-1] + dur[-1] * j[-1] / 6)) == (
        pytest.approx(lim.length_mm, rel=1e-9)
    )


#: The end of a Fusion 360 helical bore (grbl post, R 0.25 mm): its last arc ends 0.14 um off
#: the start radius, a helical spiral whose pitch changes along it. On a machine whose slow Z
#: (50 mm/s^2) bounds the helix' tangential acceleration, Z also takes v^2 |h''| and a vertex
#: passed Z's limit by 2e-4; on one whose Y (1.3 mm/s) bounds its speed, the tangent's in-plane
#: share is largest at the larger radius, and a vertex passed Y's speed by 1e-6. Ruckig refused
#: both pieces: internal errors (exit 3).
SPIRAL_BORE_END = (
    "G21 G90 G17\nG0 X134.56 Y62 Z-12.75\nG1 F250\n"
    "G3 X134.06 Y62 Z-13.25 I-0.25 J0\nX134.072 Y61.923 Z-13.3 I0.25 J0\nM30\n"
)
SPIRAL_MACHINES = {
    "slow Z, Z jerk 3000": (
        "max_velocity_mm_per_s = [500.0, 400.0, 50.0]\n"
        "max_acceleration_mm_per_s2 = [3000.0, 2500.0, 50.0]\n"
        "max_jerk_mm_per_s3 = [100000.0, 80000.0, 3000.0]\n"
    ),
    "slow Z, Z jerk 20000": (
        "max_velocity_mm_per_s = [500.0, 400.0, 50.0]\n"
        "max_acceleration_mm_per_s2 = [3000.0, 2500.0, 50.0]\n"
        "max_jerk_mm_per_s3 = [100000.0, 80000.0, 20000.0]\n"
    ),
    "Y slower than the feed": (
        "max_velocity_mm_per_s = [350.3519287805477, 1.3005230983463, 274.6005247277922]\n"
        "max_acceleration_mm_per_s2 = [635429.9700252097, 23.82218826656252, 15318.0886631587]\n"
        "max_jerk_mm_per_s3 = [13277379.649239589, 36497.93780204063, 63605.17734285773]\n"
    ),
}


@pytest.mark.parametrize("name", sorted(SPIRAL_MACHINES))
def test_a_helical_spiral_keeps_the_axis_limits_that_bound_it(name, tmp_path):
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.dialects import with_segmentation_default
    from gantry_sim.controller.gcode.interpreter import interpret_events
    from gantry_sim.models import DEFAULT_MACHINE
    from tests.plan_helpers import assert_phases_within_limits

    file = tmp_path / "machine.toml"
    file.write_text("[limits]\n" + SPIRAL_MACHINES[name])
    machine = with_segmentation_default(load_machine_config(DEFAULT_MACHINE, file), "grbl")
    items = list(interpret_events(SPIRAL_BORE_END, "grbl"))
    p = plan(items, machine)
    assert_phases_within_limits(p, machine)
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, [m for m in items if isinstance(m, Arc)])


def test_an_arc_that_crawls_from_rest_keeps_its_feed(machine):
    """A grbl arc of R 0.7 um (grbl takes what LinuxCNC refuses as zero-radius) at 0.027 mm/min
    from rest (G93 F276.5 on 0.1 um, found by a fuzz): its ramp to the feed ends within a
    thousandth of its one chord, and the profile's switch there was dropped as too near the
    chord's end, so one piece over the ramp and the cruise passed the feed by 35 %. Next to a
    stop every switch is a vertex now."""
    text = (
        "G21 G90 G17\nG0 X4.0381 Y-3.1831 Z-2.4917\nG93\n"
        "G1 X4.0143 Y-3.1866 Z-2.4917 F298.589\n"
        "G3 X4.0142 Y-3.1866 Z-2.4917 I0.0001 J-0.0007 F276.507\n"
        "G3 X3.9804 Y-3.2477 Z-2.4917 I-0.0092 J-0.0348 F26.570\nM2\n"
    )
    p = plan(list(interpret_events(text, "grbl")), machine)
    assert_within_limits(p.sample(1e-4), machine, p.moves)
