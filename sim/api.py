"""The public Python API of ``gantry run``: a program (file or text) in, report and trace out.

    from pathlib import Path
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.api import run_program, write_run_outputs

    machine = load_machine_config(DEFAULT_MACHINE)
    result = run_program(Path("part.ngc"), machine=machine)   # a Path: the file is read
    result = run_program(text, file="part.ngc", machine=machine)  # a str: the program text
    result = run_program(Path("part.ngc"), machine=machine, search_path=[Path("lib")])
    result.report["contour_error_um"]["max"]      # [um], report.json's dict
    result.run_report.contour_error_um.max_um     # [um], the same, typed (sim.report.RunReport)
    result = write_run_outputs(result, Path("out"))  # report.json, timing.json, trace.npz, plots

Pipeline: interpret -> plan (Ruckig) -> sample at the servo period -> simulate (discrete PD in
MuJoCo) -> analyse against the commanded geometry. Errors a user can cause raise GantryError
subclasses (GcodeError, ConfigError, PlanningError, SimulationError) carrying file and line.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import GantryError, GcodeError, PlanningError, SimulationError
from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS
from gantry_sim.sim.budget import Budget, ParseBound, check_budget
from gantry_sim.sim.gates import Gates, Verdict
from gantry_sim.sim.progress import stage, wanted
from gantry_sim.sim.report import RunReport
from gantry_sim.sim.trace import Trace

if TYPE_CHECKING:
    from concurrent.futures import Future

    from gantry_sim.controller.moves import Move
    from gantry_sim.sim.analysis_worker import ProcessAnalyser
    from gantry_sim.sim.path_outline import Outline
    from gantry_sim.sim.plot_worker import PlotWorker
    from gantry_sim.sim.trace_writer import TraceWriter

#: runs longer than this [servo ticks] are streamed (sim.stream): the same numbers, in memory
#: bounded by sim.stream.STREAM_TICKS; their RunResult.trace is decimated (trace.npz is not),
#: every tick of it below sim.stream.DECIMATED_TICKS x 2. Streamed, a run's analysis and its
#: trace.npz's deflating overlap its simulation, beside a worker process that takes 0.3-0.5 s
#: to start: 131,000 ticks (1,000 tangent arcs) ran in 2.5 s instead of 3.0 streamed, 65,000
#: in 1.7 instead of 1.8 s, and 35,000 (1,000 short G1) in 1.5 s instead of 1.3.
STREAM_ABOVE_TICKS = 65_536


@dataclass(frozen=True)
class RunResult:
    """A finished run.

    Attributes:
        run_report: the report, typed (sim.report.RunReport); :attr:`report` is its JSON form.
        trace: the per-tick arrays (trace.npz).
        moves: the interpreter's moves (the commanded geometry): a sequence kept on disk in
            blocks (:class:`~gantry_sim.controller.spill.SpilledList`), so a long program's
            moves take no memory.
    """

    run_report: RunReport
    trace: Trace
    moves: Sequence[Move]
    #: a streamed run's full-rate trace, deflated in anonymous temporary files (the run is then
    #: too long to hold: :attr:`trace` is its decimated trace); ``full_trace.save(path)`` writes
    #: it as trace.npz. None when :attr:`trace` is complete, or with ``keep_trace=False``.
    full_trace: TraceWriter | None = field(default=None, repr=False, compare=False)
    #: the run was streamed (sim.stream): :attr:`trace` is decimated
    streamed: bool = False
    #: path.png's commanded geometry, computed in a thread during the run (sim.path_outline);
    #: None: computed where the plot is drawn
    outline: Future[Outline | None] | None = field(default=None, repr=False, compare=False)
    #: the worker process that draws the plots (run_program(plots=True)), closed by
    #: write_run_outputs (or when the result is garbage collected); None: drawn in this process
    plotter: PlotWorker | None = field(default=None, repr=False, compare=False)

    @cached_property
    def report(self) -> dict:
        """Exactly the content of report.json (see README, "Running a simulation")."""
        return self.run_report.to_json()


def run_program(
    program: str | os.PathLike[str],
    *,
    file: str | None = None,
    dialect: str = "linuxcnc",
    machine: MachineConfig,
    feed_override_pct: float = 100.0,
    progress: bool | None = False,
    budget: Budget | None = None,
    search_path: Sequence[os.PathLike[str]] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    keep_trace: bool = True,
    plots: bool | None = None,
    plot_worker: PlotWorker | None = None,
) -> RunResult:
    """Interpret, plan, simulate and analyse one program on ``machine``.

    Args:
        program: a ``pathlib.Path`` (any ``os.PathLike``): the G-code file, read as UTF-8 text
            (an unreadable file is a GcodeError naming it); a ``str``: the program TEXT itself.
            A one-line str naming an existing file is refused (a GcodeError that says to pass
            ``Path(...)``), since running a file name as G-code would fail obscurely.
        file: the program's name for error messages and the report (default: the path, or
            "<program>" for text).
        dialect: "linuxcnc", "g2core", "marlin", "laserdyne" or "grbl".
        machine: the machine file (limits, travel, servo, sim; its ``work`` holds the tool
            table and the offsets the program starts from, e.g. ``work.placed((x, y, z))``).
            Unless the machine file set a [segmentation], the dialect's own applies (grbl:
            chords within 0.002 mm; marlin: 1 mm segments).
        feed_override_pct: scales every programmed feed [%].
        progress: bars on stderr for the stages that take long (sim.progress); None: when
            stderr is a terminal.
        budget: the largest simulation run without asking (default: sim.budget.Budget()).
        search_path: folders searched for ``NAME.ngc`` subroutine files, after the program's
            own folder when ``program`` is a path.
        max_iterations: bound on O-word loop repetitions and subroutine calls.
        keep_trace: keep the full-rate trace for trace.npz. False (``--no-trace``): a streamed run
            writes no staging trace (gigabytes for hours of machine time); the result's
            ``trace`` is still there for the plots (a streamed run's is the decimated one),
            and nothing else changes.
        plots: whether write_run_outputs will draw path.png and error.png. True: the process
            that draws them starts now (sim.plot_worker: it imports matplotlib, 0.7-0.9 s of
            CPU, on the second core while the run goes on; ``gantry run`` does, unless
            ``--no-plots``). False: nothing of the plots is prepared (``--no-plots``). None:
            not known; their outline and imports are prepared in a thread of this process
            (sim.plot_prep). The plots are the same in every case, and drawn whenever asked.
        plot_worker: the plots' worker, started by the caller before its own imports
            (sim.plot_worker.early_plot_worker(program), as ``gantry run`` does); the run
            closes it. Given, ``plots`` is True.

    Raises:
        GcodeError, ConfigError, PlanningError, SimulationError: with file and line;
        PlanningError also when the simulation would exceed ``budget``.
    """
    from gantry_sim.sim.plot_worker import early_plot_worker

    plotter = plot_worker
    try:
        if plotter is None and plots:
            plotter = early_plot_worker(program)  # started now if short, else after the parse
        return _run(
            program,
            file,
            dialect,
            machine,
            feed_override_pct,
            progress,
            budget,
            search_path,
            max_iterations,
            keep_trace,
            plots is not False or plotter is not None,
            plotter,
        )
    except BaseException:
        if plotter is not None:
            plotter.close()
        raise


def _run(
    program: str | os.PathLike[str],
    file: str | None,
    dialect: str,
    machine: MachineConfig,
    feed_override_pct: float,
    progress: bool | None,
    budget: Budget | None,
    search_path: Sequence[os.PathLike[str]],
    max_iterations: int,
    keep_trace: bool,
    prepare_plots: bool,
    plotter: PlotWorker | None,
) -> RunResult:
    """run_program's work; ``prepare_plots``: prepare the plots' outline (and imports, when
    no ``plotter`` draws them) during the run."""
    from gantry_sim.controller.gc_pause import gc_paused
    from gantry_sim.controller.gcode.dialects import with_segmentation_default
    from gantry_sim.controller.moves import Arc, Linear, Rapid, Spline
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.controller.spill import SpilledList
    from gantry_sim.sim.analysis_worker import early_worker
    from gantry_sim.sim.blend_parts import split_reference
    from gantry_sim.sim.contour import analyse
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.program import checked_placement, interpret_program
    from gantry_sim.sim.report import build_report
    from gantry_sim.sim.runner import simulate

    t0 = time.perf_counter()
    text, file = _program_text(program, file)
    folders = [Path(p) for p in search_path]
    if isinstance(program, os.PathLike):
        folders.insert(0, Path(program).resolve().parent)
    worker = early_worker(len(text))  # a long run's analysis worker, started while it parses
    try:
        machine = with_segmentation_default(machine, dialect)
        shown = wanted(progress)
        # the duration bound taken as the program is read: a program already too long for
        # the budget is refused as soon as its read part is; the bound's check may find the
        # program leaving the travel first
        bound = ParseBound(machine, budget or Budget(), file, feed_override_pct)

        def placed(exc: PlanningError, text: str) -> GantryError:
            """``exc``, its suggested work offset checked on the program ``text``
            (sim.program.checked_placement)."""
            return checked_placement(
                exc,
                text,
                dialect=dialect,
                machine=machine,
                search_path=folders,
                max_iterations=max_iterations,
            )

        try:
            with stage("parse", text.count("\n") + 1, "line", shown) as advance, gc_paused():
                items = interpret_program(
                    text,
                    dialect=dialect,
                    file=file,
                    machine=machine,
                    search_path=folders,
                    max_iterations=max_iterations,
                    events=True,
                    advance=advance,
                    watch=bound,
                )
        except PlanningError as exc:
            raise placed(exc, text) from None
        moves = SpilledList(m for m in items if isinstance(m, Rapid | Linear | Arc | Spline))
        t1 = time.perf_counter()
        if plotter is not None:
            plotter.start()  # a long program's after its parse (sim.plot_worker)
        try:
            bound.check(items)  # the whole program's bound (sim.budget.check_lower_bound)
            with stage("plan", len(items), "move", shown, ticking=True) as advance:
                planned = plan(items, machine, feed_override_pct=feed_override_pct, advance=advance)
        except PlanningError as exc:
            raise placed(exc, text) from None
        del items, text  # the moves are on disk now (``moves``); the run needs neither
        check_budget(planned, machine, budget or Budget(), file)
        if planned.sample_count(machine.servo.period_s) > STREAM_ABOVE_TICKS:
            return _streamed(
                moves,
                planned,
                machine,
                file,
                dialect,
                feed_override_pct,
                progress,
                {"parse": t1 - t0, "plan": time.perf_counter() - t1},
                keep_trace,
                worker,
                plotter,
                prepare_plots,
            )
        if worker is not None:  # not streamed: no worker (closed before the simulation)
            worker.close()
        traj = planned.sample(machine.servo.period_s)
        t2 = time.perf_counter()
        gantry = load_gantry(machine)  # mujoco imported before the plots' thread imports
        drawing = _prepared_plots(moves, prepare_plots, plotter)
        sim = simulate(gantry, machine, traj, progress=progress)
        t3 = time.perf_counter()
        with stage("analyse", traj.t.size, "tick", shown, known_size=False):
            result = analyse(moves, traj.line, traj.pos, sim.pos, planned.vertices, traj.source)
            result = split_reference(result, planned, traj)
        t4 = time.perf_counter()
    except GantryError as exc:
        if isinstance(exc, SimulationError) and exc.file is None and exc.move is not None:
            exc.file = _move_file(moves, exc.move)  # a subroutine file's line names its file
        if exc.file is None and exc.line is not None:
            exc.file = file
        raise
    finally:
        if worker is not None:  # (streamed, the run closed it already: closing is idempotent)
            worker.close()
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
    return RunResult(run_report=report, trace=trace, moves=moves, outline=drawing, plotter=plotter)


def _streamed(
    moves: Sequence[Move],
    planned,
    machine: MachineConfig,
    file: str,
    dialect: str,
    feed_override_pct: float,
    progress: bool | None,
    timing: dict[str, float],
    keep_trace: bool = True,
    worker: ProcessAnalyser | None = None,
    plotter: PlotWorker | None = None,
    prepare_plots: bool = True,
) -> RunResult:
    """run_program's path for long runs: sim.stream range by range, the full-rate trace
    deflated as it comes (sim.trace_writer) unless ``keep_trace`` is False, a decimated trace
    kept; ``worker``: the analysis worker started for it (sim.analysis_worker.early_worker; the
    run closes it), or None: one is started now where it pays; ``plotter``: the run's plot
    worker, or None (drawn here); ``prepare_plots``: False for no plots."""

    from gantry_sim.controller.gc_pause import gc_frozen
    from gantry_sim.controller.heap import one_arena
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.report import build_streamed_report
    from gantry_sim.sim.stream import stream_run
    from gantry_sim.sim.trace_writer import TraceWriter

    entered = time.perf_counter()
    n = planned.sample_count(machine.servo.period_s)
    one_arena()  # the run's threads on the main heap (controller/heap.py)
    writer = TraceWriter(n) if keep_trace else None
    try:
        gantry = load_gantry(machine)  # mujoco imported before the plots' thread imports
        drawing = _prepared_plots(moves, prepare_plots, plotter)
        with stage("simulate+analyse", n, "tick", wanted(progress)) as advance, gc_frozen():
            streamed = stream_run(
                moves, planned, machine, gantry, on_range=writer, on_ticks=advance, worker=worker
            )
    except BaseException:
        if writer is not None:
            writer.close()  # its thread and files
        raise
    t0 = time.perf_counter()
    if writer is not None:
        with stage("trace.npz", 1, "file", wanted(progress), known_size=False):
            writer.finish()
    # "simulate" holds the set-up as the whole run's does (the model's load, the plots'
    # preparation; here also the range tables' index and the workers' start): the stages
    # add up to the wall time
    timing["simulate"] = t0 - entered - streamed.analyse_s
    timing["analyse"] = streamed.analyse_s
    timing["trace"] = time.perf_counter() - t0
    timing["total"] = sum(timing.values())
    report = build_streamed_report(
        program=file,
        dialect=dialect,
        machine=machine,
        steps=n * gantry.substeps,
        feed_override_pct=feed_override_pct,
        planned=planned,
        streamed=streamed,
        timing=timing,
    )
    return RunResult(
        report,
        streamed.decimated,
        moves,
        outline=drawing,
        full_trace=writer,
        streamed=True,
        plotter=plotter,
    )


def _prepared_plots(
    moves: Sequence[Move], prepare: bool, plotter: PlotWorker | None
) -> Future[Outline | None] | None:
    """The plots' outline (and imports, when no ``plotter`` draws them) prepared in a thread
    (sim.plot_prep); None when not ``prepare`` (no plots), or when the ``plotter`` computes the
    outline (PlotWorker.send_outline: the moves kept on disk go to it as their pickled
    blocks)."""
    if not prepare:
        return None
    from gantry_sim.controller.spill import SpilledList
    from gantry_sim.sim.plot_prep import prepare_plots

    if (
        plotter is not None
        and isinstance(moves, SpilledList)
        and plotter.send_outline(moves.pickled(0, len(moves)))
    ):
        return None

    return prepare_plots(moves, imports=plotter is None)


def _move_file(moves: Sequence[Move], index: int) -> str | None:
    """The subroutine file of program move ``index`` (None: the program's own, or no such
    move)."""
    return moves[index].file if 0 <= index < len(moves) else None


def _program_text(program: str | os.PathLike[str], file: str | None) -> tuple[str, str]:
    """(text, name) of ``program``: a path is read, a str is the text (see run_program)."""
    if isinstance(program, os.PathLike):
        from gantry_sim.sim.program import read_program

        path = Path(program)
        return read_program(path), file if file is not None else str(path)
    if not isinstance(program, str):
        raise TypeError(f"program must be a str (G-code text) or a Path, not {type(program)}")
    name = file if file is not None else "<program>"
    one_line = program.strip()
    if one_line and "\n" not in one_line and len(one_line) < 4096:
        try:
            is_file = Path(one_line).is_file()
        except OSError:
            is_file = False
        if is_file:
            raise GcodeError(
                f"run_program got the str '{one_line}', which names a file: pass "
                f"Path('{one_line}') to run that file (a str is the program text)",
                file=name,
            )
    return program, name


def with_verdict(result: RunResult, verdict: Verdict) -> RunResult:
    """``result`` with the gates' verdict in its report (report.json "verdict")."""
    return replace(result, run_report=replace(result.run_report, verdict=verdict))


def write_run_outputs(
    result: RunResult,
    out_dir: Path,
    *,
    plots: bool = True,
    deterministic: bool = False,
    gates: Gates | None = None,
    started: float | None = None,
    trace: bool = True,
    progress: bool | None = False,
) -> RunResult:
    """Write report.json, timing.json, (``trace``) trace.npz and (``plots``) path.png and
    error.png into ``out_dir`` (created if needed); return ``result`` with timing_s "write" and
    "total", and report.json "files" listing what was written. ``progress``: a bar on stderr
    over the files (sim.progress; None: when stderr is a terminal).

    Atomic per file set: everything is written into a temporary folder beside the outputs and
    moved in only when all of it succeeded, report.json last. ``deterministic``: report.json's
    wall-clock fields are null (timing.json has them); ``gates`` are drawn on error.png;
    ``started``: ``time.perf_counter()`` at the start, so "total" counts everything.
    """
    from gantry_sim.sim.report import write_outputs

    plotter = result.plotter if plots else None
    if result.plotter is not None and plotter is None:
        result.plotter.close()  # no plots: nothing for it to do
    try:
        report = write_outputs(
            result.run_report,
            result.trace,
            result.moves,
            Path(out_dir),
            plots=plots,
            deterministic=deterministic,
            gates=gates,
            started=started,
            full_trace=result.full_trace,
            outline=result.outline,
            trace_npz=trace,
            progress=wanted(progress),
            plotter=plotter,
        )
    finally:
        if plotter is not None:
            plotter.close()  # it draws one set of plots
    return replace(result, run_report=report)
