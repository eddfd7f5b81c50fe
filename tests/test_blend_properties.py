"""G64 blending on generated CAM polylines: the reference stays within P of the program (P + Q
where the naive-CAM merge moved it first, as on LinuxCNC) and every limit holds, whether
the blends meet (regular polygons) or not (uneven segments).

The polylines are arcs of a circle written as G1 chords, as CAM posts and slicers write them, in
each principal plane, with chord lengths either equal or drawn at random; P, F and the naive-CAM
Q (P, as rs274 sets it, or 0) vary. Seeded (derandomized), so every run tests the same programs.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Linear
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import PLAN_PROPERTY_SETTINGS as SETTINGS
from tests.plan_helpers import assert_within_limits, polyline_distance

PLANES = {"G17": (0, 1), "G18": (2, 0), "G19": (1, 2)}


@st.composite
def polylines(draw):
    plane = draw(st.sampled_from(sorted(PLANES)))
    radius = draw(st.floats(2.0, 30.0))
    turn_deg = draw(st.floats(0.5, 6.0))
    count = draw(st.integers(10, 30))
    even = draw(st.booleans())
    steps = [turn_deg if even else turn_deg * draw(st.floats(0.5, 1.5)) for _ in range(count)]
    tol = draw(st.sampled_from([0.002, 0.005, 0.01, 0.02, 0.05]))
    q = draw(st.sampled_from(["", " Q0"]))
    feed = draw(st.sampled_from([600, 1500, 3000, 6000]))
    start = draw(st.floats(0.0, 2 * math.pi))
    i, j = PLANES[plane]
    angles = start + np.radians(np.concatenate(([0.0], np.cumsum(steps))))
    pts = []
    for a in angles:
        p = [0.0, 0.0, 0.0]
        p[i], p[j] = radius * math.cos(a), radius * math.sin(a)
        pts.append(p)
    words = ["X", "Y", "Z"]
    body = "".join(
        "G1 " + " ".join(f"{words[k]}{p[k]:.4f}" for k in range(3)) + "\n" for p in pts[1:]
    )
    head = " ".join(f"{words[k]}{pts[0][k]:.4f}" for k in range(3))
    text = f"G21 G90 {plane} G64 P{tol:g}{q}\nG0 {head}\nF{feed}\n{body}M2\n"
    return text, tol, (tol if q == "" else 0.0)


@SETTINGS
@given(case=polylines())
def test_blended_cam_polylines_stay_within_p_and_the_limits(machine, case):
    text, tol, merge = case
    moves = parse_program(text)
    p = plan(moves, machine)
    fine = p.sample(1e-4)
    feed = [m for m in moves if isinstance(m, Linear)]
    on_feed = np.isin(fine.line, [m.line for m in feed])
    assert polyline_distance(fine.pos[on_feed], feed).max() <= (tol + merge) * (1 + 1e-9)
    assert all(b.deviation_mm <= tol for b in p.blends)
    assert_within_limits(p.sample(machine.servo.period_s), machine, moves)


#: Found by the property test above (F600, P0.01, uneven chords of R28): on the blend arc of
#: line 5 the closed-form pieces rose 1.0e-5 above the arc's cap and passed F10 mm/s by
#: 3.6e-7 mm/s between the samples the planner checks, while the cap kept only 1e-5 below the
#: feed (move_geometry.FEED_MARGIN_REL, now 5e-5).
FEED_OVERSHOOT = (
    "G21 G90 G17 G64 P0.01\n"
    "G0 X28.0000 Y0.0000 Z0.0000\n"
    "F600\n"
    "G1 X27.9824 Y0.9924 Z0.0000\n"
    "G1 X27.8969 Y2.4011 Z0.0000\n"
    "G1 X27.7799 Y3.5039 Z0.0000\n"
    "G1 X27.6383 Y4.4863 Z0.0000\n"
    "G1 X27.4619 Y5.4631 Z0.0000\n"
    "G1 X27.2510 Y6.4331 Z0.0000\n"
    "G1 X27.0058 Y7.3949 Z0.0000\n"
    "G1 X26.7268 Y8.3475 Z0.0000\n"
    "G1 X26.4141 Y9.2895 Z0.0000\n"
    "G1 X26.0682 Y10.2199 Z0.0000\n"
    "M2\n"
)


def test_a_blend_arc_of_a_cam_polyline_keeps_the_feed(machine):
    moves = parse_program(FEED_OVERSHOOT)
    assert_within_limits(plan(moves, machine).sample(machine.servo.period_s), machine, moves)
