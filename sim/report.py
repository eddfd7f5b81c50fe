"""The run report: typed (:class:`RunReport`) until the JSON boundary, then report.json.

report.json keys (contract, see README "Running a simulation"): program, dialect, cycle_time_s,
contour_error_um {max, rms, p95}, parts_um {chord_max, reference_max, tracking_max}, blocks
[{line, kind, max_error_um, rms_error_um}], limits, sim {physics_timestep_s, servo_period_s, steps,
realtime_factor}, timing_s {parse, plan, simulate, analyse, total}; plus a few extra keys.
:meth:`RunReport.to_json` is the only place that spells them; :func:`write_outputs` writes
report.json, trace.npz and the plots (sim.plots, imported only there).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gantry_sim.controller.config import Limits, MachineConfig
from gantry_sim.controller.servo import AxisPlant
from gantry_sim.sim.contour import Analysis, BlockError, ContourStats, ErrorParts
from gantry_sim.sim.trace import Trace

if TYPE_CHECKING:
    from gantry_sim.controller.moves import Move
    from gantry_sim.controller.planner.result import Plan
    from gantry_sim.controller.trajectory import Trajectory
    from gantry_sim.sim.runner import SimTrace

#: files a run writes into its output folder (removed first by `gantry run`: no stale report)
OUTPUT_FILES = ("report.json", "trace.npz", "path.png", "error.png")


@dataclass(frozen=True)
class SimStats:
    """How the simulation ran (report.json "sim").

    Attributes:
        physics_timestep_s: MuJoCo's step [s].
        servo_period_s: the servo's period [s].
        steps: physics steps taken.
        realtime_factor: simulated time / wall-clock time of the loop (0 when unmeasurable).
        model: the MJCF file simulated.
        max_force_N: largest drive force magnitude per axis x, y, z [N].
        saturated_fraction: per axis, the fraction of servo ticks at the force limit.
    """

    physics_timestep_s: float
    servo_period_s: float
    steps: int
    realtime_factor: float
    model: str
    max_force_N: tuple[float, float, float]
    saturated_fraction: tuple[float, float, float]

    def to_json(self) -> dict[str, Any]:
        return {
            "physics_timestep_s": self.physics_timestep_s,
            "servo_period_s": self.servo_period_s,
            "steps": self.steps,
            "realtime_factor": self.realtime_factor,
            "model": self.model,
            "max_force_N": list(self.max_force_N),
            "saturated_fraction": list(self.saturated_fraction),
        }


@dataclass(frozen=True)
class RunReport:
    """Everything report.json says about a run, typed (errors [um], times [s], lengths [mm]).

    Attributes:
        program: the program's name (file).
        dialect: the G-code dialect interpreted.
        machine: the machine file(s) read (MachineConfig.source).
        feed_override_pct: the feed override applied [%].
        cycle_time_s: the planned duration, rest to rest [s].
        contour_error_um: contour error statistics over the feed moves.
        parts_um: the largest chord, reference and tracking parts.
        blocks: per feed block in program order.
        limits: the kinematic limits planned with.
        moves: number of moves interpreted.
        segments: chords and straight pieces planned.
        chord_tolerance_mm: the machine's chord tolerance [mm].
        sim: how the simulation ran.
        timing_s: wall-clock time per stage ("parse", "plan", "simulate", "analyse", "total") [s].
    """

    program: str
    dialect: str
    machine: str
    feed_override_pct: float
    cycle_time_s: float
    contour_error_um: ContourStats
    parts_um: ErrorParts
    blocks: tuple[BlockError, ...]
    limits: Limits
    moves: int
    segments: int
    chord_tolerance_mm: float
    sim: SimStats
    timing_s: dict[str, float]

    def block(self, line: int) -> BlockError | None:
        """The block executing program line ``line``, or None when it is no feed block."""
        return next((b for b in self.blocks if b.line == line), None)

    def to_json(self) -> dict[str, Any]:
        """The report.json object (key order as written)."""
        return {
            "program": self.program,
            "dialect": self.dialect,
            "machine": self.machine,
            "feed_override_pct": self.feed_override_pct,
            "cycle_time_s": self.cycle_time_s,
            "contour_error_um": self.contour_error_um.to_json(),
            "parts_um": self.parts_um.to_json(),
            "blocks": [b.to_json() for b in self.blocks],
            "limits": self.limits.to_json(),
            "moves": self.moves,
            "segments": self.segments,
            "chord_tolerance_mm": self.chord_tolerance_mm,
            "sim": self.sim.to_json(),
            "timing_s": dict(self.timing_s),
        }


def build_report(
    *,
    program: str,
    dialect: str,
    machine: MachineConfig,
    plant: Sequence[AxisPlant],
    feed_override_pct: float,
    planned: Plan,
    traj: Trajectory,
    sim: SimTrace,
    analysis: Analysis,
    timing: dict[str, float],
) -> RunReport:
    """The report of one run: the plan's figures, the simulation's and the analysis's."""
    force = np.abs(sim.force)
    limit = np.array([[-p.force_min_N, p.force_max_N] for p in plant]).min(axis=1)
    saturated = (force >= limit * (1 - 1e-12)).mean(axis=0) if force.size else np.zeros(3)
    max_force = force.max(axis=0) if force.size else np.zeros(3)
    return RunReport(
        program=program,
        dialect=dialect,
        machine=machine.source,
        feed_override_pct=float(feed_override_pct),
        cycle_time_s=float(planned.duration_s),
        contour_error_um=analysis.contour,
        parts_um=analysis.parts,
        blocks=analysis.blocks,
        limits=machine.limits,
        moves=len(planned.moves),
        segments=int(planned.segment_count),
        chord_tolerance_mm=float(planned.chord_tolerance_mm),
        sim=SimStats(
            physics_timestep_s=machine.sim.physics_timestep_s,
            servo_period_s=machine.servo.period_s,
            steps=int(sim.steps),
            realtime_factor=float(traj.duration_s / sim.wall_s) if sim.wall_s > 0 else 0.0,
            model=machine.sim.model,
            max_force_N=_vec3(max_force),
            saturated_fraction=_vec3(saturated),
        ),
        timing_s={k: float(v) for k, v in timing.items()},
    )


def _vec3(values: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def write_outputs(report: RunReport, trace: Trace, moves: Sequence[Move], out_dir: Path) -> None:
    """Write the run's files into a temporary folder, then move them in, report.json last."""
    from gantry_sim.sim.outdir import atomic_output_dir
    from gantry_sim.sim.plots import save_error_plot, save_path_plot

    with atomic_output_dir(out_dir, last="report.json") as tmp:
        (tmp / "report.json").write_text(json.dumps(report.to_json(), indent=2) + "\n")
        np.savez_compressed(
            tmp / "trace.npz",
            t=trace.t,
            ref=trace.ref,
            pos=trace.pos,
            line=trace.line,
            err_um=trace.err_um,
            force_N=trace.force_N,
        )
        save_path_plot(tmp / "path.png", moves, trace, report.program, report.contour_error_um)
        save_error_plot(tmp / "error.png", trace, report.contour_error_um)
