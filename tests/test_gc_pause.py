"""The collector is paused while planning and comes back as it was."""

from __future__ import annotations

import gc
import importlib
from collections.abc import Callable

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


def test_frozen_objects_are_out_of_reach_inside_and_back_after() -> None:
    from gantry_sim.controller.gc_pause import gc_frozen

    alive = [[] for _ in range(100)]
    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError), gc_frozen():
        assert gc.get_freeze_count() >= len(alive)
        assert gc.collect() >= 0 and gc.get_freeze_count() >= len(alive)  # a pass leaves them
        raise RuntimeError("the run failed")
    assert gc.get_freeze_count() == 0 and gc.isenabled()


def test_a_caller_s_own_freeze_is_left_as_it_was(monkeypatch) -> None:
    """Neither ``gc.unfreeze`` (which would give back the caller's objects too) nor
    ``gc.freeze`` is called while the caller's freeze holds: both are watched, and still do
    their work. The frozen count alone cannot say so exactly: reference counting still frees
    frozen objects (pytest-xdist's I/O thread freed two between two reads, 274,552 ->
    274,550), so without a call it may fall, but never rise, nor reach 0."""
    from gantry_sim.controller.gc_pause import gc_frozen

    freeze, unfreeze = gc.freeze, gc.unfreeze
    calls: list[str] = []

    def watched(name: str, real: Callable[[], None]) -> Callable[[], None]:
        def call() -> None:
            calls.append(name)
            real()

        return call

    freeze()
    try:
        mine = gc.get_freeze_count()
        monkeypatch.setattr(gc, "freeze", watched("freeze", freeze))
        monkeypatch.setattr(gc, "unfreeze", watched("unfreeze", unfreeze))
        with gc_frozen(), gc_frozen():
            assert 0 < gc.get_freeze_count() <= mine
        assert 0 < gc.get_freeze_count() <= mine
        assert calls == []
    finally:
        monkeypatch.undo()
        unfreeze()


def _enabled_when_decoded() -> bool:
    """Unpickled (controller.spill), whether the collector was running meanwhile."""
    return gc.isenabled()


class _Probe:
    def __reduce__(self):
        return (_enabled_when_decoded, ())


def test_spilled_blocks_are_decoded_with_the_collector_paused() -> None:
    from gantry_sim.controller.spill import SpilledList

    items = SpilledList([_Probe() for _ in range(6)], block_items=2)
    try:
        assert gc.isenabled()
        assert list(items)[:4] == [False] * 4  # the two closed blocks, read back from disk
        assert gc.isenabled()
    finally:
        items.close()


def test_a_streamed_run_keeps_the_collector_off_the_plan(monkeypatch) -> None:
    """The streamed simulation and analysis run with the objects made before them frozen
    (gc_frozen): the collector's passes walk the run's own objects only."""
    from gantry_sim.sim import api, stream

    frozen = []
    real = stream.stream_run

    def spy(*args, **kwargs):
        frozen.append(gc.get_freeze_count())
        return real(*args, **kwargs)

    monkeypatch.setattr(stream, "stream_run", spy)
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    machine = load_machine_config(DEFAULT_MACHINE)
    result = api.run_program("G21 G1 X2 F600\nM2\n", machine=machine)
    assert result.streamed and len(frozen) == 1 and frozen[0] > 1000
    assert gc.get_freeze_count() == 0
