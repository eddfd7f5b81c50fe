"""The public Python API of ``gantry run``: program text in, report and trace out.

    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.api import run_program, write_run_outputs

    result = run_program(text, file="part.ngc", machine=load_machine_config(DEFAULT_MACHINE))
    result.report["contour_error_um"]["max"]      # [um], report.json's dict
    result.run_report.contour_error_um.max_um     # [um], the same, typed (sim.report.RunReport)
    write_run_outputs(result, Path("out"))        # report.json, trace.npz, path.png, error.png

Pipeline: interpret -> plan (Ruckig) -> sample at the servo period -> simulate (discrete PD in
MuJoCo) -> analyse against the commanded geometry. Errors a user can cause raise GantryError
subclasses (GcodeError, ConfigError, PlanningError, SimulationError) carrying file and line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import GantryError
from gantry_sim.sim.report import RunReport
from gantry_sim.sim.trace import Trace


@dataclass(frozen=True)
class RunResult:
    """A finished run.

    Attributes:
        run_report: the report, typed (sim.report.RunReport); :attr:`report` is its JSON form.
        trace: the per-tick arrays (trace.npz).
        moves: the interpreter's moves (the commanded geometry).
    """

    run_report: RunReport
    trace: Trace
    moves: tuple

    @cached_property
    def report(self) -> dict:
        """Exactly the content of report.json (see README, "Running a simulation")."""
        return self.run_report.to_json()


def run_program(
    text: str,
    *,
    file: str = "<program>",
    dialect: str = "linuxcnc",
    machine: MachineConfig,
    feed_override_pct: float = 100.0,
    progress: bool = False,
) -> RunResult:
    """Interpret, plan, simulate and analyse one program on ``machine``.

    Args:
        text: the G-code program.
        file: the program's name for error messages and the report.
        dialect: "linuxcnc", "g2core", "marlin" or "laserdyne".
        machine: the machine file (limits, travel, servo, sim).
        feed_override_pct: scales every programmed feed [%].
        progress: show a progress bar on stderr during long simulations.

    Raises:
        GcodeError, ConfigError, PlanningError, SimulationError: with file and line.
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
    return RunResult(run_report=report, trace=trace, moves=moves)


def write_run_outputs(result: RunResult, out_dir: Path) -> None:
    """Write report.json, trace.npz, path.png and error.png into ``out_dir`` (created if needed).

    Atomic per file set: everything is written into a temporary folder beside the outputs and
    moved in only when all of it succeeded, report.json last.
    """
    from gantry_sim.sim.report import write_outputs

    write_outputs(result.run_report, result.trace, result.moves, Path(out_dir))
