"""The planner's orchestration: moves -> a jerk-limited reference, with look-ahead.

1. Geometry (:mod:`~gantry_sim.controller.planner.move_geometry`): chord vertices per move,
   tangents and curvatures at its ends, its 1-D limits (:mod:`~gantry_sim.controller.planner.limits`):
   the feed is a PATH-speed cap.
2. Junctions and look-ahead (:mod:`~gantry_sim.controller.planner.junctions`,
   :mod:`~gantry_sim.controller.planner.lookahead`): exact stops at corners, rapids and the end;
   tangent junctions keep their speed; backward and forward passes.
3. One 1-D Ruckig profile per move along its path s(t), from (0, v_in, 0) to (L, v_out, 0)
   (:class:`~gantry_sim.controller.planner.ruckig_solver.RuckigSolver`, built once per plan), and
   faster candidates for arcs that ramp (:mod:`~gantry_sim.controller.planner.speedup`).
4. Pieces (:mod:`~gantry_sim.controller.planner.pieces`): straight moves (G0/G1) are that profile
   projected on the line: exactly straight, and the feed holds along the diagonal. Arcs: the 1-D
   profile is sampled at the chord vertices (time, speed, tangential acceleration), each vertex
   gets the exact arc state (position on the arc, velocity v T, acceleration a_t T + v^2 k), and
   consecutive vertex states are joined by the closed-form constant-jerk piece of
   :mod:`~gantry_sim.controller.planner.jerk3` (the default: it stays far closer to the arc than
   Ruckig's ``minimum_duration`` profile, see README "Planning"). A piece that would break an
   axis limit or the feed is made instead by a 3-DoF Ruckig piece between the same states with
   ``minimum_duration`` = the profile's time (counted in :attr:`Plan.ruckig_piece_count`);
   ``plan(..., arc_pieces="ruckig")`` makes every arc piece that way.
5. All pieces are stored as constant-jerk phases (:mod:`~gantry_sim.controller.planner.cubic`)
   and sampled vectorised.

Steps 3-4 run in re-planning rounds (:mod:`~gantry_sim.controller.planner.rounds`, which
re-plans only the chains whose end speeds changed): a piece next to a moving junction that
leaves the arc, or that Ruckig had to stretch, lowers that junction's speed and the program is
planned again. A Ruckig piece that fails even without ``minimum_duration``
raises :class:`PlanningError` naming the line: never a reference beyond the limits.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Iterator, Sequence

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.forked import one_process, process_count
from gantry_sim.controller.forked_runs import MAX_RUNS, fork_runs
from gantry_sim.controller.gc_pause import gc_paused
from gantry_sim.controller.heap import trim_heap
from gantry_sim.controller.moves import Arc, Event, Linear, Move, Rapid, Spline
from gantry_sim.controller.planner import window_cut
from gantry_sim.controller.planner.blend import REFERENCE_SHARE, CornerMemo, PathPlan
from gantry_sim.controller.planner.blend_types import Blend
from gantry_sim.controller.planner.limit_events import (
    JoinedPlans,
    Part,
    capping,
    read_limits,
    split_at_limits,
)
from gantry_sim.controller.planner.magnitudes import check_magnitudes
from gantry_sim.controller.planner.path_stream import path_plan
from gantry_sim.controller.planner.polyline_fit import FitMemo
from gantry_sim.controller.planner.prepare import prepare, slow_blends
from gantry_sim.controller.planner.result import Plan, overlap_entries
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.transition import TransitionMachine
from gantry_sim.controller.planner.travel import check_travel
from gantry_sim.controller.planner.vertices import ChordVertices
from gantry_sim.controller.planner.window_judge import JudgedPath
from gantry_sim.controller.planner.windows import plan_path
from gantry_sim.controller.spill import SpilledList

__all__ = ["LONE_PART_MOVES", "PART_BATCH_MOVES", "Plan", "plan"]

#: A program cut into parts by limit changes (Marlin's M201, M203 and M205 J: when M204 cut parts
#: too, a PrusaSlicer Benchy was 2,088 parts of 31 moves on average) has its parts planned
#: over the cores, each whole in one process (:func:`~gantry_sim.controller.forked_runs.fork_runs`),
#: in batches of about this many moves (their plans, about 2 KB a move, come back pickled and
#: are joined before the next batch: memory holds a batch, not the program) ...
PART_BATCH_MOVES = 4_000
#: ... except a part of this many moves or more, planned alone with the cores its own windows
#: and rounds use (:mod:`~gantry_sim.controller.planner.windows`).
LONE_PART_MOVES = 2_000


def plan(
    moves: Sequence[Move | Event],
    machine: MachineConfig,
    *,
    feed_override_pct: float = 100.0,
    arc_pieces: str = "jerk3",
    advance: Callable[[int], object] | None = None,
) -> Plan:
    """Plan ``moves`` on ``machine`` (see the module docstring).

    Args:
        moves: the interpreter's moves, and optionally its events among them
            (:func:`~gantry_sim.controller.gcode.interpreter.interpret_events`): a dwell is an
            exact stop plus its time, a program stop an exact stop, Marlin's limit changes
            apply from their line on (:mod:`~gantry_sim.controller.planner.limit_events`). The machine is at rest at
            the first move's start.
        machine: limits, travel, segmentation, path control at program start.
        feed_override_pct: scales every programmed feed (not rapids) [%], > 0.
        arc_pieces: "jerk3" (default: closed-form constant-jerk pieces, Ruckig where they would
            break a limit) or "ruckig" (every arc piece by Ruckig; kept for comparison).
        advance: progress, in this process: called with how many more of ``moves`` (moves and
            events) are planned, as a long program's windows and a print's parts are; the
            calls add up to ``len(moves)`` when planning returns (a progress bar's update).

    Raises:
        ConfigError: a feed override that is not a finite number > 0.
        PlanningError: a move leaving the travel, an arc needing too many chords, or a piece
            Ruckig cannot plan (each names the line).
    """
    if not (np.isfinite(feed_override_pct) and feed_override_pct > 0):
        raise ConfigError(f"feed override must be a number > 0 %, got {feed_override_pct}")
    if arc_pieces not in ("jerk3", "ruckig"):
        raise ConfigError(f"arc_pieces must be 'jerk3' or 'ruckig', got {arc_pieces!r}")
    items = moves if isinstance(moves, SpilledList) else tuple(moves)
    done = _Done(advance)
    try:
        with gc_paused():  # see controller/gc_pause.py: 19-22 % of planning time
            planned = _plan(items, machine, feed_override_pct, arc_pieces, done)
        done.to(len(items))
        return planned
    finally:
        trim_heap()  # planning's freed working set back to the system (controller/heap.py)


class _Done:
    """How many of the program's items are planned, reported to ``advance`` (when given) as
    it grows: never backwards (a window planned again takes back nothing already reported)."""

    def __init__(self, advance: Callable[[int], object] | None) -> None:
        self._advance = advance
        self.count = 0

    def to(self, count: int) -> None:
        if self._advance is not None and count > self.count:
            self._advance(count - self.count)
            self.count = count

    def within(self, first: int, size: int) -> Callable[[float], object] | None:
        """For the windows of a part of ``size`` items after the first ``first``: the share of
        its path planned -> items planned (None without an ``advance``)."""
        if self._advance is None:
            return None
        return lambda share: self.to(first + int(share * size))


def _plan(
    items: Sequence[Move | Event],
    machine: MachineConfig,
    feed_override_pct: float,
    arc_pieces: str,
    done: _Done,
) -> Plan:
    """:func:`plan` with its arguments checked: the travel of the whole program (its hint
    places all of it), then the program, with each move under the M204 path acceleration of
    its line, or its parts where Marlin's M201, M203 or M205 J change the machine (each part
    from rest to rest, the travel the same: small parts in batches over the cores,
    :func:`_batches`, joined as they come by
    :class:`~gantry_sim.controller.planner.limit_events.JoinedPlans`)."""
    program = SpilledList(
        check_magnitudes(m) for m in items if isinstance(m, Rapid | Linear | Arc | Spline)
    )
    check_travel(program, machine.travel, machine.work.systems_mm[0])
    limits = read_limits(items, machine)
    if not limits.cuts:  # one part (the path ignores the events; M204 alone cuts nothing)
        progress = done.within(0, len(items))
        return _plan_part(
            items,
            program,
            machine,
            feed_override_pct,
            arc_pieces,
            progress,
            limits.path_acc_mm_per_s2,
        )
    joined = JoinedPlans(machine.segmentation)

    def plan_one(part: Part, progress: Callable[[float], object] | None = None) -> Plan:
        moves = SpilledList(i for i in part.items if isinstance(i, Rapid | Linear | Arc | Spline))
        path_acc = capping(part.path_acc_mm_per_s2)
        return _plan_part(
            part.items, moves, part.machine, feed_override_pct, arc_pieces, progress, path_acc
        )

    def plan_alone(part: Part) -> Plan:
        with one_process():  # one of the runs sharing the cores (no progress from a child)
            return plan_one(part)

    first = 0  # the parts' items planned (without the limit events)
    for lone, parts in _batches(split_at_limits(items, machine)):
        size = sum(len(part.items) for part in parts)
        if lone:  # its own windows and rounds use the cores
            joined.add(plan_one(parts[0], done.within(first, size)), parts[0].machine.limits)
        else:
            for part, planned in zip(
                parts, fork_runs(plan_alone, parts, process_count()), strict=True
            ):
                joined.add(planned, part.machine.limits)
        first += size
        done.to(first)
    return joined.finish()


def _batches(parts: Iterable[Part]) -> Iterator[tuple[bool, list[Part]]]:
    """The parts in order: (True, [part]) for a part of :data:`LONE_PART_MOVES` moves or more;
    (False, batch) for consecutive smaller parts, :data:`PART_BATCH_MOVES` moves or so
    together (at most :data:`~gantry_sim.controller.forked_runs.MAX_RUNS` parts)."""
    batch: list[Part] = []
    size = 0
    for part in parts:
        count = len(part.path_acc_mm_per_s2)  # one per motion
        if count >= LONE_PART_MOVES:
            if batch:
                yield False, batch
                batch, size = [], 0
            yield True, [part]
            continue
        batch.append(part)
        size += count
        if size >= PART_BATCH_MOVES or len(batch) >= MAX_RUNS:
            yield False, batch
            batch, size = [], 0
    if batch:
        yield False, batch


def _plan_part(
    items: Sequence[Move | Event],
    program: Sequence[Move],
    machine: MachineConfig,
    feed_override_pct: float,
    arc_pieces: str,
    progress: Callable[[float], object] | None = None,
    path_acc: Sequence[float] | None = None,
) -> Plan:
    """The plan of ``items`` (no limit changes among them; ``program``: their moves, whose
    travel is checked) on ``machine``; ``progress``: the share of its path planned, as its
    windows are (:func:`~gantry_sim.controller.planner.windows.plan_path`); ``path_acc``: per
    motion of ``program``, Marlin's M204 path acceleration [mm/s^2] (inf: none; None: none
    anywhere)."""
    seg = machine.segmentation
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    sizing = TransitionMachine(machine.limits, seg, feed_override_pct / 100.0)
    sized: dict = {}  # transitions by site, for a path made again without some blends
    corners = CornerMemo()  # the arc corners' blends, likewise
    fitted = FitMemo()  # the G64 fits of short moves, likewise
    tol = seg.chord_tolerance_mm

    def made(
        slow: frozenset[int],
        sized: dict = sized,
        corners: CornerMemo = corners,
        fitted: FitMemo = fitted,
    ) -> PathPlan:
        """The path, with ``slow``'s blends left out (exact stops there)."""
        out = path_plan(items, machine.path, tol, slow, jerk, sizing, sized, corners, fitted)
        out.path_acc_mm_per_s2 = path_acc
        return out

    path = made(frozenset())
    prepared = None
    remake: Callable[[frozenset[int]], PathPlan] | None = None
    first = window_cut.window_stop(path.moves, 0, window_cut.WINDOW_MOVES, seg)
    if first == len(path.moves):  # one window: planned whole, its geometry made once
        known: dict = {}
        prepared = prepare(path, machine, feed_override_pct, known)
        slow = slow_blends(path, prepared, jerk)
        if slow:  # those corners are faster as exact stops: plan them so
            path = made(slow)
            prepared = prepare(path, machine, feed_override_pct, known)
        del known
    elif path.blend_junction:  # judged window by window as they are planned (window_judge)
        remake = made
    del sized, corners, fitted
    solver = RuckigSolver(machine.limits)
    # the path is held by ``src`` alone while planned: made again, the old one is freed
    src = JudgedPath(path, remake, machine, feed_override_pct)
    del path, remake
    planned = plan_path(src, machine, feed_override_pct, arc_pieces, solver, prepared, progress)
    path = src.path
    del src
    end = np.array(program[-1].end if program else (0.0, 0.0, 0.0), dtype=float)
    move_start = np.frombuffer(planned.move_start_s, dtype=float).copy()
    lines = np.frombuffer(planned.lines, dtype=np.int64).copy()
    sources = _entry_sources(
        np.frombuffer(planned.entries, dtype=np.int64).reshape(-1, 2),
        np.frombuffer(planned.sources, dtype=np.int64).reshape(-1, 2),
    )
    overlaps_s = np.array([(o.start_s, o.start_s + o.tau_s) for o in planned.overlaps])
    overlaps_s = overlaps_s.reshape(-1, 2)
    _widen_overlap_sources(sources, move_start, overlaps_s)
    path_sources = np.fromiter(
        itertools.chain.from_iterable(path.sources), dtype=np.int64, count=2 * len(path.sources)
    ).reshape(-1, 2)
    for arr in (end, move_start, lines, sources, path_sources, overlaps_s):
        arr.setflags(write=False)
    share = REFERENCE_SHARE * seg.chord_tolerance_mm
    overlaps = [
        Blend(o.line, o.deviation_mm, o.budget_mm + share, "overlap", o.file)
        for o in planned.overlaps
    ]
    blends = path.blends  # the path's (a list, or on disk), then the overlaps
    if overlaps:
        blends = blends if isinstance(blends, SpilledList | list) else list(blends)
        blends.extend(overlaps)
    vertices = ChordVertices(program, seg)
    return Plan(
        moves=program,
        duration_s=planned.duration_s,
        segment_count=vertices.chord_total(),
        chord_tolerance_mm=seg.chord_tolerance_mm,
        vertices=vertices,
        ruckig_piece_count=planned.ruckig_pieces,
        curve=planned.curve.finish(),
        move_start_s=move_start,
        move_lines=lines,
        end_mm=end,
        blends=blends,
        merges=tuple(path.merges),
        path_moves=path.moves,
        move_sources=sources,
        path_sources=path_sources,
        overlaps_s=overlaps_s,
    )


