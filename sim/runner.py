"""The simulation of a run: sim.servo_loop's ticks range after range, each range checked.

Every CHUNK ticks the recorded qpos rows become tool-site positions in one pass
(Gantry.tool_site_m: a closed form checked against MuJoCo when only slides carry the site,
mj_kinematics per row otherwise) and the range is checked: non-finite values, MuJoCo's
instability warnings, or a following error beyond [servo] max_following_error_mm raise
:class:`SimulationError` -- a diverged run is not a result.

:func:`simulate_pieces` takes the reference piece after piece (a streaming run samples the plan
one range at a time) and yields each piece's trace; :func:`simulate` runs a whole trajectory.
Both step the same loop through the same ranges, so their numbers are the same bit for bit.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import SimulationError
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.machine import AXES, Gantry
from gantry_sim.sim.progress import stage, wanted
from gantry_sim.sim.servo_loop import ServoLoop

#: servo ticks between divergence checks (and tool-site passes, progress-bar updates): large
#: enough that the per-range numpy work is a small part of the tick's cost
CHUNK = 8192


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


def simulate_pieces(
    gantry: Gantry,
    machine: MachineConfig,
    pieces: Iterable[Trajectory],
    start_work_mm: np.ndarray,
    on_ticks: Any = None,
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Run the servo along the reference given piece after piece (consecutive samples of one
    trajectory); yield per piece (tool tip (n, 3) in work coordinates [mm], held force (n, 3)
    [N]). The machine starts at rest at ``start_work_mm`` [mm] (the first sample). Raises
    SimulationError (with the program line being executed) when the run diverges.
    ``on_ticks(n)`` is called after every checked range (a progress bar's update)."""
    import mujoco

    loop = ServoLoop(gantry, machine, gantry.work_to_joint_mm(np.asarray(start_work_mm)))
    # MuJoCo's warnings (e.g. "Nan, Inf or huge value in CTRL") would go to stdout and to
    # ./MUJOCO_LOG.TXT; collect them instead: each range's check turns them into an error
    warnings: list[str] = []
    previous_handler = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)
    try:
        for piece in pieces:
            n = piece.t.size
            pos_parts, force_parts = [], []
            for lo in range(0, n, CHUNK):
                hi = min(n, lo + CHUNK)
                qpos, force = loop.run(
                    gantry.work_to_joint_mm(piece.pos[lo:hi]), piece.vel[lo:hi], piece.acc[lo:hi]
                )
                work = gantry.tool_to_work_mm(gantry.tool_site_m(qpos))
                _check(loop.data, machine, piece, work, lo, hi, warnings)
                pos_parts.append(work)
                force_parts.append(force)
                if on_ticks is not None:
                    on_ticks(hi - lo)
            yield _join(pos_parts), _join(force_parts)
    finally:
        mujoco.set_mju_user_warning(previous_handler)


def _join(parts: list[np.ndarray]) -> np.ndarray:
    return parts[0] if len(parts) == 1 else np.concatenate(parts) if parts else np.empty((0, 3))


def simulate(
    gantry: Gantry,
    machine: MachineConfig,
    traj: Trajectory,
    *,
    progress: bool | None = None,
) -> SimTrace:
    """Run the servo against MuJoCo along ``traj`` and trace the tool tip; ``progress``: a
    bar on stderr (sim.progress; None: when stderr is a terminal).

    The machine starts at rest at the trajectory's first sample. Raises SimulationError (with
    the program line being executed) when the run diverges.
    """
    n = traj.t.size
    start = time.perf_counter()
    with stage("simulate", n, "tick", wanted(progress)) as advance:
        start_mm = traj.pos[0] if n else np.zeros(3)
        pieces = (traj.slice(lo, min(n, lo + CHUNK)) for lo in range(0, n, CHUNK))
        out = list(simulate_pieces(gantry, machine, pieces, start_mm, advance))
    pos = _join([p for p, _ in out])
    force = _join([f for _, f in out])
    wall = time.perf_counter() - start
    pos.setflags(write=False)
    force.setflags(write=False)
    return SimTrace(pos=pos, force=force, steps=n * gantry.substeps, wall_s=wall)


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
                move=_move_at(traj, lo),
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
            move=_move_at(traj, k),
        )


def _move_at(traj: Trajectory, k: int) -> int | None:
    """The program move sample ``k`` executes (Trajectory.source), or None where not known."""
    if traj.source is None:
        return None
    first = int(np.asarray(traj.source).reshape(-1, 2)[k, 0])
    return first if first >= 0 else None
