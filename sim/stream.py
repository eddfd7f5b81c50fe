"""A run streamed range by range: sample, simulate and analyse STREAM_TICKS servo ticks at a time.

Per range [lo, hi) of the run's N ticks: the plan is sampled over the range and the analysis'
reference context around it (Plan.sample_range; sim.contour.reference_context), the servo loop
continues from where the previous range left it (sim.runner.simulate_pieces: MjData, encoders,
integral and backlash state carried exactly), and the range is analysed (sim.contour
.analyse_chunk, and the reference's distance from the path it follows for the blend/planning
split, sim.blend_parts). What is kept for the whole run is what report.json needs: running
figures (sim.error_tally.ErrorTally: per block a few numbers, the feed ticks' errors in an
anonymous temporary file for the exact 95th percentile), running maxima of the forces and the
parts, the saturated-tick counts, and a decimated trace (every ``stride``-th tick and each
range's worst tick) for the plots. The full-rate arrays of each range go to ``on_range`` (e.g. a
sim.trace_writer.TraceWriter) and are dropped. Each range is analysed against the moves it
reaches only (sim.range_rows); the program's moves and the plan's path stay on disk
(controller.spill). The peak memory is therefore that of one range, and about 35 bytes per move
of whole-program arrays (sim.move_table.ProgramIndex), whatever the number of ticks.

The figures equal those of the whole-program path (sample, simulate, analyse at once) bit for bit:
tests/test_stream.py runs both.
"""

from __future__ import annotations

import functools
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, fields

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.forked import Background
from gantry_sim.controller.heap import trim_heap
from gantry_sim.controller.moves import Move
from gantry_sim.controller.planner.result import Plan
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.analysis_worker import ProcessAnalyser, RangeJob, Result, make_analyser
from gantry_sim.sim.blend_parts import (
    blend_max_um,
    in_overlaps,
    known_path_sources,
    with_planning_split,
)
from gantry_sim.sim.block_files import tick_keys
from gantry_sim.sim.contour import (
    Analysis,
    ChunkAnalysis,
    ErrorParts,
    chord_max_um,
    reference_context,
    tally_figures,
)
from gantry_sim.sim.error_tally import ErrorTally
from gantry_sim.sim.machine import Gantry
from gantry_sim.sim.move_table import ProgramIndex
from gantry_sim.sim.range_helper import Helper, InlineHelper, RangeHelper
from gantry_sim.sim.range_rows import RowPicker
from gantry_sim.sim.runner import simulate_pieces
from gantry_sim.sim.trace import Trace

#: servo ticks per range at most (about 1 minute of machine time at 1 kHz; ~100 MB of arrays
#: at peak)
STREAM_TICKS = 65536
#: a run is cut into this many ranges at least, of MIN_RANGE_TICKS at least: the analysis of
#: the last range is not overlapped by any simulation (1,000 tangent arcs, 131,000 ticks: 0.50
#: s in two ranges, 0.14 s in eight)
MIN_RANGES = 8
MIN_RANGE_TICKS = 8192
#: the last range is cut in halves down to this many ticks at least: the run waits for the last
#: range's analysis with nothing beside it (10,000 polylines, 348,317 ticks in eight ranges:
#: 0.20 s of analysis after the loop, 0.12 s with the last range cut, and 0.10 s less wall).
#: Cutting the first range likewise (the loop waits for its sampling) made the loop 0.17 s
#: slower there: the helper then samples a whole range while a short one steps.
END_TICKS = 4096
#: ticks kept at full rate in the decimated trace at most (about; plus each range's worst)
DECIMATED_TICKS = 200_000
#: simulated ranges waiting to be handed to the analysis at most (each holds its arrays: about
#: 10 MB); beyond, the loop waits (the analysis is then slower than the simulation)
HANDED_AHEAD = 2
#: Ranges between two trims of the C heap (controller/heap.py; the first after the first range).
TRIM_RANGES = 32

#: ``on_range(lo, piece, pos, force, analysis)``: one range's full-rate arrays
OnRange = Callable[[int, Trajectory, np.ndarray, np.ndarray, ChunkAnalysis], object]


@dataclass(frozen=True)
class StreamedRun:
    """A run streamed range by range.

    Attributes:
        analysis: the contour analysis, its parts split into blend and planning; the per-tick
            arrays (err_um, nearest, feed) are not kept: empty.
        ticks: servo ticks N; duration_s: time of the last tick [s].
        max_force_N: (3,) largest |force| per axis [N]; saturated_ticks: (3,) ticks at the limit.
        decimated: the trace every ``stride``-th tick and at each range's worst tick.
        simulate_s: wall time of the simulation [s]; analyse_s: of the analysis, besides the
            simulation [s] (with sim.analysis_worker's worker process: what the run waited for
            it, and the running figures).
    """

    analysis: Analysis
    ticks: int
    duration_s: float
    max_force_N: np.ndarray
    saturated_ticks: np.ndarray
    decimated: Trace
    simulate_s: float
    analyse_s: float