def _widen_overlap_sources(
    sources: np.ndarray, move_start_s: np.ndarray, overlaps_s: np.ndarray
) -> None:
    """Give each overlapped stop's entry of ``sources`` (changed in place) the program moves of
    both its moves, the first of the one before to the last of the one after. During the
    overlap the reference is on the end of the first and the start of the second at once, and
    each may be a G64 Q merge of many short moves: measured against the last program move of
    the first and the first of the second (a dwell's window), a hairpin of 0.17 mm moves
    merged either side of its tip in G64 P0.05 read 176 um of reference error where the
    reference was 49 um from the program (a real CAM program of CAMotics' examples)."""
    e = overlap_entries(move_start_s, overlaps_s)
    e = e[(e > 0) & (e + 1 < len(sources))]
    sources[e, 0] = sources[e - 1, 0]
    sources[e, 1] = sources[e + 1, 1]


def _entry_sources(entries: np.ndarray, active_sources: np.ndarray) -> np.ndarray:
    """(m, 2) per entry of the plan's timeline (``entries`` (m, 2): a move, or a dwell between
    two moves: see :class:`~gantry_sim.controller.planner.windows.Planned`), the first and last
    program move it comes from or lies between (-1 -1: a dwell of a program without moves);
    ``active_sources`` (n, 2): per active move, its program moves."""
    out = np.full((len(entries), 2), -1, dtype=np.int64)
    n = len(active_sources)
    if not n or not len(entries):
        return out
    a, b = entries[:, 0], entries[:, 1]
    move = a == b  # else a dwell between moves a and b (either may be past an end)
    ia, ib = np.clip(a, 0, n - 1), np.clip(b, 0, n - 1)
    before = np.where(a >= 0, active_sources[ia, 1], active_sources[ib, 0])
    after = np.where(b < n, active_sources[ib, 0], active_sources[ia, 1])
    out[:, 0] = np.where(move, active_sources[ia, 0], before)
    out[:, 1] = np.where(move, active_sources[ia, 1], after)
    return out
