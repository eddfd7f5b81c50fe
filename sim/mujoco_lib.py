"""The libmujoco the ``mujoco`` bindings loaded, through ctypes, and its profiler timers.

MuJoCo times the stages of every ``mj_step`` (``mjData.timer``) when its global ``mjcb_time``
is set, and the Python bindings set it on import (to a clock of their own, even with no Python
callback: ``mujoco.get_mjcb_time()`` is then None). Each step then reads the clock a few dozen
times: on the bundled gantry, 100,000 steps took 0.33-0.40 s of CPU with the timers and
0.26-0.30 s without (2026-11-29, mujoco 4.0.0), and a servo loop of 106,785 ticks 0.72 s
against 0.58 s. The physics does not read the timers: the traced positions and forces are the
same bit for bit (tests/test_mujoco_lib.py). :func:`timers_off` clears ``mjcb_time`` while the
servo loop steps (and the benchmarks' MuJoCo-alone replays, so that both sides of their ratio
step alike), and gives it back after; a time callback set from Python
(``mujoco.set_mjcb_time``) is left alone.
"""

from __future__ import annotations

import ctypes
import functools
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = ["libmujoco", "timers_off"]


@functools.cache
def libmujoco() -> Any | None:
    """The bindings' libmujoco as a ``ctypes.CDLL`` (the library already loaded: the same
    globals and functions), or None where it is not found in the mujoco package's folder."""
    import mujoco

    folder = Path(mujoco.__file__).parent
    found = [
        *folder.glob("libmujoco.so*"),
        *folder.glob("libmujoco*.dylib"),
        *folder.glob("mujoco.dll"),
    ]
    if not found:
        return None
    try:
        return ctypes.CDLL(str(found[0]))
    except OSError:
        return None


@functools.cache
def _time_slot() -> Any | None:
    """libmujoco's ``mjcb_time`` as a ``ctypes.c_void_p`` living at its address, or None."""
    lib = libmujoco()
    if lib is None:
        return None
    try:
        return ctypes.c_void_p.in_dll(lib, "mjcb_time")
    except ValueError:  # not exported by this build
        return None


#: Threads inside :func:`timers_off` (loops of a sweep's threads may overlap) and the
#: callback the first of them cleared, given back by the last to leave.
_LOCK = threading.Lock()
_inside = 0
_saved: int | None = None


@contextmanager
def timers_off() -> Iterator[None]:
    """MuJoCo's profiler timers off inside (``mjcb_time`` cleared, given back when the last
    thread inside leaves; nothing is done where the global is not found or a Python time
    callback is set)."""
    import mujoco

    global _inside, _saved
    slot = _time_slot()
    if slot is None or mujoco.get_mjcb_time() is not None:
        yield
        return
    with _LOCK:
        if _inside == 0:
            _saved, slot.value = slot.value, None
        _inside += 1
    try:
        yield
    finally:
        with _LOCK:
            _inside -= 1
            if _inside == 0:
                slot.value = _saved
