"""G64 corners between two straight moves that stay exact stops, passed with the two moves'
profiles overlapped.

In G64 a sharp corner between two lines stays an exact stop where its blend arc would be slower
(:mod:`~gantry_sim.controller.planner.blend_judge`): a jerk-limited reference passes a small arc
slowly, since the curvature jumps at its ends. The stop is not the fastest way through such a
corner that keeps every limit. The first move decelerates to rest at the corner C and the
second accelerates from rest there; overlapping the two by ``tau`` seconds,

    r(t) = A(T_A - tau + t) + B(t) - C,   t in [0, tau],

keeps position, velocity and acceleration continuous (both moves are at rest with no
acceleration at C) and makes the program ``tau`` shorter. Each axis' velocity, acceleration and
jerk in the overlap are the sums of the two moves' along it, so where the moves share no axis
(a pocket's linking lines, a plunge into a cut) both profiles keep their full jerk and the sum
keeps every limit; where they share one (a 30 degree turn) the jerks add past the limit at once
and the corner stays a stop. The reference leaves the two segments by the corner it cuts: the
overlap is kept within the G64 budget (P less the reference's share of the chord tolerance) of
both segments, and C within that of the reference (LinuxCNC's meaning of P: the path passes
within P of the programmed corner), as a blend arc is.

:func:`overlap_at` finds the longest overlap that keeps them
(:mod:`~gantry_sim.controller.planner.overlap_search`) and cuts the two chains' phases there.
A window of a long program that ends at such a stop holds its last chain back for the next
window's first (:mod:`~gantry_sim.controller.planner.windows`), so the windows overlap it as
the whole program does.

Which stops (:func:`~gantry_sim.controller.planner.prepare.stop_corners`): between two
straight feed moves, or two rapids, the first in G64 with a budget (the move before a junction
governs it, as in LinuxCNC), turning by less than 179 degrees (a reversal stays a stop, as in
LinuxCNC and grbl); not where the program asks for a stop (G61, G61.1, a dwell, M0/M1/M60, a
Marlin limit change), not between a rapid and a feed move (LinuxCNC 2.9 stops there, and
blends two rapids), not next to a curve.

The peer pocket of issue 12 (``benchmarks/bench_peer.py``) overlaps its 352 stops between
lines by 11-15 ms each: 196.46 -> 191.15 s, 1.035 x LinuxCNC's time instead of 1.063.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.moves import Linear, PathMove, Rapid
from gantry_sim.controller.planner.chains import Chain
from gantry_sim.controller.planner.cubic import Chunk, Jerk3Run, Segment
from gantry_sim.controller.planner.move_geometry import MoveGeometry
from gantry_sim.controller.planner.overlap_search import (
    LIMIT_REL,
    STEP_S,
    Corner,
    Found,
    Phases,
    phase_starts_s,
    search,
    state_at,
)

__all__ = ["Overlapped", "Pending", "first_move_s", "last_move_s", "overlap_at"]


@dataclass(frozen=True)
class Pending:
    """A chain's end (or start) at a stop, as an overlap there needs it: its ``chunk``, how
    long its last (first) move lasts that no other overlap took [s], that move's geometry,
    and the M204 path acceleration it runs under [mm/s^2] (inf: none)."""

    chunk: Chunk
    room_s: float
    geometry: MoveGeometry
    path_acc_mm_per_s2: float = math.inf


@dataclass(frozen=True)
class Overlapped:
    """A stop overlapped: where the overlap starts [s], how long it lasts [s], the line of the
    move ending at the corner, the largest deviation [mm] (:attr:`Found.deviation_mm`), the
    budget it was held to [mm], and the subroutine file of the line (None: the program's)."""

    start_s: float
    tau_s: float
    line: int
    deviation_mm: float
    budget_mm: float
    file: str | None = None


def first_move_s(chain: Chain) -> float:
    """How long the first move of ``chain`` lasts [s]."""
    return chain.starts_s[1] if len(chain.starts_s) > 1 else chain.duration_s


def last_move_s(chain: Chain, taken_s: float = 0.0) -> float:
    """How long the last move of ``chain`` lasts [s], less ``taken_s`` [s] where it is also
    the first and an overlap took that much of its start."""
    alone = len(chain.starts_s) == 1
    return chain.duration_s - chain.starts_s[-1] - (taken_s if alone else 0.0)


def overlappable(first: PathMove, second: PathMove) -> bool:
    """Whether a stop between ``first`` and ``second`` may overlap their profiles: both
    straight feed moves, or both rapids (a rapid and a feed move meet at rest, as in LinuxCNC
    2.9; a curve's end is not straight)."""
    return (isinstance(first, Linear) and isinstance(second, Linear)) or (
        isinstance(first, Rapid) and isinstance(second, Rapid)
    )


def overlap_at(
    a: Pending, b: Pending, budget_mm: float, limits: Limits
) -> tuple[Chunk, Chunk, Found] | None:
    """The longest overlap at the stop between chain end ``a`` and chain start ``b`` (both
    straight feed moves or both rapids, else none) within ``budget_mm`` [mm] and the
    machine's ``limits``:
    the two chunks cut for it (``a``'s up to the overlap, then the overlap; ``b``'s after it)
    and the overlap; None where none keeps them."""
    ma, mb = a.geometry.move, b.geometry.move
    if not overlappable(ma, mb) or budget_mm <= 0.0:
        return None
    vmax, amax, jmax = (np.asarray(x, dtype=float) for x in limits.per_axis())
    if _jerks_add_past(a.chunk[-1], b.chunk[0], jmax):
        return None
    room = min(a.room_s, b.room_s) - STEP_S  # each move keeps a step of its own
    if room < STEP_S:
        return None
    corner = Corner(
        start_mm=np.asarray(ma.start, dtype=float),
        point_mm=np.asarray(ma.end, dtype=float),
        end_mm=np.asarray(mb.end, dtype=float),
        feed_mm_per_s=min(a.geometry.feed_mm_per_s, b.geometry.feed_mm_per_s),
        budget_mm=budget_mm,
        limits=(vmax, amax, jmax),
        path_acc_mm_per_s2=min(a.path_acc_mm_per_s2, b.path_acc_mm_per_s2),
    )
    before, tail = _tail(a.chunk, room)
    head, after = _head(b.chunk, room)
    found = search(tail, head, corner, room)
    if found is None:
        return None
    tau = found.tau_s
    cut_a = tuple(_until(tail[i], float(np.sum(tail[i][0])) - tau) for i in range(3))
    cut_b = tuple(_from(head[i], tau) for i in range(3))
    return (
        (*before, (cut_a[0], cut_a[1], cut_a[2]), found.phases),
        ((cut_b[0], cut_b[1], cut_b[2]), *after),
        found,
    )


def _jerks_add_past(last: Segment, first: Segment, jerk_limit: np.ndarray) -> bool:
    """Whether the first move's last phase (of the segment ``last``) and the second's first
    (of ``first``) have jerks that add past ``jerk_limit`` (3,) [mm/s^3] on some axis: every
    overlap holds both phases, so none keeps the limits (most corners whose moves share an
    axis, found before anything is laid out)."""
    ends = []
    for seg, pick in ((last, -1), (first, 0)):
        jerk = np.empty(3)
        for i in range(3):
            rows = _axis(seg, i)
            timed = np.flatnonzero(rows[0] > 0.0)
            jerk[i] = rows[4, timed[pick]] if timed.size else 0.0
        ends.append(jerk)
    return bool((np.abs(ends[0] + ends[1]) > jerk_limit * (1.0 + LIMIT_REL)).any())


def _axis(seg: Segment, axis: int) -> np.ndarray:
    if isinstance(seg, Jerk3Run):
        return np.array(seg.axis_phases(axis))
    return np.asarray(seg[axis])


def _laid_out(segments: Sequence[Segment]) -> Phases:
    out = [np.concatenate([_axis(s, i) for s in segments], axis=1) for i in range(3)]
    return out[0], out[1], out[2]


def _duration(seg: Segment) -> float:
    return float(np.sum(_axis(seg, 0)[0]))


def _tail(chunk: Chunk, span_s: float) -> tuple[Chunk, Phases]:
    """The segments of ``chunk`` before those covering its last ``span_s`` [s], and those
    laid out."""
    k, covered = len(chunk), 0.0
    while k > 0 and covered < span_s:
        k -= 1
        covered += _duration(chunk[k])
    return chunk[:k], _laid_out(chunk[k:])


def _head(chunk: Chunk, span_s: float) -> tuple[Phases, Chunk]:
    """Those laid out covering the first ``span_s`` [s] of ``chunk``, and the rest."""
    k, covered = 0, 0.0
    while k < len(chunk) and covered < span_s:
        covered += _duration(chunk[k])
        k += 1
    return _laid_out(chunk[:k]), chunk[k:]


def _until(rows: np.ndarray, t_end: float) -> np.ndarray:
    """The phases ``rows`` up to time ``t_end`` [s] (the one it falls in shortened)."""
    t0 = phase_starts_s(rows)
    keep = t0 < t_end
    out = rows[:, keep].copy()
    if out.shape[1]:
        out[0, -1] = t_end - t0[keep][-1]
    return out


def _from(rows: np.ndarray, t_start: float) -> np.ndarray:
    """The phases ``rows`` from time ``t_start`` [s] on (the one it falls in starting there,
    in its state at that time)."""
    t0 = phase_starts_s(rows)
    ends = t0 + rows[0]
    k = min(int(np.searchsorted(ends, t_start, side="right")), rows.shape[1] - 1)
    out = rows[:, k:].copy()
    out[0, 0] = max(ends[k] - t_start, 0.0)
    out[1:5, 0] = state_at(rows[1:5, k], t_start - t0[k])
    return out
