"""The public Python API of ``gantry run``: program text in, report and trace out.

    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.api import run_program, write_run_outputs

    result = run_program(text, file="part.ngc", machine=load_machine_config(DEFAULT_MACHINE))
    result.report["contour_error_um"]["max"]      # [um]
    write_run_outputs(result, Path("out"))        # report.json, trace.npz, path.png, error.png

Pipeline: interpret -> plan (Ruckig) -> sample at the servo period -> simulate (discrete PD in
MuJoCo) -> analyse against the commanded geometry. Errors a user can cause raise GantryError
subclasses (GcodeError, ConfigError, PlanningError, SimulationError) carrying file and line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import GantryError
from gantry_sim.sim.budget import Budget, check_budget


@dataclass(frozen=True)
class Trace:
    """Per servo tick, program (work) coordinates.

    Attributes:
        t: (N,) time [s].
        ref: (N, 3) commanded reference [mm].
        pos: (N, 3) traced tool tip from MuJoCo [mm].
        line: (N,) program line being executed.
        err_um: (N,) contour error of each traced point against the commanded geometry [um].
        nearest: (N, 3) nearest commanded point to each traced point [mm].
        feed: (N,) True on feed moves (G1/G2/G3), False on rapids.
        force_N: (N, 3) drive force held over each tick per axis [N].
    """

    t: np.ndarray
    ref: np.ndarray
    pos: np.ndarray
    line: np.ndarray
    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    force_N: np.ndarray


@dataclass(frozen=True)
class RunResult:
    """A finished run.

    Attributes:
        report: exactly the content of report.json (see README, "Running a simulation").
        trace: the per-tick arrays (trace.npz).
        moves: the interpreter's moves (the commanded geometry).
    """

    report: dict
    trace: Trace
    moves: tuple


def run_program(
    text: str,
    *,
    file: str = "<program>",
    dialect: str = "linuxcnc",
    machine: MachineConfig,
    feed_override_pct: float = 100.0,
    progress: bool = False,
    budget: Budget | None = None,
) -> RunResult:
    """Interpret, plan, simulate and analyse one program on ``machine``.

    Args:
        text: the G-code program.
        file: the program's name for error messages and the report.
        dialect: "linuxcnc", "g2core", "marlin" or "laserdyne".
        machine: the machine file (limits, travel, servo, sim).
        feed_override_pct: scales every programmed feed [%].
        progress: show a progress bar on stderr during long simulations.
        budget: the largest simulation run without asking (default: sim.budget.Budget()).

    Raises:
        GcodeError, ConfigError, PlanningError, SimulationError: with file and line;
        PlanningError also when the simulation would exceed ``budget``.
    """
    from gantry_sim.controller.gcode.interpreter import interpret
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.contour import analyse
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.report import build_report
    from gantry_sim.sim.runner import simulate

    t0 = time.perf_counter()
    try:
        moves = tuple(interpret(text, dialect, file))
        t1 = time.perf_counter()
        planned = plan(moves, machine, feed_override_pct=feed_override_pct)
        check_budget(planned, machine, budget or Budget(), file)
        traj = planned.sample(machine.servo.period_s)
        t2 = time.perf_counter()
        gantry = load_gantry(machine)
        sim = simulate(gantry, machine, traj, progress=progress)
        t3 = time.perf_counter()
        result = analyse(moves, traj.line, traj.pos, sim.pos, planned.vertices)
        t4 = time.perf_counter()
    except GantryError as exc:
        if exc.file is None and exc.line is not None:
            exc.file = file
        raise
    timing: dict[str, float] = {
        "parse": t1 - t0,
        "plan": t2 - t1,
        "simulate": t3 - t2,
        "analyse": t4 - t3,
    }
    timing["total"] = t4 - t0
    trace = Trace(
        t=traj.t,
        ref=traj.pos,
        pos=sim.pos,
        line=traj.line,
        err_um=result.err_um,
        nearest=result.nearest,
        feed=result.feed,
        force_N=sim.force,
    )
    report = build_report(
        program=file,
        dialect=dialect,
        machine=machine,
        plant=gantry.plant,
        feed_override_pct=feed_override_pct,
        planned=planned,
        traj=traj,
        sim=sim,
        analysis=result,
        timing=timing,
    )
    return RunResult(report=report, trace=trace, moves=moves)


def write_run_outputs(result: RunResult, out_dir: Path) -> None:
    """Write report.json, trace.npz, path.png and error.png into ``out_dir`` (created if needed).

    Atomic per file set: everything is written into a temporary folder beside the outputs and
    moved in only when all of it succeeded, report.json last.
    """
    from gantry_sim.sim.report import write_outputs

    write_outputs(result, Path(out_dir))
