"""The servo loop's ticks against MuJoCo, run range after range with the loop's state carried.

Per servo tick k (time t_k = k T):
  1. read qpos -- the state at t_k -- and record it;
  2. take the joint positions x_k (the encoders) and compute the held force F_k (controller.servo);
  3. write F_k to the actuators and advance the physics by T: ``mj_step(m, d, substeps)`` (one
     call for the tick's sub-steps: the force is held over the tick, and MuJoCo's ``nstep``
     loop is its own ``mj_step`` repeated, bit for bit -- tests/test_servo_loop.py).

:class:`ServoLoop` owns everything that survives from one tick to the next -- the ``MjData``, the
previous encoder reading x_{k-1}, the previous reference r_{k-1} (the drive terms' derivative)
and, with an integral term or backlash, sim.stateful_ticks' integral, saturation and motor-side
encoders -- so ticks run in ranges of any size give the same numbers as one range, bit for bit.
The per-tick work is plain float arithmetic on three axes: the part of the law that depends only
on the reference (DiscretePD.drive_terms) is computed per range, vectorised; after the range the
held forces are recomputed vectorised from the recorded encoders with the same law
(DiscretePD.forces, the same operations in the same order, so bit for bit).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.servo import DiscretePD
from gantry_sim.sim.machine import MM_PER_M, Gantry
from gantry_sim.sim.mujoco_lib import timers_off
from gantry_sim.sim.pd_ticks import compiled_ticks
from gantry_sim.sim.stateful_ticks import StatefulTicks


class ServoLoop:
    """A machine at rest at ``start_joint_mm``, then servo ticks range after range.

    Args:
        gantry: the loaded model (indices, gear, substeps).
        machine: the machine file (servo law, backlash).
        start_joint_mm: (3,) where the machine rests at t = 0, joint coordinates [mm].
        pure_python: True runs the Python ticks even when the compiled ones are built (None:
            the environment's GANTRY_PURE_PYTHON decides; sim/pd_ticks.py).
    """

    def __init__(
        self,
        gantry: Gantry,
        machine: MachineConfig,
        start_joint_mm: np.ndarray,
        pure_python: bool | None = None,
    ) -> None:
        import mujoco

        self.gantry = gantry
        self.servo = DiscretePD(machine.servo, gantry.plant)
        self.data: Any = mujoco.MjData(gantry.model)
        self.data.qpos[:] = gantry.joint_qpos_m(np.asarray(start_joint_mm, dtype=float))
        self.data.qvel[:] = 0.0
        q = self.data.qpos.tolist()
        #: the previous tick's encoders x_{k-1} [mm] (x_0 before the first tick)
        self.enc_prev = np.array([q[i] * MM_PER_M for i in gantry.qpos_adr])
        #: the previous tick's reference r_{k-1}, joint coordinates [mm] (None before tick 0)
        self.ref_prev: np.ndarray | None = None
        self.stateful: StatefulTicks | None = None
        if self.servo.has_integral or any(machine.sim.backlash_mm):
            self.stateful = StatefulTicks(gantry, self.servo, machine.sim.backlash_mm, self.data)
        #: the compiled PD ticks (sim/pd_ticks.py), or None: the Python ticks below
        self.compiled = (
            None
            if self.stateful is not None
            else compiled_ticks(gantry, self.servo, self.data, MM_PER_M, pure_python)
        )
        #: ticks run so far
        self.ticks = 0

    def run(
        self, ref_joint_mm: np.ndarray, vel: np.ndarray, acc: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The next n ticks along the reference ``ref_joint_mm`` (n, 3) [mm, joint coordinates]
        with ``vel`` (n, 3) [mm/s] and ``acc`` (n, 3) [mm/s^2] -> (qpos (n, nq) at t_k [m or
        rad], held force (n, 3) per axis x, y, z [N])."""
        with timers_off():  # MuJoCo's profiler reads the clock a few dozen times a step
            return self._run(ref_joint_mm, vel, acc)

    def _run(
        self, ref_joint_mm: np.ndarray, vel: np.ndarray, acc: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        ref = np.asarray(ref_joint_mm, dtype=float).reshape(-1, 3)
        n = ref.shape[0]
        nq = self.gantry.model.nq
        if n == 0:
            return np.empty((0, nq)), np.empty((0, 3))
        # b_k needs r_{k-1}: the previous range's last reference row (r_{-1} = r_0 at tick 0)
        head = ref[:1] if self.ref_prev is None else self.ref_prev[None]
        b_arr = self.servo.drive_terms(
            np.vstack([head, ref]), np.vstack([vel[:1], vel]), np.vstack([acc[:1], acc])
        )[1:]
        if self.compiled is not None:
            qpos, force = np.empty((n, nq)), np.empty((n, 3))
            enc = self.enc_prev.copy()
            self.compiled(b_arr, enc, qpos, force)
            self.enc_prev = enc
            self.ref_prev = ref[-1].copy()
            self.ticks += n
            return qpos, force
        flat: list[float] = []  # qpos row after row (cheapest to extend and to convert)
        if self.stateful is not None:
            force = self.stateful.run(b_arr.tolist(), ref.tolist(), flat.extend)
        else:
            self._pd_ticks(b_arr.tolist(), flat.extend)
        qpos = np.fromiter(flat, float, len(flat)).reshape(-1, nq)
        joint = qpos[:, list(self.gantry.qpos_adr)] * MM_PER_M
        if self.stateful is None:
            # the held forces again, vectorised from the recorded encoders (the same law)
            force = self.servo.forces(b_arr, joint, np.vstack([self.enc_prev[None], joint[:-1]]))
        self.enc_prev = joint[-1].copy()
        self.ref_prev = ref[-1].copy()
        self.ticks += n
        return qpos, force

    def _pd_ticks(self, b: list, record: Any) -> None:
        """The PD law of controller.servo.DiscretePD.force, unrolled over x, y, z."""
        import mujoco

        g, servo, d = self.gantry, self.servo, self.data
        m, qpos, ctrl, nsub, step = g.model, d.qpos, d.ctrl, g.substeps, mujoco.mj_step
        ix, iy, iz = g.qpos_adr
        ux, uy, uz = g.actuator_id
        gx, gy, gz = (1.0 / v for v in g.gear)
        ax, ay, az = servo.a
        cx, cy, cz = servo.c
        lox, loy, loz = servo.lo
        hix, hiy, hiz = servo.hi
        mm = MM_PER_M
        px, py, pz = self.enc_prev.tolist()
        for bx, by, bz in b:
            q = qpos.tolist()  # the state at t_k: encoders now, tool site after the range
            record(q)
            x, y, z = q[ix] * mm, q[iy] * mm, q[iz] * mm
            # u = b - a x_k + c x_{k-1}, clamped
            fx = bx - ax * x + cx * px
            fx = hix if fx > hix else (lox if fx < lox else fx)
            fy = by - ay * y + cy * py
            fy = hiy if fy > hiy else (loy if fy < loy else fy)
            fz = bz - az * z + cz * pz
            fz = hiz if fz > hiz else (loz if fz < loz else fz)
            ctrl[ux] = fx * gx
            ctrl[uy] = fy * gy
            ctrl[uz] = fz * gz
            step(m, d, nsub)
            px, py, pz = x, y, z
