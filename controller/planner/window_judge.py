"""A long path's G64 blends judged window by window, on the windows' own preparation.

:func:`~gantry_sim.controller.planner.prepare.slow_blends` finds the corners whose blend is
estimated slower than an exact stop; the path is then made again without those blends. Its
numbers for a blend depend only on :data:`BLEND_CONTEXT` moves either side, so a long path can
be judged in stretches. Judging it all before planning (:func:`blends_to_skip`) prepared every
window twice, once for the judge and once to plan it: a sixth of planning 100,000 polyline
blocks, whose corners all blend.

:class:`JudgedPath` judges instead each window as the planner prepares it
(:mod:`~gantry_sim.controller.planner.windows`), on that preparation: the blends from the
first one not yet judged to :data:`BLEND_CONTEXT` moves before the window's end (all of them
in the path's last window). At the first window with a slow blend, the rest of the path is
judged at once (:func:`blends_to_skip`), the path is made again without every slow blend
found, and the planner plans that window again from the same start: the moves before the
first slow blend are the same in both paths, and a window's start is always before the blends
it judges. Every blend is judged once, with its context, so the blends kept are those of
judging the whole path first, and the plan is the same.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.forked import fork_map, process_count
from gantry_sim.controller.planner.blend import PathPlan
from gantry_sim.controller.planner.prepare import Prepared, prepare, slow_blends, sub_path
from gantry_sim.controller.planner.window_cut import ChordCounts

__all__ = ["BLEND_CONTEXT", "JUDGE_MOVES", "JudgedPath", "blends_to_skip", "judge_stretch"]

#: Moves of context around a stretch judged for slow blends (a blend's speed cap depends on
#: its neighbours' limits, which depend on their other junctions).
BLEND_CONTEXT = 3
#: Path moves judged at a time by :func:`blends_to_skip` (one process each).
JUDGE_MOVES = 5_000


def blends_to_skip(
    path: PathPlan,
    machine: MachineConfig,
    feed_override_pct: float,
    start: int = 0,
    stop: int | None = None,
) -> frozenset[int]:
    """The junctions of the blend arcs of ``path`` at moves ``start`` .. ``stop - 1`` (the
    path's end: None) whose blends are too slow to keep (:func:`judge_stretch`), in stretches
    of :data:`JUDGE_MOVES` moves from a blend on, or fewer where their chords pass a window's
    (:func:`~gantry_sim.controller.planner.window_cut.window_stop`); the stretches are
    independent, so they are judged over the cores
    (:func:`~gantry_sim.controller.forked.fork_map`, a wave of one stretch per process: each
    holds one stretch's working set)."""
    stop = len(path.moves) if stop is None else min(stop, len(path.moves))
    blends = sorted(start + k for k in path.blends_between(start, stop))
    chords = ChordCounts(path.moves, machine.segmentation)
    stretches: list[tuple[int, int]] = []
    for k in blends:
        if not stretches or k >= stretches[-1][1]:  # the first blend after the last stretch
            stretches.append((k, min(stop, chords.stop(k, JUDGE_MOVES))))

    def judge(span: tuple[int, int]) -> frozenset[int]:
        return judge_stretch(path, *span, machine, feed_override_pct)

    slow: set[int] = set()
    wave = process_count()
    for first in range(0, len(stretches), wave):
        for found in fork_map(judge, stretches[first : first + wave]):
            slow |= found
    return frozenset(slow)


def judge_stretch(
    path: PathPlan, lo: int, hi: int, machine: MachineConfig, feed_override_pct: float
) -> frozenset[int]:
    """The junctions of the blend arcs of ``path`` at moves ``lo`` .. ``hi - 1`` whose blends
    are too slow to keep (:func:`~gantry_sim.controller.planner.prepare.slow_blends`), judged
    on the stretch with :data:`BLEND_CONTEXT` moves of context either side, in this process."""
    n = len(path.moves)
    a, b = max(0, lo - BLEND_CONTEXT), min(n, hi + BLEND_CONTEXT)
    stretch = sub_path(path, a, b, a)
    prepared = prepare(stretch, machine, feed_override_pct, {})
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    return _slow_between(stretch, prepared, a, lo, hi, jerk)


def _slow_between(
    stretch: PathPlan, pre: Prepared, base: int, lo: int, hi: int, jerk_mm_per_s3: float
) -> frozenset[int]:
    """:func:`~gantry_sim.controller.planner.prepare.slow_blends` of the blend arcs of
    ``stretch`` (path moves ``base`` on, prepared as ``pre``) at path moves ``lo`` ..
    ``hi - 1`` only."""
    inner = {k: j for k, j in stretch.blend_junction.items() if lo <= base + k < hi}
    return slow_blends(replace(stretch, blend_junction=inner), pre, jerk_mm_per_s3)


class JudgedPath:
    """The path a long program's windows are planned on, with its blends judged as they go
    (see the module docstring).

    ``path``: the path, all G64 blends in it until :meth:`remake` (then the path made again);
    ``upto``: every blend arc before this path move is judged (and kept); ``remake_path``:
    makes the path again without the blends at the junctions given (None: the blends are
    judged already, or there are none).
    """

    def __init__(
        self,
        path: PathPlan,
        remake_path: Callable[[frozenset[int]], PathPlan] | None,
        machine: MachineConfig,
        feed_override_pct: float,
    ) -> None:
        self.path: PathPlan = path
        self.upto = 0
        self._remake = remake_path if path.blend_junction else None
        self._machine = machine
        self._feed = feed_override_pct
        self._jerk = float(min(machine.limits.max_jerk_mm_per_s3))
        self._chords = ChordCounts(path.moves, machine.segmentation)

    def window_stop(self, lo: int, size: int) -> int:
        """Where the window of ``size`` moves from path move ``lo`` stops
        (:func:`~gantry_sim.controller.planner.window_cut.window_stop`; each move's chords
        counted once)."""
        return self._chords.stop(lo, size)

    @property
    def judging(self) -> bool:
        """Whether windows still judge their blends."""
        return self._remake is not None

    def judge(
        self, stretch: PathPlan, pre: Prepared, base: int, hi: int, upto: int
    ) -> tuple[frozenset[int], int]:
        """The slow blends of a window (``stretch``: path moves ``base`` .. ``hi - 1``, prepared
        as ``pre``) from path move ``upto`` on, and the move up to which it judged them: the
        blends between with too little context in the window (a window sent back can start
        further on than the judging) are judged on a stretch of their own."""
        n = len(self.path.moves)
        first = max(upto, base + BLEND_CONTEXT) if base > 0 else upto
        stop = hi - BLEND_CONTEXT if hi < n else n
        if first >= stop:
            return frozenset(), upto
        gap: frozenset[int] = frozenset()
        if upto < first:  # (only where a window's margin is shorter than twice the context)
            gap = judge_stretch(self.path, upto, first, self._machine, self._feed)
        return gap | _slow_between(stretch, pre, base, first, stop, self._jerk), stop

    def remake(self, found: frozenset[int], judged_to: int) -> None:
        """Judge the blends from path move ``judged_to`` on, and make the path again without
        those found slow and ``found``; no blend is judged after."""
        remake = self._remake
        if remake is None:
            raise AssertionError("a path made again is judged already")
        slow = found | blends_to_skip(self.path, self._machine, self._feed, judged_to)
        del self.path  # the old path freed before the new one is made
        self.path = remake(slow)
        self._remake = None
        self._chords = ChordCounts(self.path.moves, self._machine.segmentation)
