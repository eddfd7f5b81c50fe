"""The run report: typed (:class:`RunReport`) until the JSON boundary, then report.json.

report.json keys (contract, see README "Running a simulation"): program, dialect, cycle_time_s,
contour_error_um {max, rms, p95}, parts_um {chord_max, reference_max, tracking_max}, blocks
[{line, kind, max_error_um, rms_error_um}], limits, sim {physics_timestep_s, servo_period_s, steps,
realtime_factor}, timing_s {parse, plan, simulate, analyse, total}; plus a few extra keys
(blocks[].time_s, timing_s.write, verdict). :meth:`RunReport.to_json` is the only place that
spells them; :func:`write_outputs` writes report.json, timing.json, trace.npz and the plots
(sim.plots, imported only there).

Deterministic reports: everything in report.json follows from the inputs except the wall-clock
fields timing_s.* and sim.realtime_factor. They stay in report.json (the contract) and are also
written to timing.json on every run; ``deterministic=True`` (``gantry run --deterministic``)
writes them as null in report.json, so two runs of the same input give byte-identical reports
while timing.json keeps the measurements.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from gantry_sim.controller.config import Limits, MachineConfig
from gantry_sim.controller.servo import AxisPlant
from gantry_sim.sim.contour import Analysis, BlockError, ContourStats, ErrorParts
from gantry_sim.sim.gates import Gates, Verdict
from gantry_sim.sim.json_text import indented
from gantry_sim.sim.progress import stage
from gantry_sim.sim.trace import Trace

if TYPE_CHECKING:
    from concurrent.futures import Future

    from gantry_sim.controller.moves import Move
    from gantry_sim.controller.planner.result import Plan
    from gantry_sim.controller.trajectory import Trajectory
    from gantry_sim.sim.path_outline import Outline
    from gantry_sim.sim.plot_worker import PlotWorker
    from gantry_sim.sim.runner import SimTrace
    from gantry_sim.sim.stream import StreamedRun
    from gantry_sim.sim.trace_writer import TraceWriter

#: report.json's keys that the writing of the outputs fills in: after "blocks", so that the text
#: up to there can be written while the plots are drawn (RunReport.write_json_start)
LATE_KEYS = ("timing_s", "verdict", "files")

#: files a run writes into its output folder: a new run replaces them all, those it does not
#: write (--no-plots, --no-trace) removed (sim.outdir); a failed run removes them all
OUTPUT_FILES = ("report.json", "timing.json", "trace.npz", "path.png", "error.png")
#: the plots among them (not written with ``plots=False``)
PLOT_FILES = ("path.png", "error.png")


def written_files(plots: bool = True, trace: bool = True) -> tuple[str, ...]:
    """The files of OUTPUT_FILES a run writes with these options (report.json "files")."""
    skip = (() if plots else PLOT_FILES) + (() if trace else ("trace.npz",))
    return tuple(f for f in OUTPUT_FILES if f not in skip)


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

    def to_json(self, deterministic: bool = False) -> dict[str, Any]:
        return {
            "physics_timestep_s": self.physics_timestep_s,
            "servo_period_s": self.servo_period_s,
            "steps": self.steps,
            "realtime_factor": None if deterministic else self.realtime_factor,
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
        timing_s: wall-clock time per stage ("parse", "plan", "simulate", "analyse", "write"
            once written, "total": from the start to the outputs written) [s].
        verdict: the gates' verdict (passed, no gates, until :func:`gantry_sim.sim.gates`'s
            evaluation is applied).
        files: the files written into the output folder (empty until :func:`write_outputs`);
            trace.npz is missing when the run was asked not to write it (``--no-trace``).
        limit_change_stops (a property, from ``program_limits``): Marlin limit changes planned
            as exact stops, which Marlin does not make (their decelerations and accelerations
            are in ``cycle_time_s``).
        program_limits: where Marlin's M201/M203 changed the limits, per part of the program
            the first line of its first motion and the limits it ran under (empty: ``limits``
            throughout).
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
    verdict: Verdict = field(default_factory=Verdict)
    files: tuple[str, ...] = ()
    program_limits: tuple[tuple[int, Limits], ...] = ()

    @property
    def limit_change_stops(self) -> int:
        """The joins between the parts of ``program_limits``: one exact stop each."""
        return max(len(self.program_limits) - 1, 0)

    def block(self, line: int) -> BlockError | None:
        """The block executing program line ``line`` (of the program's own file), or None when
        it is no feed block."""
        return next((b for b in self.blocks if b.line == line and b.file is None), None)

    @property
    def block_time_s(self) -> dict[int, float]:
        """Per feed block's line (of the program's own file), the time spent executing it [s]
        (servo ticks on the line x servo period)."""
        period = self.sim.servo_period_s
        return {b.line: b.ticks * period for b in self.blocks if b.file is None}

    def blocks_json(self) -> Iterator[dict[str, Any]]:
        """report.json's "blocks", one object at a time (a 100,000-block run's take 40 MB as
        dicts at once)."""
        period = self.sim.servo_period_s
        for b in self.blocks:
            item: dict[str, Any] = b.to_json()
            item["time_s"] = b.ticks * period
            yield item

    def to_json(self, deterministic: bool = False, *, blocks: bool = True) -> dict[str, Any]:
        """The report.json object (key order as written); ``deterministic``: the wall-clock
        fields (timing_s.*, sim.realtime_factor) as null (see the module docstring);
        ``blocks=False``: "blocks" left empty (:meth:`blocks_json` gives them)."""
        return {
            "program": self.program,
            "dialect": self.dialect,
            "machine": self.machine,
            "feed_override_pct": self.feed_override_pct,
            "cycle_time_s": self.cycle_time_s,
            "contour_error_um": self.contour_error_um.to_json(),
            "parts_um": self.parts_um.to_json(),
            "blocks": list(self.blocks_json()) if blocks else [],
            "limits": self.limits.to_json(),
            "moves": self.moves,
            "segments": self.segments,
            "chord_tolerance_mm": self.chord_tolerance_mm,
            "limit_change_stops": self.limit_change_stops,
            "program_limits": program_limits_json(self.program_limits),
            "sim": self.sim.to_json(deterministic),
            "timing_s": {k: None if deterministic else v for k, v in self.timing_s.items()},
            "verdict": self.verdict.to_json(),
            "files": list(self.files),
        }

    def worst_block(self) -> BlockError | None:
        """The feed block with the largest max error (the first of equals), or None."""
        return max(self.blocks, key=lambda b: b.max_error_um, default=None)

    def write_json(self, out: IO[str], deterministic: bool = False) -> None:
        """Write report.json's text to ``out``: ``json.dump(self.to_json(deterministic), out,
        indent=2)`` and a newline, character for character, with the blocks written one at a
        time (tests/test_report_json.py compares the two): :meth:`write_json_start` then
        :meth:`write_json_end`."""
        self.write_json_start(out, deterministic)
        self.write_json_end(out, deterministic)

    def write_json_start(self, out: IO[str], deterministic: bool = False) -> None:
        """report.json's text up to its "blocks" (those included): nothing there depends on
        the outputs' writing (:data:`LATE_KEYS` come after), so it can be written while the
        plots are drawn elsewhere, and finished by :meth:`write_json_end` of this report with
        its timing and files filled in."""
        head = self.to_json(deterministic, blocks=False)
        keys = list(head)
        out.write("{\n")
        self._write_keys(out, head, keys[: keys.index("blocks") + 1], keys[-1])

    def write_json_end(self, out: IO[str], deterministic: bool = False) -> None:
        """The rest of report.json's text after :meth:`write_json_start`."""
        head = self.to_json(deterministic, blocks=False)
        keys = list(head)
        self._write_keys(out, head, keys[keys.index("blocks") + 1 :], keys[-1])
        out.write("}\n")

    def _write_keys(self, out: IO[str], head: dict[str, Any], keys: list[str], last: str) -> None:
        """The members ``keys`` of the object ``head`` (``last``: the object's last key), the
        blocks one at a time."""
        for key in keys:
            out.write(f"  {json.dumps(key)}: ")
            if key == "blocks" and self.blocks:
                out.write("[")
                for i, item in enumerate(self.blocks_json()):
                    out.write(",\n    " if i else "\n    ")
                    out.write(_indented(indented(item), "    "))
                out.write("\n  ]")
            else:
                out.write(_indented(json.dumps(head[key], indent=2), "  "))
            out.write("\n" if key == last else ",\n")

    def timing_json(self) -> dict[str, Any]:
        """timing.json: the wall-clock fields of report.json, always measured."""
        return {
            "program": self.program,
            "timing_s": dict(self.timing_s),
            "realtime_factor": self.sim.realtime_factor,
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
    limit = force_limits_N(plant)
    saturated = (force >= limit * (1 - 1e-12)).mean(axis=0) if force.size else np.zeros(3)
    max_force = force.max(axis=0) if force.size else np.zeros(3)
    return _report(
        program=program,
        dialect=dialect,
        machine=machine,
        feed_override_pct=feed_override_pct,
        planned=planned,
        realtime=float(traj.duration_s / sim.wall_s) if sim.wall_s > 0 else 0.0,
        steps=int(sim.steps),
        max_force=max_force,
        saturated=saturated,
        analysis=analysis,
        timing=timing,
    )


def build_streamed_report(
    *,
    program: str,
    dialect: str,
    machine: MachineConfig,
    steps: int,
    feed_override_pct: float,
    planned: Plan,
    streamed: StreamedRun,
    timing: dict[str, float],
) -> RunReport:
    """:func:`build_report` of a streamed run (sim.stream): the same figures from its running
    maxima and counts (the saturated fraction is count / ticks, as the mean of the flags)."""
    ticks = max(streamed.ticks, 1)
    sim_s = streamed.simulate_s
    return _report(
        program=program,
        dialect=dialect,
        machine=machine,
        feed_override_pct=feed_override_pct,
        planned=planned,
        realtime=float(streamed.duration_s / sim_s) if sim_s > 0 else 0.0,
        steps=steps,
        max_force=streamed.max_force_N,
        saturated=streamed.saturated_ticks / ticks if streamed.ticks else np.zeros(3),
        analysis=streamed.analysis,
        timing=timing,
    )


def force_limits_N(plant: Sequence[AxisPlant]) -> np.ndarray:
    """(3,) the smaller of |force_min| and force_max per axis [N] (a tick at it is saturated)."""
    return np.array([[-p.force_min_N, p.force_max_N] for p in plant]).min(axis=1)


def _report(
    *,
    program: str,
    dialect: str,
    machine: MachineConfig,
    feed_override_pct: float,
    planned: Plan,
    realtime: float,
    steps: int,
    max_force: np.ndarray,
    saturated: np.ndarray,
    analysis: Analysis,
    timing: dict[str, float],
) -> RunReport:
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
        program_limits=planned.part_limits,
        chord_tolerance_mm=float(planned.chord_tolerance_mm),
        sim=SimStats(
            physics_timestep_s=machine.sim.physics_timestep_s,
            servo_period_s=machine.servo.period_s,
            steps=steps,
            realtime_factor=realtime,
            model=machine.sim.model,
            max_force_N=_vec3(max_force),
            saturated_fraction=_vec3(saturated),
        ),
        timing_s={k: float(v) for k, v in timing.items()},
    )


