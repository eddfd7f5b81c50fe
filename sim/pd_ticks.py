"""The compiled PD ticks (sim/pd_ticks.c), when they were built, through ctypes.

``pip install .`` compiles sim/pd_ticks.c when a C compiler is there (an optional extension in
setup.py: without a compiler the install goes on without it). :func:`compiled_ticks` returns a
runner for a loop's MjData, or None -- no extension, a MuJoCo whose bindings do not expose the raw
pointers, ``GANTRY_PURE_PYTHON=1`` in the environment -- and the loop then runs
sim/servo_loop.py's Python ticks, which give the same numbers bit for bit (tests/test_pd_ticks.py).

The C loop calls the same ``mj_step`` of the same libmujoco the bindings loaded (found in the
mujoco package's folder), on the bindings' own mjModel / mjData; ctypes releases the GIL for the
call, so other threads (a trace writer) run meanwhile.
"""

from __future__ import annotations

import ctypes
import functools
import importlib
import os
from collections.abc import Callable
from typing import Any

import numpy as np

from gantry_sim.sim.mujoco_lib import libmujoco

#: set to 1 to run the Python ticks even when the compiled ones are built
PURE_PYTHON_ENV = "GANTRY_PURE_PYTHON"

_P = ctypes.c_void_p
_I, _L = ctypes.c_int, ctypes.c_long
#: gantry_pd_ticks' parameters, in order (sim/pd_ticks.c)
_ARGTYPES: list[Any] = [_P, _P, _P, _P, _P, _P, _P, _I, _I, _L, _P, _P, _P, _P, _P]

#: runs n ticks: (b (n, 3), enc_prev (3,) in/out, qpos_out (n, nq), force_out (n, 3)) -> None
Ticks = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None]


@functools.cache
def _libraries() -> tuple[Any, Any] | None:
    """(our library, libmujoco) loaded through ctypes, or None when either is missing."""
    try:
        ext = importlib.import_module("gantry_sim.sim._pd_ticks")
    except ImportError:
        return None
    import mujoco

    lib = libmujoco()
    if lib is None or not hasattr(mujoco.MjData, "_address"):
        return None
    ours = ctypes.CDLL(ext.__file__)
    ours.gantry_pd_ticks.argtypes = _ARGTYPES
    ours.gantry_pd_ticks.restype = ctypes.c_int
    ours.gantry_install_error_handler.argtypes = [_P]
    ours.gantry_last_error.restype = ctypes.c_char_p
    slot = ctypes.c_void_p.in_dll(lib, "mju_user_error")
    if not ours.gantry_install_error_handler(ctypes.addressof(slot)):
        return None  # someone else handles MuJoCo's fatal errors: keep to the bindings' path
    return ours, lib


def available() -> bool:
    """Whether the compiled ticks are built and usable (ignoring GANTRY_PURE_PYTHON)."""
    return _libraries() is not None


def compiled_ticks(
    gantry: Any, servo: Any, data: Any, mm_per_m: float, pure_python: bool | None = None
) -> Ticks | None:
    """A runner of PD ticks on ``data`` (the loop's MjData), or None for the Python ticks.

    Args:
        gantry: the loaded model (sim.machine.Gantry: indices, gear, substeps).
        servo: the law (controller.servo.DiscretePD: a, c, lo, hi).
        data: the MjData the loop steps.
        mm_per_m: millimetres per metre (the encoders' scale).
        pure_python: force the choice; None reads GANTRY_PURE_PYTHON.
    """
    if pure_python is None:
        pure_python = os.environ.get(PURE_PYTHON_ENV, "") not in ("", "0")
    libs = None if pure_python else _libraries()
    if libs is None:
        return None
    ours, lib = libs
    import mujoco

    model = gantry.model
    step = ctypes.cast(lib.mj_step, _P)
    c_long = np.dtype(f"i{ctypes.sizeof(ctypes.c_long)}")
    adr = np.asarray(gantry.qpos_adr, dtype=c_long)
    act = np.asarray(gantry.actuator_id, dtype=c_long)
    inv_gear = [1.0 / v for v in gantry.gear]  # as the Python loop computes it
    coef = np.array([*servo.a, *servo.c, *servo.lo, *servo.hi, *inv_gear, mm_per_m])
    qpos, ctrl = data.qpos, data.ctrl
    nq, nsub = int(model.nq), int(gantry.substeps)
    run = ours.gantry_pd_ticks

    def ticks(b: np.ndarray, enc: np.ndarray, qpos_out: np.ndarray, force_out: np.ndarray) -> None:
        b = np.ascontiguousarray(b, dtype=float)
        n = b.shape[0]
        assert enc.flags.c_contiguous and qpos_out.shape == (n, nq) and force_out.shape == (n, 3)
        failed = run(
            step, model._address, data._address, qpos.ctypes.data, ctrl.ctypes.data,
            adr.ctypes.data, act.ctypes.data, nq, nsub, n, b.ctypes.data, coef.ctypes.data,
            enc.ctypes.data, qpos_out.ctypes.data, force_out.ctypes.data,
        )  # fmt: skip
        if failed:
            raise mujoco.FatalError(ours.gantry_last_error().decode(errors="replace"))

    return ticks
