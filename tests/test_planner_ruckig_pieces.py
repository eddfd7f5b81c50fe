"""Arc pieces made by Ruckig (where the closed-form piece would break a limit) next to moving
junctions: the path the benchmark's pocket exercises thousands of times, kept small here."""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import ROUNDED_RECTANGLE, arc_deviation, assert_within_limits


def test_ruckig_pieces_beside_junctions_keep_limits_and_tolerance(machine):
    # G61: in G64 the line-arc junctions get G2 transitions, which need no chord smoothing
    machine = machine.with_changes("path", mode="G61")
    moves = parse_program(ROUNDED_RECTANGLE)
    p = plan(moves, machine)
    assert p.ruckig_piece_count > 0  # the Ruckig branch really runs in this program
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    tol = machine.segmentation.chord_tolerance_mm
    for a in (m for m in moves if isinstance(m, Arc)):
        assert arc_deviation(tr, a) <= 0.25 * tol, a.line
    # no stop at the tangent line/arc junctions: the speed never drops to rest mid-loop
    speed = np.linalg.norm(tr.vel, axis=1)
    loop = (tr.line >= 3) & (tr.line <= 10) & (tr.t > tr.t[tr.line == 3][0] + 0.02)
    loop &= tr.t < tr.t[tr.line == 10][-1] - 0.02
    assert speed[loop].min() > 5.0
    np.testing.assert_array_equal(tr.pos[-1], moves[-1].end)
    assert not tr.vel[-1].any() and not tr.acc[-1].any()
