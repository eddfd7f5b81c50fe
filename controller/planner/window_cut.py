"""Where a window of a long program ends and is cut, and which window comes after it.

A window of path moves [lo, hi) holds :data:`WINDOW_MOVES` moves, or fewer where their chords
pass :data:`WINDOW_CHORDS` (:func:`window_stop`: planning's memory grows with the chords, and
an arc of many turns has thousands). A probe planned over it keeps its chains up to its last
chain boundary of the first round that leaves at least :data:`MARGIN_MOVES` moves (a quarter
of the window's, in a window of fewer than four times that) and :data:`MARGIN_BRAKING` braking
distances before hi, or no braking distance where a stop lies between it and hi (step 2 of
:mod:`~gantry_sim.controller.planner.windows`); the next window
starts there, with the move before it as context, and is known by its :data:`WindowKey`.

The window's size and margins are read from this module only: a test or benchmark that plans
in smaller windows sets them here (a path whose first window is the whole of it is planned
whole: :func:`window_stop`).
"""

from __future__ import annotations

import bisect
from array import array
from collections.abc import Callable, Sequence

import numpy as np

from gantry_sim.controller.config import Segmentation
from gantry_sim.controller.moves import Arc, Spline
from gantry_sim.controller.planner.limits import BlockLimits, braking_mm
from gantry_sim.controller.planner.move_geometry import MoveGeometry
from gantry_sim.controller.planner.prepare import Prepared
from gantry_sim.controller.planner.rounds import Settled
from gantry_sim.controller.planner.segment import chords_of_sweep

__all__ = [
    "MARGIN_BRAKING",
    "MARGIN_MOVES",
    "MARGIN_MOVES_MIN",
    "WINDOW_CHORDS",
    "WINDOW_MOVES",
    "ChordCounts",
    "WindowKey",
    "chord_count",
    "cut",
    "cut_at",
    "key_after",
    "next_key",
    "window_stop",
]

#: Path moves planned at a time (a path up to this long is planned whole): about 50 MB of
#: planning's working set.
WINDOW_MOVES = 5_000
#: ... and chords (a straight move is one): planning holds about 0.2 KB a chord, so a window
#: stays within about 500 MB in this process however many turns its arcs make (1,000 circles
#: of R 0.05 and 100 turns, 1.6 million chords, are planned whole at 364 MB; 10,000 of them
#: took 2.1 GB in windows of 5,000 moves, 1.1 GB in these). A window cut short costs the
#: probe's margin planned again (half a million chords took 1.3-1.4 x as long on those 1,000
#: circles). Moves of generated CAM programs have 1-30 chords: this binds only on arcs of
#: hundreds of chords.
WINDOW_CHORDS = 2_000_000
#: Moves of a probe after the kept part, at least ...
MARGIN_MOVES = 250
#: ... and this many braking distances (from the probe's fastest speed cap to rest) [1].
MARGIN_BRAKING = 2.0
#: The fewest moves after a cut before a stop, however short the window (one cut short by its
#: chords keeps 3/4 of itself): a kept move's preparation depends on a few moves after it, and
#: the window after the cut may find a blend slow within window_judge.BLEND_CONTEXT (3) moves
#: of this window's end and make the path again from there. Cut before a stop with margins of
#: 6 moves in windows of 30, a fuzzed program planned an arc's last piece 1e-12 apart from the
#: whole program's; with 8 and more, the whole program's plan. (A cut with its braking
#: distances keeps the quarter: a window of a few moves of a million chords each must still
#: cut, where it can, rather than widen to hold eight of them.)
MARGIN_MOVES_MIN = 8


#: A window by (its first stretch move, its stop, whether the first is context, the path move
#: its judging starts from or None).
WindowKey = tuple[int, int, bool, int | None]


def cut(settled: Settled, caps: np.ndarray) -> tuple[int, int] | None:
    """Where a probe is cut: (chains kept, the active move after them), at its last chain
    boundary of the first round (a boundary in every round: the next window replays the
    rounds there, ``windows._replay``) with the margins of the module docstring after it, or
    before a stop (``caps`` [mm/s]: the window's junction caps, as prepared; :func:`cut_at`);
    None where there is none."""
    at = cut_at(settled.setup.active, settled.first_spans, caps)
    if at is None:
        return None
    c = at[1]
    return next(k for k, (first, _) in enumerate(settled.spans) if first == c), c


