"""Arcs whose end radius differs from their start radius (spirals) plan as the spirals they are.

LinuxCNC accepts a centre-format arc whose end is up to 0.1 % off its radius, and runs it as a spiral; a tool-offset change under an arc (rs274's canonical
layer starting the arc from where the tool really is) gives larger ones. The planner used to
take the sweep fraction for the arc-length fraction, so on a spiral its vertex states came
apart from its 1-D profile: closed-form pieces broke the jerk limit by up to 0.1 %, and the
Ruckig pieces that replaced them failed at the arc's end (exit 3 on valid programs, found by
planning the rs274 corpus).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.arcs import arc_points, spiral_fraction_at, spiral_length_at
from gantry_sim.controller.gcode.interpreter import interpret, parse_program
from gantry_sim.controller.gcode.tools import read_tool_table
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import arc_deviation, assert_within_limits

TOL = 0.001  # the bundled machine's chord tolerance [mm]
CORPUS = Path(__file__).resolve().parent / "data" / "rs274"


def _check(moves, machine):  # type: ignore[no-untyped-def]
    p = plan(moves, machine)
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    arcs = [m for m in moves if isinstance(m, Arc)]
    for m in arcs:
        assert arc_deviation(tr, m) <= 0.25 * TOL, m.line
    assert not tr.vel[-1].any()
    return p, arcs


@pytest.mark.parametrize(
    "text",
    [
        "G21 G17 F500\nG2 X200.05 I100\nM2",  # 0.05 % of R100
        "G21 G17 F500\nG3 X200.0999 I100\nM2",
        "G21 G17 F3000\nG2 X199.9 I100\nM2",  # inwards
        "G20 G17 F10\nG2 X2.0028 I1\nM2",  # inch, 0.14 % inside the inch tolerance
        "G21 G18 F800\nG0 X10 Y0 Z0\nG2 X-10.004 Z0 Y-3 I-10 K0\nM2",  # a spiral helix in XZ
    ],
)
def test_a_spiral_arc_keeps_the_limits_the_feed_and_its_path(text: str, machine) -> None:  # type: ignore[no-untyped-def]
    _, arcs = _check(parse_program(text), machine)
    assert arcs


def test_a_spiral_from_a_tool_offset_change_plans(machine) -> None:  # type: ignore[no-untyped-def]
    # rs274 corpus program gen_tofs_018 with its tool table read in mm: after G43.2 H1 and
    # G10 L10 the G18 G3 of line 14 starts 0.5 mm off its radius and sweeps 1.1 degrees
    text = (CORPUS / "programs" / "gen_tofs_018.ngc").read_text()
    tools = read_tool_table(CORPUS / "rs274_default_tools.tbl", units_mm=1.0)
    moves = list(interpret(text, tools=tools))
    p, arcs = _check(moves, machine)
    [spiral] = [a for a in arcs if a.line == 14]
    assert spiral.length_mm < 0.1  # the mean-radius length leaves out the radial run...
    k = next(i for i, m in enumerate(p.moves) if m.line == 14)
    assert p.move_start_s[k + 1] - p.move_start_s[k] > 0.5 / (300.0 / 60.0)  # ...0.51 mm at F300


def test_spiral_length_and_its_inverse_match_the_polyline() -> None:
    a = parse_program("G21 G17 F500\nG2 X200.0999 I100\nM2")[0]
    assert isinstance(a, Arc)
    u = np.linspace(0.0, 1.0, 100_001)
    p = arc_points(a, u)
    polyline = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
    s = spiral_length_at(a, u)
    assert np.abs(s - polyline).max() < 1e-7  # the chords' own shortfall is below 1e-8 mm
    assert np.abs(spiral_fraction_at(a, s, float(s[-1])) - u).max() < 1e-12


def test_arc_frames_kept_for_reuse_are_each_arcs_own() -> None:
    # arc_frame keeps the frames it made (keyed by the arc's id, with the arc held): arcs
    # made and dropped in turn, more than the cache holds, each get their own frame
    from gantry_sim.controller import arcs

    for k in range(arcs.FRAME_CACHE_SIZE + 100):
        r = 1.0 + k * 1e-3
        arc = Arc(
            1,
            (r, 0.0, 0.0),
            (0.0, r, 0.0),
            600.0,
            "XY",
            "ccw",
            (0.0, 0.0, 0.0),
            r,
            1,
            0.5 * math.pi,
        )
        assert arcs.arc_frame(arc) == arcs._arc_frame(arc)
        assert arcs.arc_frame(arc).r0_mm == r
    assert 0 < len(arcs._frames) <= arcs.FRAME_CACHE_SIZE
