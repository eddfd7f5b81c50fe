"""Every move's box in the analysis' move table holds the whole move (sim/move_table.py): the
nearest-point search skips a move whose box is farther than the best so far, so a box that
missed part of its arc would give a wrong nearest point."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.sim.move_table import move_table

PLANES = {"G17": (0, 1, 2), "G18": (2, 0, 1), "G19": (1, 2, 0)}
LETTERS = ("X", "Y", "Z")
OFFSETS = ("I", "J", "K")


@given(
    plane=st.sampled_from(sorted(PLANES)),
    code=st.sampled_from(["G2", "G3"]),
    radius=st.floats(0.05, 80.0),
    start_deg=st.floats(0.0, 360.0),
    sweep_deg=st.floats(1.0, 359.0),
    spiral_mm=st.floats(-0.01, 0.01),
    height=st.floats(-5.0, 5.0),
    turns=st.integers(1, 3),
)
@settings(max_examples=300, deadline=None)
def test_an_arc_lies_inside_its_box(
    plane: str,
    code: str,
    radius: float,
    start_deg: float,
    sweep_deg: float,
    spiral_mm: float,
    height: float,
    turns: int,
) -> None:
    i1, i2, n = PLANES[plane]
    a0 = math.radians(start_deg)
    a1 = a0 + (1 if code == "G3" else -1) * math.radians(sweep_deg)
    start = [10.0, -20.0, 5.0]
    centre = list(start)
    centre[i1] -= radius * math.cos(a0)
    centre[i2] -= radius * math.sin(a0)
    end = list(centre)
    end[i1] += (radius + spiral_mm) * math.cos(a1)  # a spiral within rs274's tolerance
    end[i2] += (radius + spiral_mm) * math.sin(a1)
    end[n] = start[n] + height
    words = " ".join(f"{LETTERS[i]}{end[i]:.6f}" for i in range(3))
    offsets = " ".join(f"{OFFSETS[i]}{centre[i] - start[i]:.6f}" for i in (i1, i2))
    text = (
        f"G21 G90 {plane}\nG0 X{start[0]} Y{start[1]} Z{start[2]}\n"
        f"{code} {words} {offsets} P{turns} F1000\nM2\n"
    )
    try:
        moves = parse_program(text)
    except GcodeError:  # an end the controller refuses (too far off the circle): no arc
        return
    (arc,) = [m for m in moves if isinstance(m, Arc)]
    tab = move_table([arc])
    on = arc_points(arc, np.linspace(0.0, 1.0, 4001))
    assert (on >= tab.box_lo[0]).all() and (on <= tab.box_hi[0]).all()
