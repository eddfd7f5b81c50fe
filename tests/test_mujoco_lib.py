"""MuJoCo's profiler timers are off while the servo loop steps, given back after, and change
nothing of the physics (sim/mujoco_lib.py)."""

from __future__ import annotations

import sys
import threading

import mujoco
import numpy as np
import pytest

from gantry_sim.sim.machine import load_gantry
from gantry_sim.sim.mujoco_lib import _time_slot, libmujoco, timers_off
from gantry_sim.sim.servo_loop import ServoLoop

STEP = mujoco.mjtTimer.mjTIMER_STEP

pytestmark = pytest.mark.skipif(
    libmujoco() is None or _time_slot() is None,
    reason="libmujoco or its mjcb_time not found next to the bindings",
)


def test_libmujoco_is_found_on_linux() -> None:
    if sys.platform.startswith("linux"):
        assert libmujoco() is not None and _time_slot() is not None


def _steps(gantry, n: int) -> tuple[np.ndarray, float]:
    """qpos after ``n`` steps of a pushed machine from rest, and the step timer's total [ms]."""
    d = mujoco.MjData(gantry.model)
    d.ctrl[list(gantry.actuator_id)] = [40.0, -25.0, 10.0]
    for _ in range(n):
        mujoco.mj_step(gantry.model, d)
    return d.qpos.copy(), float(d.timer[STEP].duration)


def test_timers_off_inside_given_back_after_and_the_physics_unchanged(machine) -> None:
    gantry = load_gantry(machine)
    slot = _time_slot()
    before = slot.value
    assert before is not None  # the bindings set it on import
    q_on, timed_on = _steps(gantry, 300)
    with timers_off():
        assert slot.value is None
        with timers_off():  # nested: still off, and the outer one gives it back
            assert slot.value is None
        assert slot.value is None
        q_off, timed_off = _steps(gantry, 300)
    assert slot.value == before
    assert timed_on > 0.0 and timed_off == 0.0
    assert np.array_equal(q_on, q_off)


def test_timers_given_back_when_the_body_raises() -> None:
    slot = _time_slot()
    before = slot.value
    with pytest.raises(RuntimeError), timers_off():
        raise RuntimeError("stop")
    assert slot.value == before


def test_overlapping_threads_give_the_timers_back_when_the_last_one_leaves() -> None:
    slot = _time_slot()
    before = slot.value
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen: list[int | None] = []

    def first() -> None:
        with timers_off():
            first_in.set()
            second_in.wait(5)
        first_out.set()

    def second() -> None:
        first_in.wait(5)
        with timers_off():
            second_in.set()
            first_out.wait(5)
            seen.append(slot.value)  # the first thread has left: still off for this one

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen == [None]
    assert slot.value == before


def test_a_python_time_callback_is_left_alone() -> None:
    slot = _time_slot()
    mujoco.set_mjcb_time(lambda: 0.0)
    try:
        held = slot.value
        with timers_off():
            assert slot.value == held and slot.value is not None
    finally:
        mujoco.set_mjcb_time(None)


@pytest.mark.parametrize("pure_python", [True, False])
def test_the_servo_loop_steps_with_the_timers_off(machine, pure_python: bool) -> None:
    gantry = load_gantry(machine)
    loop = ServoLoop(gantry, machine, np.zeros(3), pure_python=pure_python)
    ref = np.zeros((50, 3))
    ref[:, 0] = np.linspace(0.0, 0.05, 50)
    loop.run(ref, np.zeros((50, 3)), np.zeros((50, 3)))
    assert loop.data.timer[STEP].number == 50 * gantry.substeps
    assert loop.data.timer[STEP].duration == 0.0