def cut_at(
    active: list[MoveGeometry], spans: list[tuple[int, int]], caps: np.ndarray
) -> tuple[int, int] | None:
    """:func:`cut` of chains ``spans`` over the moves ``active`` whose junction caps [mm/s]
    are ``caps`` (len(active) + 1).

    A boundary at or before a stop inside the window (a junction of cap 0: a rapid next to a
    feed move, a corner in G61, a dwell) needs no braking margin: the speed there is 0 in
    every round, so nothing after it, the rest the probe assumes at its end included, reaches
    the speeds or the pieces before it. Adaptive clearing stops at every rapid, a few dozen
    moves apart, and one rapid in the rest of the window asked for twice its braking distance
    (about 110 mm on the bundled machine) of moves of 0.1 mm: windows of 5,000 moves kept
    1,200-2,200 of them, and each move was planned in about four windows."""
    lengths = np.array([g.limits.length_mm for g in active])
    behind = np.concatenate((np.cumsum(lengths[::-1])[::-1], [0.0]))  # path length to the end
    braking = np.array([_braking_mm(g.limits) for g in active] + [0.0])
    needed = MARGIN_BRAKING * np.maximum.accumulate(braking[::-1])[::-1]  # from here on
    margin = min(MARGIN_MOVES, len(active) // 4)  # a window cut short by its chords keeps 3/4
    before_stop = max(margin, MARGIN_MOVES_MIN)
    stops = np.flatnonzero(caps[1 : len(active)] == 0.0)
    last_stop = int(stops[-1]) + 1 if stops.size else -1  # the window's last stop inside it
    for k in range(len(spans) - 1, 0, -1):
        first = spans[k][0]
        after = len(active) - first
        if after >= margin and behind[first] >= needed[first]:
            return k, first
        if after >= before_stop and first <= last_stop:
            return k, first
    return None


def _braking_mm(lim: BlockLimits) -> float:
    """:func:`~gantry_sim.controller.planner.limits.braking_mm` from a block's speed cap."""
    return braking_mm(lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3)


def next_key(
    pre: Prepared,
    base: int,
    spans: list[tuple[int, int]],
    stop: Callable[[int, int], int],
    upto: int | None,
) -> tuple[WindowKey, int] | None:
    """The key of the window after the cut that ``spans`` give a window (path moves from
    ``base``, prepared as ``pre``; ``stop``: :func:`window_stop` on the path) -- its first
    stretch move (the context), its stop, True, and the move its judging starts from -- and the
    cut's active move; None: no cut."""
    at = cut_at(pre.active, spans, pre.caps)
    if at is None:
        return None
    c = at[1]
    return key_after(base + pre.path_index[c - 1], base + pre.path_index[c], stop, upto), c


def key_after(ctx: int, lo: int, stop: Callable[[int, int], int], upto: int | None) -> WindowKey:
    """The key of the window that starts at path move ``lo`` after its context ``ctx``
    (``stop``: :func:`window_stop` on the path), judging its blends from ``upto``."""
    return (ctx, stop(lo, WINDOW_MOVES), True, upto)


def window_stop(moves: Sequence[object], lo: int, size: int, seg: Segmentation) -> int:
    """Where a window of ``size`` path moves (:data:`WINDOW_MOVES`, or more for a window sent
    back wider) starting at path move ``lo`` of ``moves`` stops: ``lo + size``, the path's
    end, or the first move whose chords (:func:`chord_count`) take the window's past
    :data:`WINDOW_CHORDS` x ``size`` / :data:`WINDOW_MOVES` (a window has one move at least).
    Once; :class:`ChordCounts` for many windows of one path."""
    return ChordCounts(moves, seg).stop(lo, size)


class ChordCounts:
    """:func:`window_stop` on the moves of one path, their chords counted once, in order, as
    far as a window reaches (a path on disk decodes each of its blocks once for it)."""

    def __init__(self, moves: Sequence[object], seg: Segmentation) -> None:
        self._moves = moves
        self._seg = seg
        self._before = array("q", [0])  # chords of the moves before each index

    def stop(self, lo: int, size: int) -> int:
        """:func:`window_stop` of the window of ``size`` moves from ``lo``."""
        hi = min(len(self._moves), lo + size)
        before = self._before
        if len(before) <= hi:
            seg, total = self._seg, before[-1]
            for move in self._moves[len(before) - 1 : hi]:
                total += chord_count(move, seg)
                before.append(total)
        limit = before[lo] + WINDOW_CHORDS * size / WINDOW_MOVES
        # the first move past the budget, the window's first not counted (one move at least)
        past = bisect.bisect_right(before, limit, lo + 2, hi + 1)
        return past - 1 if past <= hi else hi


def chord_count(move: object, seg: Segmentation) -> int:
    """The chords of a path move as the planner segments it: an arc's by ``seg`` at its start
    radius (``segment_count`` takes a spiral's larger end radius, which may add a few; the
    arc's frame it needs for that cost 33 ms a window of 5,000 arcs, this 11 ms); a spline's
    where this copy of it was counted already (the count is a search, made when the window is
    prepared; 1 otherwise); a straight move or a G2 transition (a few chords within one
    junction's tolerance) 1."""
    if isinstance(move, Arc):
        return chords_of_sweep(
            move, move.radius, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm
        )
    if isinstance(move, Spline):
        key = (seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
        return int(move.curve.chord_counts.get(key, 1))
    return 1
