"""The collector is paused while planning and comes back as it was."""

from __future__ import annotations

import gc
import importlib

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gc_pause import gc_paused
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import plan
from gantry_sim.models import DEFAULT_MACHINE

#: the module (the package's ``plan`` is the function)
plan_mod = importlib.import_module("gantry_sim.controller.planner.plan")


def test_nested_pauses_end_with_the_outermost() -> None:
    assert gc.isenabled()
    with gc_paused():
        assert not gc.isenabled()
        with gc_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()


def test_a_pause_inside_a_disabled_collector_leaves_it_disabled() -> None:
    gc.disable()
    try:
        with gc_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_planning_runs_paused_and_restores_the_collector_even_when_it_fails(
    monkeypatch,
) -> None:
    seen = []
    real = plan_mod.check_travel

    def spy(*args):
        seen.append(gc.isenabled())
        return real(*args)

    monkeypatch.setattr(plan_mod, "check_travel", spy)
    machine = load_machine_config(DEFAULT_MACHINE)
    plan(parse_program("G21 G1 X10 F600\nM2\n"), machine)
    assert seen == [False] and gc.isenabled()
    with pytest.raises(Exception, match="travel"):
        plan(parse_program("G21 G1 X100000 F600\nM2\n"), machine)
    assert gc.isenabled()
