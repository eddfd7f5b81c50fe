"""The travel check's quick box (:func:`~gantry_sim.controller.planner.travel._may_leave`) never
clears a move whose exact extent leaves the travel: arcs in every plane, helices, full turns
and slight spirals (LinuxCNC accepts an end radius off by a little), near the limits."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.config import Travel
from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner.travel import check_travel, extent_points

travel_mod = importlib.import_module("gantry_sim.controller.planner.travel")
LO, HI = np.array([0.0, 0.0, -50.0]), np.array([100.0, 80.0, 0.0])
TRAVEL = Travel(tuple(LO), tuple(HI))

PLANES = {"G17": (0, 1), "G18": (2, 0), "G19": (1, 2)}


@st.composite
def arc_program(draw):  # type: ignore[no-untyped-def]
    plane = draw(st.sampled_from(sorted(PLANES)))
    i1, i2 = PLANES[plane]
    r = draw(st.floats(0.05, 30.0))
    centre = [draw(st.floats(lo + 0.0, hi)) for lo, hi in zip(LO, HI, strict=True)]
    th0 = draw(st.floats(0.0, 2 * math.pi))
    start = list(centre)
    start[i1] += r * math.cos(th0)
    start[i2] += r * math.sin(th0)
    th1 = th0 + draw(st.floats(-4 * math.pi, 4 * math.pi))
    r1 = r * (1.0 + draw(st.sampled_from([0.0, 1e-4, -1e-4, 5e-4])))
    end = list(centre)
    end[i1] += r1 * math.cos(th1)
    end[i2] += r1 * math.sin(th1)
    n = 3 - i1 - i2
    end[n] += draw(st.floats(-5.0, 5.0))
    word = draw(st.sampled_from(["G2", "G3"]))
    turns = draw(st.integers(1, 3))
    ijk = {0: "I", 1: "J", 2: "K"}
    off = f"{ijk[i1]}{centre[i1] - start[i1]:.6f} {ijk[i2]}{centre[i2] - start[i2]:.6f}"
    xyz = " ".join(f"{a}{v:.6f}" for a, v in zip("XYZ", end, strict=True))
    return (
        f"G21 G90 {plane}\nG0 X{start[0]:.6f} Y{start[1]:.6f} Z{start[2]:.6f}\n"
        f"{word} {xyz} {off} P{turns} F600\nM2\n"
    )


@settings(max_examples=300, deadline=None)
@given(arc_program())
def test_the_box_flags_every_arc_that_leaves_the_travel(text: str) -> None:
    try:
        moves = parse_program(text)
    except Exception:  # an arc the interpreter refuses (radius mismatch): not a move
        return
    flagged = travel_mod._may_leave(moves, LO, HI)
    for move, flag in zip(moves, flagged, strict=True):
        pts = extent_points(move)
        leaves = bool(np.any(pts < LO - 1e-9) or np.any(pts > HI + 1e-9))
        assert flag or not leaves, (text, pts.min(axis=0), pts.max(axis=0))


def test_the_first_move_leaving_is_named_when_others_fit() -> None:
    text = (
        "G21 G90 G17\nG0 X50 Y40 Z-10\nG2 X50 Y40 I10 J0 F600\n"  # a circle well inside
        "G3 X90 Y40 I20 J0\n"  # its far side reaches Y60: inside
        "G3 X50 Y40 I-20 J0\n"  # through Y20 back: inside
        "G2 X95 Y40 I22.5 J0\n"  # up to Y62.5: inside
        "G2 X50 Y40 I-22.5 J0\n"  # and its lower half to Y17.5: inside
        "G3 X10 Y40 I-20 J0\n"  # line 8: down to Y20; fine
        "G2 X50 Y40 I20 J0\n"  # line 9: up to Y60
        "G3 X50 Y40 I0 J-45\n"  # line 10: a circle of R45 reaching Y-50: leaves
        "M2\n"
    )
    moves = parse_program(text)
    assert list(np.flatnonzero(travel_mod._may_leave(moves, LO, HI))) == [8]
    with pytest.raises(PlanningError) as err:
        check_travel(moves, TRAVEL)
    assert err.value.line == 10
    assert "Y-50.0000" in str(err.value)