def stream_run(
    moves: Sequence[Move],
    planned: Plan,
    machine: MachineConfig,
    gantry: Gantry,
    *,
    range_ticks: int | None = None,
    on_range: OnRange | None = None,
    on_ticks: Callable[[int], object] | None = None,
    worker: ProcessAnalyser | None = None,
) -> StreamedRun:
    """Sample, simulate and analyse ``planned`` ``range_ticks`` servo ticks at a time (default:
    an eighth of the run, within MIN_RANGE_TICKS..STREAM_TICKS).

    Raises SimulationError when the run diverges (as sim.runner.simulate). ``on_ticks(n)`` is
    called as the simulation advances (a progress bar's update). ``worker``: a worker started
    for this run (sim.analysis_worker.early_worker), closed here; None: one is made here
    (sim.analysis_worker.make_analyser).
    """
    period = machine.servo.period_s
    n = planned.sample_count(period)
    range_ticks = range_ticks or min(STREAM_TICKS, max(MIN_RANGE_TICKS, -(-n // MIN_RANGES)))
    index = ProgramIndex.of(moves)  # 35 bytes a move; the tables are laid out per range
    contexts: deque[tuple[int, Trajectory]] = deque()
    stride = max(1, n // DECIMATED_TICKS)
    limit = np.array([[-p.force_min_N, p.force_max_N] for p in gantry.plant]).min(axis=1)

    tally = ErrorTally(index, spill=True, keys=index.key)  # whole-run figures, bounded memory
    run = _Running(stride, limit)
    sim_s = ana_s = 0.0
    start = planned.sample_range(period, 0, 1).pos[0]

    def sampled(lo: int, hi: int) -> tuple[int, Trajectory]:
        c0, c1 = reference_context(lo, hi, n)
        return c0, planned.sample_range(period, c0, c1)

    def take(results: list[Result]) -> None:
        for job, part, planning_mm in results:
            if on_range is not None:
                on_range(job.lo, job.piece, job.pos, job.force, part)
            run.add(job, part, planning_mm)
            piece = job.piece
            tally.add(
                tick_keys(piece.line, piece.source, index.key, index.files), part.err_um, part.feed
            )

    def hand_over(job: RangeJob) -> None:
        analyser.submit(job, rows.tables(job.piece, job.context_pos, job.offset, job.pos))
        take(analyser.ready())
        if (job.lo + job.pos.shape[0]) // range_ticks % TRIM_RANGES == 1:
            trim_heap()  # the ranges' freed buffers, and the set-up's, back to the system

    overlaps = len(planned.overlaps_s) > 0  # stops overlapped: out of the planning split
    # the chords' largest error from their curves (a second of work at 10,000 arcs) and the
    # plan's largest blend deviation (its blends read from disk: 0.03 s at 10,000 polyline
    # blocks) need nothing from the simulation: done meanwhile by a forked child (forked before
    # the analysis worker starts: it holds none of the worker's pipes)
    plan_figures = Background(functools.partial(_plan_figures_um, moves, planned))
    try:
        analyser = make_analyser() if worker is None else worker
        # each range goes to the analysis with the moves it reaches (sim.range_rows), whose
        # tables the analysis lays out: no table of the whole program is made (28 MB each at
        # 100,000 blocks: the program's, and the path's for the blend/planning split); to a
        # worker process as the pickled blocks that hold them
        rows = RowPicker(
            moves,
            planned.path_moves or moves,
            index,
            known_path_sources(planned),
            pickled=isinstance(analyser, ProcessAnalyser),
        )
        # sampling and hand-over on a thread while the loop steps (sim.range_helper)
        helper: Helper = RangeHelper() if isinstance(analyser, ProcessAnalyser) else InlineHelper()
        handed: deque[Future[None]] = deque()  # the hand-overs not seen finished

        def pieces() -> Iterator[Trajectory]:
            bounds = range_bounds(n, range_ticks)
            ahead: Future[tuple[int, Trajectory]] | None = None  # the next range's sampling
            for k, (lo, hi) in enumerate(bounds):
                c0, ctx = (helper.submit(sampled, lo, hi) if ahead is None else ahead).result()
                if k + 1 < len(bounds):  # the next range, sampled while this one steps
                    ahead = helper.submit(sampled, *bounds[k + 1])
                contexts.append((c0, ctx))
                yield ctx.slice(lo - c0, hi - c0)

        try:
            lo = 0
            t0 = time.perf_counter()
            for pos, force in simulate_pieces(gantry, machine, pieces(), start, on_ticks):
                t1 = time.perf_counter()
                sim_s += t1 - t0
                c0, ctx = contexts.popleft()
                piece = ctx.slice(lo - c0, lo - c0 + pos.shape[0])
                lap = in_overlaps(piece.t, planned.overlaps_s) if overlaps else None
                job = RangeJob(lo, piece, ctx.pos, lo - c0, pos, force, lap)
                handed.append(helper.submit(hand_over, job))
                # a failed hand-over stops the run here; at most HANDED_AHEAD ranges wait
                while handed and (handed[0].done() or len(handed) > HANDED_AHEAD):
                    handed.popleft().result()
                lo += pos.shape[0]
                t0 = time.perf_counter()
                ana_s += t0 - t1
            t1 = time.perf_counter()
            while handed:
                handed.popleft().result()
            take(analyser.ready(drain=True))
            contour, blocks = tally_figures(tally, index.files)
            chord_um, blend_um = plan_figures.result()
        finally:
            if handed:  # the run failed: a hand-over may wait for the worker's reply
                analyser.abort()
            helper.stop()
            analyser.close()
    finally:
        plan_figures.close()
        tally.values.close()
    parts = ErrorParts(chord_um, run.reference_max, run.tracking_max)
    empty = np.zeros(0)
    analysis = Analysis(empty, np.zeros((0, 3)), empty.astype(bool), contour, parts, blocks)
    analysis = with_planning_split(analysis, planned, run.planning_mm * UM_PER_MM, blend_um)
    ana_s += time.perf_counter() - t1
    return StreamedRun(
        analysis=analysis,
        ticks=n,
        duration_s=(n - 1) * period if n else 0.0,
        max_force_N=run.max_force,
        saturated_ticks=run.saturated,
        decimated=_join_decimated(run.kept),
        simulate_s=sim_s,
        analyse_s=ana_s,
    )


def _plan_figures_um(moves: Sequence[Move], planned: Plan) -> tuple[float, float]:
    """(the chords' largest error from their curves, the plan's largest blend deviation) [um]:
    sim.contour.chord_max_um, sim.blend_parts.blend_max_um."""
    return chord_max_um(moves, planned.vertices), blend_max_um(planned)


def range_bounds(n: int, size: int, end: int | None = None) -> list[tuple[int, int]]:
    """Ranges [lo, hi) of servo ticks covering 0..n: of ``size`` ticks, the last cut in halves
    while a half keeps ``end`` (default :data:`END_TICKS`) ticks at least (e.g. size 40,000:
    40,000, ..., 40,000, 20,000, 10,000, 5,000, 5,000)."""
    bounds = [(lo, min(n, lo + size)) for lo in range(0, n, size)]
    return bounds[:-1] + _halves(*bounds[-1], END_TICKS if end is None else end) if bounds else []


def _halves(lo: int, hi: int, end: int) -> list[tuple[int, int]]:
    """[lo, hi) cut in halves, largest first, while a half keeps ``end`` ticks at least."""
    out = []
    while hi - lo >= 2 * end:
        half = (hi - lo) // 2
        out.append((lo, lo + half))
        lo += half
    out.append((lo, hi))
    return out


class _Running:
    """The running figures of a streamed run: maxima of the forces and the error parts, the
    saturated-tick counts, and the decimated trace's rows."""

    def __init__(self, stride: int, limit_N: np.ndarray) -> None:
        self.stride, self.limit_N = stride, limit_N
        self.max_force, self.saturated = np.zeros(3), np.zeros(3, dtype=np.int64)
        self.reference_max = self.tracking_max = self.planning_mm = 0.0
        self.kept: list[Trace] = []

    def add(self, job: RangeJob, part: ChunkAnalysis, planning_mm: float) -> None:
        absf = np.abs(job.force)
        if absf.size:
            self.max_force = np.maximum(self.max_force, absf.max(axis=0))
        self.saturated += (absf >= self.limit_N * (1 - 1e-12)).sum(axis=0)
        rows = np.arange(job.lo, job.lo + job.pos.shape[0])
        pick = (rows % self.stride == 0) | (rows == job.lo + int(np.argmax(part.err_um)))
        self.kept.append(_decimate(job, part, pick))
        self.reference_max = max(self.reference_max, part.reference_max_um)
        self.tracking_max = max(self.tracking_max, part.tracking_max_um)
        self.planning_mm = max(self.planning_mm, planning_mm)


def _decimate(job: RangeJob, part: ChunkAnalysis, pick: np.ndarray) -> Trace:
    """The ``pick``ed ticks of one range, as small copies (the range's arrays can be freed;
    the reference's speed, acceleration and sources are not kept: the plots do not draw them,
    and they were 16 MB of the 200,000 ticks kept)."""
    piece = job.piece
    return Trace(
        t=piece.t[pick],
        ref=piece.pos[pick],
        pos=job.pos[pick],
        line=piece.line[pick].astype(np.int64),
        err_um=part.err_um[pick],
        nearest=part.nearest[pick],
        feed=part.feed[pick].astype(bool),
        force_N=job.force[pick],
    )


def _join_decimated(kept: list[Trace]) -> Trace:
    """The ranges' picked ticks as one :class:`Trace` (empty arrays when nothing was kept)."""
    if not kept:
        empty, rows = np.zeros(0), np.zeros((0, 3))
        return Trace(
            empty, rows, rows, empty.astype(np.int64), empty, rows, empty.astype(bool), rows
        )
    return Trace(*(np.concatenate([getattr(k, f.name) for k in kept]) for f in fields(Trace)))
