"""Chains: runs of moves planned as one 1-D speed profile.

Where consecutive moves have the same speed cap and the junctions between them do not bind
(each junction's cap is at least that cap), the reference does not need to slow down, nor to
bring its tangential acceleration to 0, at those junctions. Planning each move alone would do
both: a chain of short moves (a circle written as 360 G1 segments and blended in G64, tangent
arcs, a CAM surface's polyline) would then ramp its speed in a staircase, one move at a time,
and take several times as long as the same path written as one arc. A chain is planned instead
as one block of the look-ahead (:func:`chain_limits`: its length, and the lowest of its moves'
limits), its profile is one Ruckig profile, and :func:`split_profile` cuts that profile at the
moves' ends: each move gets its own part, and the junctions between them get the profile's
speed and tangential acceleration there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.planner.cubic import Chunk
from gantry_sim.controller.planner.knots import union_sorted
from gantry_sim.controller.planner.limits import BlockLimits, braking_mm
from gantry_sim.controller.planner.profile import Profile1D

#: Relative difference of two speed caps [1] below which moves can share one profile.
SAME_CAP_REL = 1e-9
#: A chain is cut after this many moves where they are also at least :data:`SPLIT_BRAKING`
#: braking distances long (:func:`chain_spans`): a long program's windows cut only at chain
#: boundaries (:mod:`~gantry_sim.controller.planner.window_cut`), so one chain of 900,000
#: collinear moves (a hostile loop, a thread of thousands of turns written one arc a turn)
#: was planned in one window at 3.2 GB; cut, it is planned 5,000 moves at a time.
SPLIT_MOVES = 2_000
#: ... braking distances from the chain's cap to rest [1]: a part that long reaches its cap
#: from any speed and can stop from it, so the look-ahead gives the cut its cap, and each part
#: meets it cruising, as the whole chain's profile passes it.
SPLIT_BRAKING = 2.0
#: A chain is cut after this many moves however short they are: parts of moves too short to
#: reach their cap meet at the speed the look-ahead gives, with no tangential acceleration
#: (a step in the ramp: milliseconds), where one chain of 10 million moves of 1 nm would
#: hold tens of GB in one window.
SPLIT_MOVES_ALWAYS = 32_000


@dataclass(frozen=True, eq=False)
class Chain:
    """One chain's pieces, as :mod:`~gantry_sim.controller.planner.chain_plan` plans them:
    ``chunk``, its duration [s], each move's start [s] from the chain's start, the junctions
    whose pieces failed, Ruckig pieces used, and the profile's speed [mm/s] at the junctions
    inside the chain."""

    chunk: Chunk
    duration_s: float
    starts_s: tuple[float, ...]
    bad: frozenset[int]
    ruckig_pieces: int
    inner_speeds: np.ndarray


def chain_spans(blocks: Sequence[BlockLimits], caps: np.ndarray) -> list[tuple[int, int]]:
    """Split the moves into chains ``[(first, stop), ...]`` (``stop`` exclusive, in order,
    covering every move): a junction ``b`` (between moves ``b - 1`` and ``b``) is inside a chain
    when both moves have the same speed cap (to :data:`SAME_CAP_REL`) and the junction's cap
    ``caps[b]`` [mm/s] is at least that cap, unless the chain has :data:`SPLIT_MOVES` moves
    before ``b`` that are :data:`SPLIT_BRAKING` braking distances long, or
    :data:`SPLIT_MOVES_ALWAYS` moves (counted from the chain's first move, so a window
    starting at a chain boundary cuts where the whole program does)."""
    spans, first = [], 0
    tops = [b.cap_mm_per_s for b in blocks]
    at = caps.tolist()  # Python floats: the same numbers, without a NumPy scalar per junction
    run: _Run | None = None  # the chain's moves before b, once it has SPLIT_MOVES of them
    for b in range(1, len(blocks)):
        c0, c1 = tops[b - 1], tops[b]
        top = max(c0, c1)
        cut = not (abs(c0 - c1) <= SAME_CAP_REL * top and at[b] >= top * (1.0 - SAME_CAP_REL))
        moves = b - first
        if not cut and moves >= SPLIT_MOVES:  # (a short chain costs no more than before)
            if run is None:
                run = _Run(blocks[first:b])
            else:
                run.add(blocks[b - 1])
            cut = moves >= SPLIT_MOVES_ALWAYS or run.long()
        if cut:
            spans.append((first, b))
            first, run = b, None
    if blocks:
        spans.append((first, len(blocks)))
    return spans


class _Run:
    """The moves of a chain so far (:func:`chain_spans`): their length [mm] and lowest cap,
    acceleration and jerk, as :func:`chain_limits` would give them."""

    __slots__ = ("acc", "cap", "jerk", "length")

    def __init__(self, blocks: Sequence[BlockLimits]) -> None:
        lim = chain_limits(blocks)
        self.length, self.cap = lim.length_mm, lim.cap_mm_per_s
        self.acc, self.jerk = lim.acc_mm_per_s2, lim.jerk_mm_per_s3

    def add(self, b: BlockLimits) -> None:
        self.length += b.length_mm
        self.cap = min(self.cap, b.cap_mm_per_s)
        self.acc = min(self.acc, b.acc_mm_per_s2)
        self.jerk = min(self.jerk, b.jerk_mm_per_s3)

    def long(self) -> bool:
        """At least :data:`SPLIT_BRAKING` times the distance to rest from the cap with the
        lowest acceleration and jerk (:func:`~gantry_sim.controller.planner.limits.braking_mm`)."""
        return self.length >= SPLIT_BRAKING * braking_mm(self.cap, self.acc, self.jerk)


def chain_limits(blocks: Sequence[BlockLimits]) -> BlockLimits:
    """One block for a chain: its total length [mm] and the lowest of its moves' speed cap,
    acceleration and jerk limits (every move's own limits hold along the whole profile)."""
    if len(blocks) == 1:
        return blocks[0]
    return BlockLimits(
        length_mm=float(sum(b.length_mm for b in blocks)),
        cap_mm_per_s=min(b.cap_mm_per_s for b in blocks),
        acc_mm_per_s2=min(b.acc_mm_per_s2 for b in blocks),
        jerk_mm_per_s3=min(b.jerk_mm_per_s3 for b in blocks),
    )


def move_bounds(lengths_mm: Sequence[float]) -> np.ndarray:
    """Arc length [mm] along a chain at its moves' starts and its end (len(lengths_mm) + 1,)."""
    return np.concatenate(([0.0], np.cumsum(lengths_mm)))


def split_profile(
    profile: Profile1D,
    lengths_mm: Sequence[float],
    cut: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[list[Profile1D], np.ndarray, np.ndarray]:
    """Cut a chain's ``profile`` at the ends of its moves (``lengths_mm``, summing to the
    profile's length). ``cut``: ``profile.invert`` at the inner junctions
    (``move_bounds(lengths_mm)[1:-1]``) when already made (several chains are inverted at once).

    Returns:
        (parts, speeds, accelerations): one profile per move, its arc length counted from the
        move's start; and at the k - 1 inner junctions, the path speed [mm/s] and tangential
        acceleration [mm/s^2] where the profile passes them.
    """
    rows = profile.rows[profile.rows[:, 0] > 0]
    dur, s0, v0, a0, j0 = rows.T
    t_start = np.concatenate(([0.0], np.cumsum(dur)))
    bounds = move_bounds(lengths_mm)
    t_cut, v_cut, a_cut = profile.invert(bounds[1:-1]) if cut is None else cut
    t_cut = np.maximum.accumulate(np.clip(t_cut, 0.0, t_start[-1]))
    times = union_sorted(t_start, t_cut)
    t_lo, t_hi = times[:-1], times[1:]
    k = np.clip(np.searchsorted(t_start, t_lo, side="right") - 1, 0, dur.size - 1)
    tau = t_lo - t_start[k]
    jk = j0[k]
    a = a0[k] + tau * jk
    v = v0[k] + tau * (a0[k] + 0.5 * tau * jk)
    s = s0[k] + tau * (v0[k] + tau * (0.5 * a0[k] + tau * jk / 6.0))
    owner = np.searchsorted(t_cut, t_lo, side="right")
    s = np.maximum(s - bounds[owner], 0.0)
    table = np.column_stack([t_hi - t_lo, s, v, a, jk])
    kept = table[:, 0] > 0
    table, owner = table[kept], owner[kept]
    # owner never decreases (t_lo and t_cut are sorted): each move's rows are one slice (a
    # mask per move cost moves x rows, 3 s a chain of 12,000 tiny moves)
    edges = np.searchsorted(owner, np.arange(len(lengths_mm) + 1), side="left")
    parts = []
    for m in range(len(lengths_mm)):
        mine = table[edges[m] : edges[m + 1]].copy()
        if mine.size == 0:  # a move the profile passes in no time: hold its start state
            mine = np.zeros((1, 5))
        mine[0, 1] = 0.0
        parts.append(Profile1D(mine))
    return parts, v_cut, a_cut