def _vec3(values: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def write_outputs(
    report: RunReport,
    trace: Trace,
    moves: Sequence[Move],
    out_dir: Path,
    *,
    plots: bool = True,
    deterministic: bool = False,
    gates: Gates | None = None,
    started: float | None = None,
    full_trace: TraceWriter | None = None,
    outline: Future[Outline | None] | None = None,
    trace_npz: bool = True,
    progress: bool = False,
    plotter: PlotWorker | None = None,
) -> RunReport:
    """Write the run's files into a temporary folder, then move them in, report.json last.

    Args:
        trace: the arrays plotted, and written as trace.npz unless ``full_trace`` is given.
        full_trace: a streamed run's full-rate trace, deflated during the run (``trace`` is
            then its decimated one), written as trace.npz (sim.trace_writer).
        outline: path.png's commanded geometry, computed during the run (sim.path_outline).
        plots: draw path.png and error.png.
        trace_npz: write trace.npz (False: ``--no-trace``; the plots still use ``trace``).
        progress: a bar on stderr over the files (sim.progress).
        plotter: the run's plot worker (sim.plot_worker), which then draws the plots while
            the other files are written; None: drawn here (sim.plot_files).
        deterministic: wall-clock fields null in report.json (timing.json has them).
        gates: drawn on error.png.
        started: ``time.perf_counter()`` when the run started (the command's start); "total"
            counts from there to the outputs written. None: the stages' sum.

    Returns:
        ``report`` with timing_s "write" (trace, plots, files) and "total" filled in, and
        ``files``.
    """
    from gantry_sim.sim.outdir import atomic_output_dir
    from gantry_sim.sim.plot_files import Plots

    t0 = time.perf_counter()
    files = written_files(plots, trace_npz)
    with (
        atomic_output_dir(out_dir, last="report.json", owns=OUTPUT_FILES) as tmp,
        stage("write", len(files), "file", progress) as advance,
    ):
        drawn = None
        if plots:
            drawn = Plots(
                tmp, trace, report.program, report.contour_error_um, moves, outline, gates, plotter
            )
        with (tmp / "report.json").open("w", encoding="utf-8") as out:
            # written block by block: json.dumps with indent lists every piece of the text
            # first (about 1.3 KB a block, 130 MB at 100,000 blocks), and the blocks as dicts
            # took 40 MB more
            started_json = False
            try:
                if trace_npz:
                    _write_trace_npz(tmp / "trace.npz", trace, full_trace)
                advance(int(trace_npz))
                if drawn is not None and drawn.elsewhere:
                    # this process waits for the plot worker: the report's text up to its
                    # blocks meanwhile (0.11 s at 10,000 blocks)
                    report.write_json_start(out, deterministic)
                    started_json = True
                if drawn is not None:
                    drawn.finish(advance)
            finally:
                if drawn is not None:
                    drawn.close()  # nothing draws into the folder once committed or removed
            t1 = time.perf_counter()
            timing = {k: v for k, v in report.timing_s.items() if k not in ("write", "total")}
            timing["write"] = t1 - t0
            stages = sum(timing.values())
            timing["total"] = (t1 - started) if started is not None else stages
            report = replace(report, timing_s=timing, files=files)
            (tmp / "timing.json").write_text(json.dumps(report.timing_json(), indent=2) + "\n")
            if started_json:
                report.write_json_end(out, deterministic)
            else:
                report.write_json(out, deterministic)
        advance(2)
    return report


def _write_trace_npz(path: Path, trace: Trace, full_trace: TraceWriter | None) -> None:
    """trace.npz: a streamed run's full-rate trace (deflated during the run), else ``trace``."""
    if full_trace is not None:
        full_trace.save(path)
        return
    from gantry_sim.sim.trace_writer import save_npz

    fields = {
        "t": trace.t,
        "ref": trace.ref,
        "pos": trace.pos,
        "line": trace.line,
        "err_um": trace.err_um,
        "force_N": trace.force_N,
    }
    save_npz(path, fields)


def _indented(text: str, pad: str) -> str:
    """``text`` (a JSON value, indented from column 0) with every line after its first indented
    by ``pad``: the value as json.dump writes it at that depth."""
    return text.replace("\n", "\n" + pad)


def program_limits_json(parts: Sequence[tuple[int, Limits]]) -> list[dict[str, Any]]:
    """report.json's and ``gantry plan``'s "program_limits": per part, "from_line" and the
    limits it ran under."""
    return [{"from_line": line, **limits.to_json()} for line, limits in parts]
