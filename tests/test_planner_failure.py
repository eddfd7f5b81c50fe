"""A move the planner cannot fit within the limits is gantry-sim's limitation, not the user's
error: exit 3 with one line naming the program line (issue 15, defect 15: no Ruckig jargon
blamed on a valid program with exit 2)."""

from __future__ import annotations

import pytest

from gantry_sim.controller.errors import GantryError, PlannerFailure
from gantry_sim.controller.planner import ruckig_solver
from gantry_sim.sim.cli import main

PROGRAM = "G21 G90 G17\nG2 X10 Y0 I5 J0 F3000\nM2\n"


def _reject(*_args, **_kwargs):
    raise ruckig_solver.RuckigRejected("ErrorExecutionTimeCalculation")


def test_a_planner_failure_is_an_internal_error_naming_the_line(tmp_path, capsys, monkeypatch):
    program = tmp_path / "p.ngc"
    program.write_text(PROGRAM)
    monkeypatch.setattr(ruckig_solver.RuckigSolver, "profile", _reject)
    assert main(["plan", str(program)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        "gantry: internal error (PlannerFailure: line 2:"
    )
    assert "lower the feed" not in err


def test_a_rejected_arc_piece_is_a_planner_failure(monkeypatch, machine):
    from gantry_sim.controller.gcode import interpret
    from gantry_sim.controller.planner import plan

    monkeypatch.setattr(ruckig_solver.RuckigSolver, "piece", _reject)
    with pytest.raises(PlannerFailure, match=r"line 2: no jerk-limited piece"):
        plan(list(interpret(PROGRAM)), machine, arc_pieces="ruckig")


def test_planner_failure_is_not_a_user_error():
    assert not issubclass(PlannerFailure, GantryError)
