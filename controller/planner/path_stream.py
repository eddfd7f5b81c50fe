"""The path the planner follows, made as the program's moves come, in bounded memory.

:func:`path_plan` takes the program's moves and events in order and makes the
:class:`~gantry_sim.controller.planner.blend.PathPlan` in three streamed stages:

1. the moves with length, each with the exact stop after it (G61.1, a dwell, M0/M1/M60), the
   dwells before it and its program index (:func:`_entries`);
2. G64 Q's merge of straight runs (:func:`~gantry_sim.controller.planner.path_control.merge_runs`,
   greedy from the first move on, runs of at most 256 moves);
3. G64's corner blends and G2 transitions
   (:func:`~gantry_sim.controller.planner.blend.blend_corners`), a stretch of
   :data:`STRETCH_MOVES` merged moves at a time with :data:`CONTEXT_MOVES` moves of context
   either side: a move's result depends on the moves up to three either side of it only, so the
   stretches give the whole path's result move for move.

The path's moves and blends go to :class:`~gantry_sim.controller.spill.SpilledList` (on disk in
blocks), its per-move numbers to compact arrays: a 100,000-block polyline's path took 1.3 KB a
move as Python objects, held while it was planned and run.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterable, Iterator

from gantry_sim.controller.config import PathSettings
from gantry_sim.controller.forked import fork_map, process_count
from gantry_sim.controller.moves import (
    Arc,
    Dwell,
    Event,
    Linear,
    Move,
    PathMove,
    Rapid,
    Spline,
    Stop,
)
from gantry_sim.controller.planner.blend import (
    Blend,
    Blended,
    CornerMemo,
    CornerSites,
    PathPlan,
    blend_corners,
    smoothing_budget,
)
from gantry_sim.controller.planner.path_control import (
    EPS_MM,
    Merge,
    PathEntry,
    control,
    merge_runs,
)
from gantry_sim.controller.planner.polyline_fit import FitMemo, fit_runs
from gantry_sim.controller.planner.spline_split import split_slow_parts
from gantry_sim.controller.planner.transition import TransitionMachine
from gantry_sim.controller.planner.window_cut import WINDOW_MOVES
from gantry_sim.controller.spill import SpilledList

__all__ = ["CONTEXT_MOVES", "STRETCH_MOVES", "path_plan"]

#: Merged moves blended at a time.
STRETCH_MOVES = 2048
#: Moves of context either side of a stretch (a blend's length depends on the corners at both
#: ends of its moves; a trimmed move on the blends at both its ends).
CONTEXT_MOVES = 3


def path_plan(
    items: Iterable[Move | Event],
    settings: PathSettings,
    chord_tolerance_mm: float,
    skip: frozenset[int] = frozenset(),
    jerk_mm_per_s3: float = math.inf,
    machine: TransitionMachine | None = None,
    sized: dict | None = None,
    corners: CornerMemo | None = None,
    fitted: FitMemo | None = None,
    *,
    stretch_moves: int = STRETCH_MOVES,
) -> PathPlan:
    """The moves and stops the planner follows for ``items`` (moves and events in order; see
    the module docstring); junctions in ``skip`` (values of a previous result's
    ``blend_junction``) are not blended (the planner found the exact stop faster there).
    ``jerk_mm_per_s3``: the machine's lowest axis jerk, to skip corners with an arc whose blend
    would be passed too slowly to pay
    (:func:`~gantry_sim.controller.planner.corner_blend.arc_corner`). ``machine``: the
    machine's limits and segmentation, to put G2 transitions at the G64 tangent junctions whose
    curvature jumps (:mod:`~gantry_sim.controller.planner.transition`); None: none.
    ``sized``: the transitions sized by an earlier call for the same program, by site, filled
    here while the path has at most :data:`~gantry_sim.controller.planner.window_cut.WINDOW_MOVES`
    moves (a path planned whole may be made again without its slow blends; a longer one is
    made again at most once, and keeping every transition would hold about 1 KB each for the
    whole path: beyond that it is emptied and no longer filled). ``corners``: the arc corners'
    blends of an earlier call for the same program, filled here (None: none kept); ``fitted``:
    the G64 fits of an earlier call, likewise (kept as ``sized`` is)."""
    stretch = _Stretcher(
        settings, chord_tolerance_mm, skip, jerk_mm_per_s3, machine, sized, corners, fitted
    )
    out = stretch.out
    merges: list[Merge] = []
    trailing: list[Dwell] = []
    buffer: list[PathEntry] = []  # merged moves first .. first + len(buffer) - 1
    first = core = 0  # core: the first merged move not yet blended
    spans: list[tuple[int, int]] = []  # stretches waiting for their wave
    entries = _entries(items, settings, trailing, machine)
    scale = 1.0 if machine is None else machine.feed_scale
    acc = math.inf if machine is None else min(machine.limits.max_acceleration_mm_per_s2)
    fits = fit_runs(
        entries,
        settings,
        chord_tolerance_mm,
        fitted,
        jerk_mm_per_s3=jerk_mm_per_s3,
        feed_scale=scale,
        acc_mm_per_s2=acc,
    )
    for entry in merge_runs(fits, settings, merges):
        buffer.append(entry)
        if first + len(buffer) >= core + stretch_moves + CONTEXT_MOVES:
            spans.append((core, core + stretch_moves))
            core += stretch_moves
            if len(spans) >= stretch.wave():
                stretch.blend(buffer, first, spans)
                spans = []
                drop = max(0, core - CONTEXT_MOVES - first)
                del buffer[:drop]
                first += drop
    if core < first + len(buffer):
        spans.append((core, first + len(buffer)))
    stretch.blend(buffer, first, spans)
    if trailing:  # dwells after the last move
        out.holds[len(out.moves)] = trailing
    out.merges = merges
    return out


def _entries(
    items: Iterable[Move | Event],
    settings: PathSettings,
    trailing: list[Dwell],
    machine: TransitionMachine | None = None,
) -> Iterator[PathEntry]:
    """The moves with length of ``items``, in order, each with the stop after it (G61.1, or a
    dwell or program stop before the next move), the dwells (of positive time) before it and its
    index among the program's motions; the dwells after the last move go to ``trailing``. With
    ``machine``, a spline whose curvature varies a lot comes as consecutive parts of itself
    (:func:`~gantry_sim.controller.planner.spline_split.split_slow_parts`), the stop after the
    last, the dwells before the first."""
    index = -1  # of the item among the program's motions
    pending: PathEntry | None = None  # the last move, until what follows it is known
    holds: list[Dwell] = []
    for item in items:
        if isinstance(item, Dwell | Stop):
            if pending is not None:
                pending.stop_after = True
            if isinstance(item, Dwell) and item.seconds > 0:
                holds.append(item)
            continue
        if not isinstance(item, Rapid | Linear | Arc | Spline):
            continue
        index += 1
        if item.length_mm <= EPS_MM:
            continue
        if pending is not None:
            yield pending
        stop = control(item, settings).mode == "G61.1"
        if isinstance(item, Spline) and machine is not None:
            *inner, item = split_slow_parts(
                item, machine.limits, machine.segmentation, machine.feed_scale
            )
            for part in inner:
                yield PathEntry(part, False, holds, (index, index))
                holds = []
        pending, holds = PathEntry(item, stop, holds, (index, index)), []
    if pending is not None:
        yield pending
    trailing.extend(holds)


class _Stretcher:
    """Blends stretches of the merged moves into ``out`` (see :func:`path_plan`)."""

    def __init__(
        self,
        settings: PathSettings,
        chord_tolerance_mm: float,
        skip: frozenset[int],
        jerk_mm_per_s3: float,
        machine: TransitionMachine | None,
        sized: dict | None,
        corners: CornerMemo | None,
        fitted: FitMemo | None = None,
    ) -> None:
        self.settings, self.skip = settings, skip
        self.chord_tolerance_mm, self.jerk_mm_per_s3 = chord_tolerance_mm, jerk_mm_per_s3
        self.machine, self.sized, self.corners = machine, sized, corners
        self.fitted = fitted
        self.moves: SpilledList[PathMove] = SpilledList()
        self.blends: SpilledList[Blend] = SpilledList()
        self.smoothing = array("d")
        self.sources: SpilledList[tuple[int, int]] = SpilledList()
        self.out = PathPlan(
            moves=self.moves, blends=self.blends, smoothing_mm=self.smoothing, sources=self.sources
        )

    def wave(self) -> int:
        """Stretches blended at once: one per process (:func:`~gantry_sim.controller.forked.
        process_count`) once no transitions are kept for a path made again (a child's would be
        lost), else one."""
        return 1 if self.sized is not None else process_count()

    def blend(self, buffer: list[PathEntry], first: int, spans: list[tuple[int, int]]) -> None:
        """Blend the stretches ``spans`` ((lo, hi): merged moves lo .. hi - 1; ``buffer``:
        merged moves ``first`` on, with the context either side), each but the first in a
        forked child (:func:`~gantry_sim.controller.forked.fork_map`), and append what they
        become to the path, in order (and keep the arc corners' blends they found)."""
        for made, found in fork_map(lambda span: self._blended(buffer, first, *span), spans):
            self._append(made)
            if self.corners is not None:
                self.corners.take(found)

    def _blended(
        self, buffer: list[PathEntry], first: int, lo: int, hi: int
    ) -> tuple[list[Blended], CornerSites]:
        """What merged moves ``lo`` .. ``hi - 1`` become, blended with the
        :data:`CONTEXT_MOVES` moves of ``buffer`` either side of them, and the arc corners'
        blends found meanwhile (:class:`~gantry_sim.controller.planner.blend.CornerMemo`)."""
        a = max(first, lo - CONTEXT_MOVES)
        part = buffer[a - first : min(len(buffer), hi + CONTEXT_MOVES - first)]
        n = len(part)
        local = PathPlan(
            moves=[e.move for e in part],
            stop_after=[e.stop_after for e in part],
            holds={k: e.holds for k, e in enumerate(part) if e.holds},
            smoothing_mm=[
                smoothing_budget(e.move, self.settings, self.chord_tolerance_mm)
                - (0.0 if e.fit is None else e.fit.deviation_mm)
                for e in part
            ],
            sources=[e.source for e in part],
        )
        skip = frozenset(j - a for j in self.skip if a < j < a + n)
        view = None if self.corners is None else self.corners.view()
        made = blend_corners(
            local,
            self.settings,
            self.chord_tolerance_mm,
            skip,
            self.jerk_mm_per_s3,
            self.machine,
            self.sized,
            a,
            view,
        )
        mine = made[lo - a : hi - a]
        for b, e in zip(mine, part[lo - a : hi - a], strict=True):
            if e.fit is not None:  # a G64 fit's piece (polyline_fit): reported as a blend
                b.blends.insert(0, e.fit)
        for b in mine:  # junctions counted in the whole path
            b.blend_at = [None if at is None else at + a for at in b.blend_at]
        return mine, {} if view is None else view.made

    def _append(self, made: list[Blended]) -> None:
        """Append blended merged moves (``made``, in order) to the path."""
        out = self.out
        for b in made:
            if b.holds:
                out.holds[len(self.moves)] = b.holds
            for m, stop, e, src, at in zip(
                b.moves, b.stops, b.smoothing, b.sources, b.blend_at, strict=True
            ):
                if at is not None:
                    out.blend_junction[len(self.moves)] = at
                self.moves.append(m)
                out.stop_after.append(stop)
                self.smoothing.append(e)
                self.sources.append(src)
            self.blends.extend(b.blends)
        if self.sized is not None and len(self.moves) > WINDOW_MOVES:
            self.sized.clear()  # a long path: not kept (see path_plan)
            self.sized = None
        if self.fitted is not None and len(self.moves) > WINDOW_MOVES:
            self.fitted.drop()
