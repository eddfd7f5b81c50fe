"""Speed ceilings at curvature-jump junctions (benchmarks/junction_floor.py) against the planner.

The ceilings say how fast any reference may pass a tangent junction whose curvature jumps while
staying within 0.25 x chord tolerance of the geometry; the planner keeps that tolerance, so its
junction speeds must lie below them. Planning gantry S-bends and rounded corners here checks the
ceilings' theory and the planner against each other.
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.junction_floor import C_ONE_SIDED, junction_ceiling
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.jerk3 import jerk3_pairs, jerk3_points
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import ROUNDED_RECTANGLE, arc_deviation

# Three reversing R5 semicircles at F6000: an S-bend (curvature -1/5 -> +1/5) at each junction.
S_BEND = """G21 G17 G90 F6000
G0 X0 Y0
G2 X10 Y0 R5
G3 X20 Y0 R5
G2 X30 Y0 R5
M2
"""


def test_one_sided_constant_is_the_closed_form_pieces():
    """The closed-form piece absorbing a unit acceleration jump over unit time deviates by f and
    needs jerk g: it absorbs da = (e J^2 / (f g^2))^(1/3), the linear programme's optimum."""
    z = np.zeros((1, 3))
    ps, vs, as_, js = jerk3_pairs(z, z, np.array([[-1.0, 0.0, 0.0]]), z, z, z, np.array([1.0]))
    f = np.abs(jerk3_points(ps[0], vs[0], as_[0], js[0], 1.0)[:, 0]).max()
    g = np.abs(js[0][:, 0]).max()
    assert (1.0 / (f * g * g)) ** (1.0 / 3.0) == pytest.approx(C_ONE_SIDED, rel=2e-3)


@pytest.mark.parametrize("program", [S_BEND, ROUNDED_RECTANGLE], ids=["s-bend", "rounded-rect"])
def test_planner_passes_curvature_jumps_below_their_ceilings(machine, program):
    # G61, whose promise (0.25 x chord tolerance) the ceilings take as their deviation; in G64 the
    # junctions get G2 transitions within P (tests/test_transitions.py checks those ceilings)
    machine = machine.with_changes("path", mode="G61")
    moves = [m for m in parse_program(program) if m.length_mm > 1e-9]
    p = plan(moves, machine)
    tol = machine.segmentation.chord_tolerance_mm
    tr = p.sample(machine.servo.period_s)
    assert max(arc_deviation(tr, a) for a in moves if isinstance(a, Arc)) <= 0.25 * tol
    checked = 0
    for k in range(1, len(moves)):
        ceiling = junction_ceiling(moves[k - 1], moves[k], machine.limits, 0.25 * tol)
        if not np.isfinite(ceiling):
            continue
        _, vel, _ = p.curve.evaluate(np.array([p.move_start_s[k]]))
        speed = float(np.linalg.norm(vel))
        assert speed <= ceiling, (moves[k].line, speed, ceiling)
        assert speed >= 0.5 * ceiling, (moves[k].line, speed, ceiling)  # no needless crawl
        checked += 1
    assert checked >= 2
