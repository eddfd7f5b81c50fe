"""Re-planning rounds: the round that is kept is whole and has no offending junction, however
few rounds are allowed."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import plan

rounds = importlib.import_module("gantry_sim.controller.planner.rounds")
BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def _program() -> str:
    import sys

    sys.path.insert(0, str(BENCH))
    try:
        from programs import program
    finally:
        sys.path.remove(str(BENCH))
    return program("arcs", 60)  # tangent arcs with S-bends: junctions come down over rounds


@pytest.mark.parametrize("max_rounds", [0, 1, 2])
def test_the_round_kept_is_whole_and_stops_where_junctions_still_offend(
    max_rounds: int, machine, monkeypatch: pytest.MonkeyPatch
) -> None:  # type: ignore[no-untyped-def]
    moves = parse_program(_program())
    free = plan(moves, machine)
    calls: list[int] = []
    real = rounds._plan_round

    def spy(*args):  # type: ignore[no-untyped-def]
        out = real(*args)
        calls.append(sum(1 for c in out[0] if c.bad))
        return out

    monkeypatch.setattr(rounds, "MAX_ROUNDS", max_rounds)
    monkeypatch.setattr(rounds, "_plan_round", spy)
    cut = plan(moves, machine)
    assert len(calls) >= max_rounds + 1  # the allowed rounds, then any adding stops
    assert all(c > 0 for c in calls[:-1]) and calls[-1] == 0  # no junction kept offending
    assert cut.move_start_s.size == free.move_start_s.size
    assert np.all(np.diff(cut.move_start_s) >= 0.0) and cut.duration_s > cut.move_start_s[-1]
    tr = cut.sample(machine.servo.period_s)
    assert np.allclose(tr.pos[-1], moves[-1].end, atol=1e-9)
    assert not tr.vel[-1].any()
