"""The servo loop's ticks when the law carries state: an integral term or backlash.

The law of :meth:`gantry_sim.controller.servo.DiscretePD.step` (conditional integration, the
integral clamp, the force clamp, the saturation flag) and the transmission of
:func:`gantry_sim.controller.transmission.motor_side_mm`, unrolled over x, y, z with the same
operations in the same order, so the forces are those of the law exactly (tests/test_servo_integral.py
replays the law on a trace; tests/test_backlash.py checks that with ki = 0 and no backlash this
loop is sim/servo_loop.py's PD loop bit for bit). Used by sim/servo_loop.py only when the machine file
sets ``[servo] ki_N_per_mm_s`` or ``[sim] backlash_mm``.

Start: the error integral 0, no saturation, each encoder at its axis' position (the axis in the
middle of its gap).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from gantry_sim.controller.servo import DiscretePD
from gantry_sim.sim.machine import MM_PER_M, Gantry


class StatefulTicks:
    """Runs servo ticks, chunk by chunk, keeping the loop's state between chunks.

    Args:
        gantry: the loaded model (indices, gear, substeps).
        servo: the law (gains, limits, integral gains and clamps).
        backlash_mm: play per axis [mm].
        data: the ``mujoco.MjData`` being stepped (at rest at the first sample).
    """

    def __init__(
        self,
        gantry: Gantry,
        servo: DiscretePD,
        backlash_mm,
        data: Any,
    ) -> None:
        import mujoco

        self.gantry, self.servo, self.data = gantry, servo, data
        self.half = tuple(0.5 * float(v) for v in backlash_mm)
        self.step_physics = mujoco.mj_step
        q = data.qpos.tolist()
        #: encoder of the previous tick [mm], error integral [mm s], saturation per axis
        self.enc = [q[i] * MM_PER_M for i in gantry.qpos_adr]
        self.integral = [0.0, 0.0, 0.0]
        self.saturated = [0, 0, 0]

    def run(self, b: list, ref: list, record: Callable[[list[float]], Any]) -> np.ndarray:
        """The next ticks: ``b`` (n, 3) drive terms b_k [N] and ``ref`` (n, 3) reference in joint
        coordinates [mm], as nested lists; ``record`` receives each tick's qpos (the state at
        t_k). Returns the held forces (n, 3) [N]."""
        g, servo, d = self.gantry, self.servo, self.data
        m, qpos, ctrl, nsub, step = g.model, d.qpos, d.ctrl, g.substeps, self.step_physics
        ix, iy, iz = g.qpos_adr
        ux, uy, uz = g.actuator_id
        gx, gy, gz = (1.0 / v for v in g.gear)
        ax, ay, az = servo.a
        cx, cy, cz = servo.c
        kx, ky, kz = servo.ki
        mx, my, mz = servo.i_max
        lox, loy, loz = servo.lo
        hix, hiy, hiz = servo.hi
        hx, hy, hz = self.half
        t, mm = servo.period_s, MM_PER_M
        px, py, pz = self.enc
        ix_, iy_, iz_ = self.integral
        sx, sy, sz = self.saturated
        forces: list[float] = []
        out = forces.extend
        for (bx, by, bz), (rx, ry, rz) in zip(b, ref, strict=True):
            q = qpos.tolist()
            record(q)
            # X: encoder (controller.transmission.motor_side_mm), then DiscretePD.step
            x = q[ix] * mm
            lo_, hi_ = x - hx, x + hx
            ex = hi_ if px > hi_ else (lo_ if px < lo_ else px)
            e = rx - ex
            if not ((sx > 0 and e > 0) or (sx < 0 and e < 0)):
                ix_ = ix_ + e * t
            ix_ = min(mx, max(-mx, ix_))
            u = bx - ax * ex + cx * px + kx * ix_
            fx = min(hix, max(lox, u))
            sx = 1 if fx >= hix else (-1 if fx <= lox else 0)
            px = ex
            # Y: encoder (controller.transmission.motor_side_mm), then DiscretePD.step
            x = q[iy] * mm
            lo_, hi_ = x - hy, x + hy
            ey = hi_ if py > hi_ else (lo_ if py < lo_ else py)
            e = ry - ey
            if not ((sy > 0 and e > 0) or (sy < 0 and e < 0)):
                iy_ = iy_ + e * t
            iy_ = min(my, max(-my, iy_))
            u = by - ay * ey + cy * py + ky * iy_
            fy = min(hiy, max(loy, u))
            sy = 1 if fy >= hiy else (-1 if fy <= loy else 0)
            py = ey
            # Z: encoder (controller.transmission.motor_side_mm), then DiscretePD.step
            x = q[iz] * mm
            lo_, hi_ = x - hz, x + hz
            ez = hi_ if pz > hi_ else (lo_ if pz < lo_ else pz)
            e = rz - ez
            if not ((sz > 0 and e > 0) or (sz < 0 and e < 0)):
                iz_ = iz_ + e * t
            iz_ = min(mz, max(-mz, iz_))
            u = bz - az * ez + cz * pz + kz * iz_
            fz = min(hiz, max(loz, u))
            sz = 1 if fz >= hiz else (-1 if fz <= loz else 0)
            pz = ez
            ctrl[ux] = fx * gx
            ctrl[uy] = fy * gy
            ctrl[uz] = fz * gz
            out((fx, fy, fz))
            step(m, d, nsub)
        self.enc = [px, py, pz]
        self.integral = [ix_, iy_, iz_]
        self.saturated = [sx, sy, sz]
        return np.fromiter(forces, float, len(forces)).reshape(-1, 3)
