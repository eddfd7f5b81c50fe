"""G64 stops whose two moves share an axis: their ramps take a share of the jerk, so that the
two profiles may overlap (:mod:`~gantry_sim.controller.planner.stop_overlap`).

At a stop between two straight moves A and B, A's last phase (its deceleration easing off,
tangential jerk +j_A along A's direction dA) and B's first (its acceleration building up,
+j_B along dB) run at once in every overlap. Where the moves share an axis (a 30 degree turn:
both mostly along X) those jerks add past the axis' limit, so no overlap keeps the limits and
the corner stays a plain stop (an engraving's corners, a zigzag). Planned with the jerk scaled
by ``s`` so that ``s (j_A |dA_i| + j_B |dB_i|) <= J_i`` on every axis, the two ramps keep every
limit whatever phases of them meet, and the overlap search may take the stop's time back.

That is not free: a ramp under less jerk is longer. Each such corner is judged with the
time a symmetric S-curve ramp between rest and the speed v loses against cruising at v,

    lost(v, a, j) = sqrt(v / j)            where v j <= a^2 (the jerk never lets a reach a),
                  = (v / a + a / j) / 2    otherwise,

on each of the four ramps of the two moves (v: the move's cap, or the speed it can reach
ramping at both ends, whichever is lower; the move's jerk is scaled whole, so its ramp at
its other end is longer too), against the overlap the shared jerk allows: each ramp's time
to cover the distance ``budget / (2 sin(turn / 2))`` from the corner (where the two ramps
cross, the reference is that far from each segment times sin(turn), and from the corner
times 2 sin(turn / 2)). The jerk is shared where the overlap gains more than the four ramps
lose, by 1 ms at least (:data:`MIN_GAIN_S`): at low speeds and on short moves (engraving:
1.3-3.5 %, `benchmarks/bench_engraving.py`), not on long fast moves (25 mm at F20000: 4.995 s
stopping, 5.248 s shared). Counting only the two ramps at the corner shared a slicer's lone
45 degree infill corner between short moves from and to rest, 6 % slower; where the stop at a move's other end shares too, its overlap
pays for that ramp, so a chain of such corners (a 5 mm zigzag at F3000: 5.584 s against
5.725 s stopping) would gain where this estimate keeps the stops, but whether it does lies
beyond the two moves. The estimate reads nothing beyond them, so a stretch of the path
(:func:`~gantry_sim.controller.planner.prepare.sub_path`) makes the choices the whole path
makes. The blend judge counts the overlap at the stop that would replace a blend arc as
:func:`stop_credit_s` says: nothing where that stop would not share, and a move's far ramp
paid for by a blend arc beyond it (a chain of blends judged slow becomes a chain of stops
that share).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.planner.blend import MAX_TURN_RAD
from gantry_sim.controller.planner.blend_judge import ramp_s
from gantry_sim.controller.planner.limits import BlockLimits
from gantry_sim.controller.planner.move_geometry import MoveGeometry
from gantry_sim.controller.planner.overlap_search import LIMIT_REL

__all__ = [
    "NO_SHARE",
    "Estimate",
    "overlap_estimate",
    "ramp_lost_s",
    "ramp_reach_s",
    "share_jerk_at_stops",
    "shared_stops",
    "stop_credit_s",
]

#: The share of the estimated overlap the search is counted on to find (it found 0.95 of it
#: on a zigzag of 30 degree turns at F6000, where a share judged on the whole estimate made
#: the program 0.3 % slower than its stops).
OVERLAP_TAKEN = 0.9
#: The least time [s] a stop's share must be estimated to gain, its four ramps counted: the
#: estimate's error (a slicer's 45 degree infill, PrusaSlicer's 15x150 test part: 2,857
#: stops estimated to gain 0.1 ms each lost 0.7 ms each, the print 0.08 % slower; with this
#: bound 0.04 % faster, engravings and zigzags of short moves keep 1.4-8 %).
MIN_GAIN_S = 1e-3
#: The shared jerk stays this far below what the axes allow (the pieces keep their limits to
#: about 1e-12; the overlap search allows LIMIT_REL).
SHARE_MARGIN = 1e-9
#: A turn past MAX_TURN_RAD stays a plain stop (prepare.stop_corners).
COS_MAX_TURN = math.cos(MAX_TURN_RAD)


class Estimate(NamedTuple):
    """:func:`overlap_estimate` of one stop: ``gain_s`` [s], the overlap's time less what the
    share costs the two ramps at the corner; ``share``, the jerk share (1: none needed, the
    two moves' jerks keep the limits as they are); ``far_lost_s`` [s], what it costs each
    move's ramp at its other end (the first move's start, the second's end): lost there
    unless that stop shares too, where its own estimate counts it."""

    gain_s: float
    share: float
    far_lost_s: tuple[float, float]

    @property
    def shares(self) -> bool:
        """Whether the planner takes this stop's share: one is needed, and it gains more than
        all four ramps lose, by :data:`MIN_GAIN_S` at least."""
        return self.share < 1.0 and self.gain_s - sum(self.far_lost_s) > MIN_GAIN_S


NO_SHARE = Estimate(0.0, 1.0, (0.0, 0.0))


def shared_stops(
    active: Sequence[MoveGeometry], corners: Mapping[int, float], jmax: np.ndarray
) -> dict[int, Estimate]:
    """The stops of ``corners`` (junction -> G64 budget [mm]) whose two moves share their jerk
    (module docstring), with their estimates: those estimated to gain more than the share
    costs all four ramps of the two moves, the far ones too (:attr:`Estimate.far_lost_s`:
    whether the stop at a move's other end shares as well lies beyond the two moves, which a
    window of a long program may not hold; ``jmax``: the axes' jerk limits (3,) [mm/s^3])."""
    kept = {}
    for b, budget in corners.items():
        ga, gb = active[b - 1], active[b]
        e = overlap_estimate(ga.limits, gb.limits, ga.tangent_out, gb.tangent_in, budget, jmax)
        if e.shares:
            kept[b] = e
    return kept


def share_jerk_at_stops(
    active: Sequence[MoveGeometry], corners: Mapping[int, float], limits: Limits
) -> tuple[list[MoveGeometry], frozenset[int]]:
    """``active`` with the tangential jerk of the moves next to each stop of ``corners``
    (junction -> G64 budget [mm]) scaled down where their jerks add past an axis' limit and
    sharing it gains time (:func:`shared_stops`); a move next to two such stops takes the
    smaller share. The moves elsewhere are the same objects. And the junctions of the stops
    that share."""
    jmax = np.asarray(limits.per_axis()[2], dtype=float)
    shared = shared_stops(active, corners, jmax)
    share: dict[int, float] = {}
    for b, e in shared.items():
        for k in (b - 1, b):
            share[k] = min(share.get(k, 1.0), e.share)
    out = list(active)
    for k, s in share.items():
        g = active[k]
        out[k] = replace(g, limits=replace(g.limits, jerk_mm_per_s3=g.limits.jerk_mm_per_s3 * s))
    return out, frozenset(shared)


def stop_credit_s(e: Estimate, far_pays: tuple[bool, bool]) -> float:
    """The time [s] the blend judge counts off the stop that would replace a blend arc, from
    the stop's estimate ``e``: none where the stop would not overlap, or would not share the
    jerk it needs (:func:`shared_stops`' rule, all four ramps counted); else its gain less each
    far ramp's loss unless ``far_pays`` says that end pays for it (a blend arc there, likely
    judged a stop too in a chain of them, or a stop that shares)."""
    if e.gain_s <= 0.0 or (e.share < 1.0 and not e.shares):
        return 0.0
    return e.gain_s - sum(
        lost for lost, pays in zip(e.far_lost_s, far_pays, strict=True) if not pays
    )


def overlap_estimate(
    la: BlockLimits,
    lb: BlockLimits,
    da: np.ndarray,
    db: np.ndarray,
    budget_mm: float,
    jmax: np.ndarray,
) -> Estimate:
    """What an overlap is estimated to save at a stop between a straight move with limits
    ``la`` ending along the unit direction ``da`` and one with ``lb`` starting along ``db``,
    within ``budget_mm`` [mm], against the plain stop, and the jerk share it needs (module
    docstring; share 1 where the two moves' jerks keep the limits as they are):
    :data:`NO_SHARE` where no overlap is counted on (a reversal, no budget, sharing the jerk
    costing the two ramps at the corner more than it gains). ``jmax``: the axes' jerk limits
    (3,) [mm/s^3]."""
    cos_turn = min(max(float(da @ db), -1.0), 1.0)
    half_chord = math.sqrt(0.5 * (1.0 - cos_turn))  # sin(turn / 2)
    if not budget_mm > 0.0 or half_chord <= 0.0 or cos_turn <= COS_MAX_TURN:
        return NO_SHARE
    reach_mm = budget_mm / (2.0 * half_chord)
    ja, jb = la.jerk_mm_per_s3, lb.jerk_mm_per_s3
    s = 1.0  # where the two jerks keep the limits, the overlap needs no share (stop_overlap)
    if (np.abs(ja * da + jb * db) > jmax * (1.0 + LIMIT_REL)).any():  # they add past a limit
        need = ja * np.abs(da) + jb * np.abs(db)
        s = float(np.min(jmax[need > 0.0] / need[need > 0.0])) * (1.0 - SHARE_MARGIN)
        if not 0.0 < s < 1.0:
            return NO_SHARE
    reach_s, ramps_s, lost = 0.0, [], []
    for lim in (la, lb):
        a, j = lim.acc_mm_per_s2, lim.jerk_mm_per_s3
        v = _top_speed(lim.length_mm, lim.cap_mm_per_s, a, j)
        if not v > 0.0:
            return NO_SHARE
        reach_s += ramp_reach_s(reach_mm, v, a, s * j)
        ramps_s.append(ramp_s(v, a, s * j))
        lost.append(ramp_lost_s(v, a, s * j) - ramp_lost_s(v, a, j))
    # the overlap takes at most a whole ramp: beyond it the two speeds add past the feed
    gain = OVERLAP_TAKEN * min(reach_s, *ramps_s) - lost[0] - lost[1]
    return Estimate(gain, s, (lost[0], lost[1])) if gain > 0.0 else NO_SHARE


def ramp_lost_s(v: float, a: float, j: float) -> float:
    """The time [s] a symmetric S-curve ramp between rest and speed ``v`` [mm/s] under
    acceleration ``a`` [mm/s^2] and jerk ``j`` [mm/s^3] loses against cruising at ``v`` over
    the same distance (half the ramp's duration)."""
    return 0.5 * ramp_s(v, a, j)


def _top_speed(length_mm: float, cap: float, a: float, j: float) -> float:
    """The speed [mm/s] a move of ``length_mm`` reaches from rest to rest under ``a`` and
    ``j``, at most ``cap``: the two ramps cover ``v ramp_s(v)``, which grows with ``v``;
    solved in closed form on each of its two branches (2 v^1.5 / sqrt(j) while the jerk
    never lets the acceleration reach ``a``, v^2 / a + v a / j once it does)."""
    if cap * ramp_s(cap, a, j) <= length_mm:
        return cap
    v = (0.5 * length_mm * math.sqrt(j)) ** (2.0 / 3.0)
    if v * j <= a * a:
        return v
    k = a / j
    return 0.5 * a * (math.sqrt(k * k + 4.0 * length_mm / a) - k)


def ramp_reach_s(d_mm: float, v: float, a: float, j: float) -> float:
    """The time [s] the S-curve ramp from rest to ``v`` [mm/s] (``a``, ``j`` as in
    :func:`ramp_lost_s`) takes to cover ``d_mm`` [mm] (cruising at ``v`` after it): in closed
    form in the jerk phase, the constant acceleration and the cruise, by bisection of the
    cubic in the phase easing off."""
    t1 = min(a / j, math.sqrt(v / j))  # the jerk phase; then constant acceleration, if any
    a1 = j * t1
    s1, v1 = j * t1**3 / 6.0, 0.5 * a1 * t1
    if d_mm <= s1:
        return (6.0 * d_mm / j) ** (1.0 / 3.0)
    t2 = max(v / a1 - t1, 0.0)  # the constant-acceleration phase
    s2, v2 = s1 + v1 * t2 + 0.5 * a1 * t2 * t2, v1 + a1 * t2
    if d_mm <= s2:
        return t1 + (math.sqrt(v1 * v1 + 2.0 * a1 * (d_mm - s1)) - v1) / a1
    s3 = s2 + v2 * t1 + 0.5 * a1 * t1 * t1 - j * t1**3 / 6.0  # the phase easing off
    if d_mm > s3:
        return 2.0 * t1 + t2 + (d_mm - s3) / v
    lo, hi = 0.0, t1
    for _ in range(50):
        u = 0.5 * (lo + hi)
        lo, hi = (u, hi) if s2 + u * (v2 + u * (0.5 * a1 - u * j / 6.0)) < d_mm else (lo, u)
    return t1 + t2 + hi
