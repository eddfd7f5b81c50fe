"""The servo loop around MuJoCo: one discrete PD tick, then ``substeps`` physics steps.

Per servo tick k (time t_k = k T):
  1. read qpos -- the state at t_k -- and record it;
  2. take the joint positions x_k (the encoders) and compute the held force F_k (controller.servo);
  3. write F_k to the actuators and advance the physics by T: ``mj_step(m, d, substeps)``.

The per-tick work is plain float arithmetic on three axes: everything that depends only on the
reference (DiscretePD.drive_terms) is computed beforehand, vectorised. The tool-tip site is a pure
function of qpos, so no per-tick ``mj_kinematics`` is needed: every CHUNK ticks the recorded qpos
rows become tool-site positions in one pass (Gantry.tool_site_m: a closed form checked against
MuJoCo when only slides carry the site, mj_kinematics per row otherwise), and the held forces are
recomputed vectorised from the recorded encoders with the same law (DiscretePD.forces, bit for
bit). Each chunk is then checked: non-finite values, MuJoCo's instability warnings, or a
following error beyond [servo] max_following_error_mm raise :class:`SimulationError` -- a
diverged run is not a result.

With an integral term ([servo] ki_N_per_mm_s) or backlash ([sim] backlash_mm) the loop carries
state per axis (the error integral, the drive's saturation, the motor-side encoder position):
sim.stateful_ticks runs those ticks (the law of DiscretePD.step and the transmission of
controller.transmission, unrolled) and records the held forces as it goes.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import SimulationError
from gantry_sim.controller.servo import DiscretePD
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.machine import AXES, MM_PER_M, Gantry
from gantry_sim.sim.stateful_ticks import StatefulTicks

#: servo ticks between divergence checks and progress-bar updates
CHUNK = 2000
#: show a progress bar (when asked or on a TTY) only for runs longer than this [s simulated]
PROGRESS_MIN_S = 5.0


@dataclass(frozen=True)
class SimTrace:
    """What the simulation recorded at every servo tick (same length as the trajectory).

    Attributes:
        pos: (N, 3) tool tip in program (work) coordinates [mm], at t_k.
        force: (N, 3) force held from t_k to t_k+1 per axis x, y, z [N] (after saturation).
        steps: physics steps taken.
        wall_s: wall-clock time of the loop [s].
    """

    pos: np.ndarray
    force: np.ndarray
    steps: int
    wall_s: float


def _want_progress(progress: bool | None, duration_s: float) -> bool:
    if duration_s < PROGRESS_MIN_S:
        return False
    return bool(progress) if progress is not None else sys.stderr.isatty()


def simulate(
    gantry: Gantry,
    machine: MachineConfig,
    traj: Trajectory,
    *,
    progress: bool | None = None,
) -> SimTrace:
    """Run the servo against MuJoCo along ``traj`` and trace the tool tip.

    The machine starts at rest at the trajectory's first sample. Raises SimulationError (with
    the program line being executed) when the run diverges.
    """
    import mujoco

    n = traj.t.size
    m = gantry.model
    d = mujoco.MjData(m)
    servo = DiscretePD(machine.servo, gantry.plant)
    ref_joint = gantry.work_to_joint_mm(traj.pos)
    b_arr = servo.drive_terms(ref_joint, traj.vel, traj.acc)
    b = b_arr.tolist()
    d.qpos[:] = gantry.joint_qpos_m(ref_joint[0])
    d.qvel[:] = 0.0
    stateful = None
    if servo.has_integral or any(machine.sim.backlash_mm):
        stateful = StatefulTicks(gantry, servo, machine.sim.backlash_mm, d, b, ref_joint.tolist())

    nq = m.nq
    qpos_chunks: list[np.ndarray] = []
    work_chunks: list[np.ndarray] = []
    qpos, ctrl = d.qpos, d.ctrl
    ix, iy, iz = gantry.qpos_adr
    ux, uy, uz = gantry.actuator_id
    gx, gy, gz = (1.0 / g for g in gantry.gear)
    ax, ay, az = servo.a
    cx, cy, cz = servo.c
    lox, loy, loz = servo.lo
    hix, hiy, hiz = servo.hi
    nsub = gantry.substeps
    step = mujoco.mj_step
    mm = MM_PER_M
    q = qpos.tolist()
    px, py, pz = q[ix] * mm, q[iy] * mm, q[iz] * mm

    bar = None
    if _want_progress(progress, traj.duration_s):
        from tqdm import tqdm

        bar = tqdm(total=n, unit="tick", desc="simulate", file=sys.stderr, leave=False)
    start = time.perf_counter()
    # MuJoCo's warnings (e.g. "Nan, Inf or huge value in CTRL") would go to stdout and to
    # ./MUJOCO_LOG.TXT; collect them instead: each chunk's check turns them into an error
    warnings: list[str] = []
    previous_handler = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)
    try:
        for lo in range(0, n, CHUNK):
            hi = min(n, lo + CHUNK)
            flat: list[float] = []  # qpos row after row (cheapest to extend and to convert)
            record = flat.extend
            if stateful is not None:
                stateful.run(lo, hi, record)
            for bx, by, bz in b[lo:hi] if stateful is None else ():
                q = qpos.tolist()  # the state at t_k: encoders now, tool site after the chunk
                record(q)
                x, y, z = q[ix] * mm, q[iy] * mm, q[iz] * mm
                # controller.servo.DiscretePD.force, unrolled: u = b - a x_k + c x_{k-1}, clamped
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
            qpos_chunks.append(np.fromiter(flat, float, len(flat)).reshape(-1, nq))
            work_chunks.append(gantry.tool_to_work_mm(gantry.tool_site_m(qpos_chunks[-1])))
            _check(d, machine, traj, work_chunks[-1], lo, hi, warnings)
            if bar is not None:
                bar.update(hi - lo)
        # the held forces again, vectorised from the recorded encoders (the same law, exactly)
        qpos_all = np.concatenate(qpos_chunks) if qpos_chunks else np.empty((0, nq))
        joint = qpos_all[:, list(gantry.qpos_adr)] * mm
        if stateful is not None:
            force = np.asarray(stateful.force, dtype=float).reshape(-1, 3)
        else:
            force = servo.forces(b_arr, joint, np.concatenate([joint[:1], joint[:-1]]))
        pos = np.concatenate(work_chunks) if work_chunks else np.empty((0, 3))
    finally:
        mujoco.set_mju_user_warning(previous_handler)
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - start
    pos.setflags(write=False)
    force.setflags(write=False)
    return SimTrace(pos=pos, force=force, steps=n * nsub, wall_s=wall)


def _check(
    d: Any,
    machine: MachineConfig,
    traj: Trajectory,
    work_mm: np.ndarray,
    lo: int,
    hi: int,
    warnings: list[str] | None = None,
) -> None:
    """Raise SimulationError if ticks lo..hi (tool tip ``work_mm`` [mm], work coordinates)
    diverged or lost the reference. MuJoCo's own instability warnings come first: a huge or
    non-finite actuator control (mjWARN_BADCTRL, which MuJoCo answers by zeroing the control
    and carrying on) or a bad state (BADQACC/QVEL/QPOS, answered by a reset) make the rest of
    the run meaningless even when the following error stays within its limit."""
    import mujoco

    where = f"the machine file {machine.source}" if machine.source else "the machine file"
    for w in (
        mujoco.mjtWarning.mjWARN_BADCTRL,
        mujoco.mjtWarning.mjWARN_BADQACC,
        mujoco.mjtWarning.mjWARN_BADQVEL,
        mujoco.mjtWarning.mjWARN_BADQPOS,
    ):
        if d.warning[w].number:  # the time of the fault is lost: say the chunk
            said = f": {warnings[0].strip()}" if warnings else ""
            raise SimulationError(
                f"the simulation diverged between t = {traj.t[lo]:.4f} and {traj.t[hi - 1]:.4f} s "
                f"(MuJoCo: {mujoco.mjtWarning(w).name}{said}); the servo loop is unstable: check "
                f"[servo] gains and period in {where} and the model's masses and force limits",
                line=int(traj.line[lo]),
            )
    err = np.abs(work_mm - traj.pos[lo:hi])
    limit = machine.servo.max_following_error_mm
    bad = ~(err <= limit).all(axis=1)  # beyond the limit, or NaN (no comparison holds)
    if bad.any():
        k = lo + int(np.argmax(bad))
        row = err[k - lo]
        axis = int(np.nanargmax(np.where(np.isfinite(row), row, np.inf)))
        what = "non-finite" if not np.isfinite(row[axis]) else f"{row[axis]:.4g} mm"
        raise SimulationError(
            f"following error on {AXES[axis].upper()} is {what} at t = {traj.t[k]:.4f} s, beyond "
            f"[servo] max_following_error_mm = {limit:g}: the servo lost the reference (unstable "
            f"or too weak: check [servo] gains and feedforward in {where} and the model's force "
            "limits)",
            line=int(traj.line[k]),
        )
