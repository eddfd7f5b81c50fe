"""Where a window of a long program is cut, and which window comes after it.

A probe planned over path moves [lo, hi) keeps its chains up to its last chain boundary of the
first round that leaves at least :data:`MARGIN_MOVES` moves and :data:`MARGIN_BRAKING` braking
distances before hi (step 2 of :mod:`~gantry_sim.controller.planner.windows`); the next window
starts there, with the move before it as context, and is known by its :data:`WindowKey`.

The window's size and margins are read from this module only: a test or benchmark that plans
in smaller windows sets them here (and ``plan.WINDOW_MOVES``, which decides whether a path is
planned whole).
"""

from __future__ import annotations

import math

import numpy as np

from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import MoveGeometry
from gantry_sim.controller.planner.prepare import Prepared
from gantry_sim.controller.planner.rounds import Settled

__all__ = [
    "MARGIN_BRAKING",
    "MARGIN_MOVES",
    "WINDOW_MOVES",
    "WindowKey",
    "cut",
    "cut_at",
    "key_after",
    "next_key",
]

#: Path moves planned at a time (a path up to this long is planned whole): about 50 MB of
#: planning's working set.
WINDOW_MOVES = 5_000
#: Moves of a probe after the kept part, at least ...
MARGIN_MOVES = 250
#: ... and this many braking distances (from the probe's fastest speed cap to rest) [1].
MARGIN_BRAKING = 2.0


#: A window by (its first stretch move, its stop, whether the first is context, the path move
#: its judging starts from or None).
WindowKey = tuple[int, int, bool, int | None]


def cut(settled: Settled) -> tuple[int, int] | None:
    """Where a probe is cut: (chains kept, the active move after them), at its last chain
    boundary of the first round (a boundary in every round: the next window replays the
    rounds there, ``windows._replay``) with the margins of the module docstring after it;
    None where there is none."""
    at = cut_at(settled.setup.active, settled.first_spans)
    if at is None:
        return None
    c = at[1]
    return next(k for k, (first, _) in enumerate(settled.spans) if first == c), c


def cut_at(active: list[MoveGeometry], spans: list[tuple[int, int]]) -> tuple[int, int] | None:
    """:func:`cut` of chains ``spans`` over the moves ``active``."""
    lengths = np.array([g.limits.length_mm for g in active])
    behind = np.concatenate((np.cumsum(lengths[::-1])[::-1], [0.0]))  # path length to the end
    braking = np.array([braking_mm(g.limits) for g in active] + [0.0])
    needed = MARGIN_BRAKING * np.maximum.accumulate(braking[::-1])[::-1]  # from here on
    for k in range(len(spans) - 1, 0, -1):
        first = spans[k][0]
        if len(active) - first >= MARGIN_MOVES and behind[first] >= needed[first]:
            return k, first
    return None


def braking_mm(lim: BlockLimits) -> float:
    """Distance [mm] to come to rest from a block's speed cap with its acceleration and jerk:
    an upper bound, v^2 / 2a + v a / j (the jerk-limited stop takes v^2 / 2a + v a / 2j, or
    v sqrt(v / j) when v < a^2 / j; inf for a block without a finite cap)."""
    v, a, j = lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
    return v * v / (2.0 * a) + v * a / j if np.isfinite(v) else math.inf


def next_key(
    pre: Prepared,
    base: int,
    spans: list[tuple[int, int]],
    n: int,
    upto: int | None,
) -> tuple[WindowKey, int] | None:
    """The key of the window after the cut that ``spans`` give a window (path moves from
    ``base``, prepared as ``pre``; the path has ``n`` moves) -- its first stretch move (the
    context), its stop, True, and the move its judging starts from -- and the cut's active
    move; None: no cut."""
    at = cut_at(pre.active, spans)
    if at is None:
        return None
    c = at[1]
    return key_after(base + pre.path_index[c - 1], base + pre.path_index[c], n, upto), c


def key_after(ctx: int, lo: int, n: int, upto: int | None) -> WindowKey:
    """The key of the window that starts at path move ``lo`` after its context ``ctx``, on a
    path of ``n`` moves, judging its blends from ``upto``."""
    return (ctx, min(n, lo + WINDOW_MOVES), True, upto)
