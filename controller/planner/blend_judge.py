"""Is a G64 blend faster than an exact stop? An estimate of both passes' times.

A blend lets the moves either side of a corner keep speed instead of stopping, but the blend
arc itself is passed slowly where its curvature jumps from 0 to 1/R at its ends (a jerk-limited
reference smooths that within the arc's first chord): a 14 degree turn of 5 mm moves at P0.01,
F3000, passed at 9.8 mm/s, took 1.044 x the plan with exact stops. No share of the feed decides
this alone: between 2 mm moves at F3000 a 6 degree corner's blend takes 0.85 x the stops' time,
between 20 mm moves at F1200 a 40 degree corner's 1.01 x, and the rule that kept only blends
entered at half the feed or more stopped at 2,120 of the 2,999 corners of a generated polyline
(0.05-0.5 mm moves turning 0.5-5 degrees at F3000), whose cycle was then 105.15 s against
48.30 s blended.

The estimate, per side of the corner: the neighbouring move, from its junction with the blend
to its middle, ramps from the junction speed to the highest speed it reaches there (its cap, or
less on a short move), a symmetric jerk-limited ramp under its tangential acceleration and jerk
(the 1-D profile the planner gives a move between two equal end speeds); the blend arc likewise,
each half from its junction towards its own cap (a blend of a fraction of a millimetre between
two slow junctions never reaches it). The junction speeds are the caps the planner's pieces
reach in the end (:func:`~gantry_sim.controller.planner.prepare.slow_blends`). With a stop,
each side runs from rest over its half and the part of the blend's path it would have cut (half
the blend's length). The blend is kept unless the stop's estimate is shorter by more than
:data:`STOP_GAIN_MIN`.

Measured (``plan()`` of 12 moves turning 6-40 degrees back and forth at P0.01, moves of 2, 5
and 20 mm at F1200, F3000 and F6000: 63 programs, each planned with every blend kept and with
every corner an exact stop, blending taking 0.80-1.18 x the stops' time): the estimate chose
the faster plan on 55; on the other 8 it blended where stopping was 0.1-1.7 % faster (without
:data:`STOP_GAIN_MIN`, on 4, by the same 0.1-1.7 %). It takes each corner alone: where corners
lie a fraction of a millimetre apart their speeds carry over.

Conventions: mm, s; speeds mm/s, accelerations mm/s^2, jerks mm/s^3.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.planner.limits import BlockLimits

__all__ = ["blend_faster", "blend_faster_many", "half_move_s_many", "ramp_s"]

#: Bisection steps finding the highest speed a short move reaches (to 6e-8 of its cap: 40 steps
#: were 0.35 s of planning 3,000 polyline blocks).
PEAK_STEPS = 24
#: An exact stop replaces a blend only where the stop is estimated faster by more than this
#: share: the program asks for the blend, and where the ramps take no time (low feeds) the two
#: estimates tie to rounding (a corner at F0.00001 became an exact stop by 1e-16).
STOP_GAIN_MIN = 0.01


def ramp_s(dv: float, acc: float, jerk: float) -> float:
    """Time [s] of a jerk-limited change of speed by ``dv`` between two states without
    acceleration (the acceleration limited to ``acc``)."""
    if dv <= 0.0:
        return 0.0
    if dv * jerk <= acc * acc:
        return 2.0 * math.sqrt(dv / jerk)
    return dv / acc + acc / jerk


def _ramp_mm(v0: float, v1: float, acc: float, jerk: float) -> float:
    """Path length [mm] of that ramp from ``v0`` to ``v1`` (symmetric in time: the mean speed)."""
    return 0.5 * (v0 + v1) * ramp_s(v1 - v0, acc, jerk)


def half_move_s(v: float, distance_mm: float, lim: BlockLimits) -> float:
    """Time [s] from speed ``v`` over ``distance_mm`` towards the move's cap, ending at the
    highest speed reached there with no acceleration (the middle of a move whose ends are both
    passed at ``v``)."""
    if distance_mm <= 0.0:
        return 0.0
    cap, acc, jerk = lim.cap_mm_per_s, lim.acc_mm_per_s2, lim.jerk_mm_per_s3
    v = min(v, cap)
    full = _ramp_mm(v, cap, acc, jerk)
    if full <= distance_mm:
        return ramp_s(cap - v, acc, jerk) + (distance_mm - full) / cap
    lo, hi = v, cap  # the peak reached within distance_mm
    for _ in range(PEAK_STEPS):
        mid = 0.5 * (lo + hi)
        if _ramp_mm(v, mid, acc, jerk) <= distance_mm:
            lo = mid
        else:
            hi = mid
    return ramp_s(lo - v, acc, jerk) + (distance_mm - _ramp_mm(v, lo, acc, jerk)) / max(lo, 1e-9)


def blend_faster(
    ends_mm_per_s: tuple[float, float],
    blend: BlockLimits,
    before: BlockLimits,
    after: BlockLimits,
    stop_credit_s: float = 0.0,
) -> bool:
    """Whether a blend arc with the limits ``blend``, entered and left at ``ends_mm_per_s``
    (the junction caps with the moves either side), between moves with the limits ``before``
    and ``after`` (as the blend left them), is estimated faster than an exact stop at the
    corner (module docstring), ``stop_credit_s`` [s] shorter where its two moves' profiles
    would overlap (:mod:`~gantry_sim.controller.planner.shared_jerk`). The estimate's
    definition, corner by corner in floats: the planner judges a window's corners at once with
    :func:`blend_faster_many`, which gives the same choices (``tests/test_blend_judge.py``
    compares them)."""
    v_in, v_out = (min(v, blend.cap_mm_per_s) for v in ends_mm_per_s)
    if min(v_in, v_out) <= 0.0:
        return False
    half = 0.5 * blend.length_mm
    passing = (
        half_move_s(v_in, half, blend)
        + half_move_s(v_out, half, blend)
        + half_move_s(v_in, 0.5 * before.length_mm, before)
        + half_move_s(v_out, 0.5 * after.length_mm, after)
    )
    stopping = sum(half_move_s(0.0, 0.5 * lim.length_mm + half, lim) for lim in (before, after))
    stopping -= stop_credit_s
    return passing <= (1.0 + STOP_GAIN_MIN) * stopping


def blend_faster_many(
    ends_mm_per_s: Sequence[tuple[float, float]],
    blends: Sequence[BlockLimits],
    before: Sequence[BlockLimits],
    after: Sequence[BlockLimits],
    stop_credit_s: Sequence[float] | None = None,
) -> np.ndarray:
    """:func:`blend_faster` of each corner, at once (bool array): the estimates of
    :func:`half_move_s_many`, summed in the same order, so the same choices (``stop_credit_s``:
    per corner, None: 0)."""
    n = len(blends)
    if n == 0:
        return np.zeros(0, dtype=bool)
    ends = np.array(ends_mm_per_s, dtype=float).reshape(n, 2)
    lims = np.array(
        [
            [m.length_mm, m.cap_mm_per_s, m.acc_mm_per_s2, m.jerk_mm_per_s3]
            for side in (blends, before, after)
            for m in side
        ],
        dtype=float,
    ).reshape(3, n, 4)
    blend, prev, nxt = lims
    cap = blend[:, 1]
    v_in = np.where(cap < ends[:, 0], cap, ends[:, 0])  # min(v, cap), as blend_faster takes it
    v_out = np.where(cap < ends[:, 1], cap, ends[:, 1])
    half = 0.5 * blend[:, 0]
    zero = np.zeros(n)
    # the six estimates of each corner, one call: v, distance, and the move's limits
    v = np.concatenate((v_in, v_out, v_in, v_out, zero, zero))
    d = np.concatenate(
        (half, half, 0.5 * prev[:, 0], 0.5 * nxt[:, 0], 0.5 * prev[:, 0] + half,
         0.5 * nxt[:, 0] + half)
    )  # fmt: skip
    lim = np.concatenate((blend, blend, prev, nxt, prev, nxt))
    t = half_move_s_many(v, d, lim[:, 1], lim[:, 2], lim[:, 3]).reshape(6, n)
    passing = t[0] + t[1] + t[2] + t[3]
    stopping = t[4] + t[5]
    if stop_credit_s is not None:
        stopping = stopping - np.asarray(stop_credit_s, dtype=float)
    return (v_in > 0.0) & (v_out > 0.0) & (passing <= (1.0 + STOP_GAIN_MIN) * stopping)


def half_move_s_many(
    v: np.ndarray, distance_mm: np.ndarray, cap: np.ndarray, acc: np.ndarray, jerk: np.ndarray
) -> np.ndarray:
    """:func:`half_move_s` of each element (speeds [mm/s], distances [mm], each move's speed
    cap [mm/s], acceleration [mm/s^2] and jerk [mm/s^3]), with the same operations in the
    same order (IEEE sums, products, quotients and square roots: the same numbers bit for
    bit), the bisection run on all of them at once."""
    with np.errstate(all="ignore"):  # the branches not taken are computed too
        v = np.where(cap < v, cap, v)  # min(v, cap)
        full = _ramp_mm_many(v, cap, acc, jerk)
        cruise = _ramp_s_many(cap - v, acc, jerk) + (distance_mm - full) / cap
        lo, hi = v.copy(), cap.copy()
        for _ in range(PEAK_STEPS):
            mid = 0.5 * (lo + hi)
            below = _ramp_mm_many(v, mid, acc, jerk) <= distance_mm
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        reached = np.where(1e-9 > lo, 1e-9, lo)  # max(lo, 1e-9)
        peak = (
            _ramp_s_many(lo - v, acc, jerk)
            + (distance_mm - _ramp_mm_many(v, lo, acc, jerk)) / reached
        )
        out = np.where(full <= distance_mm, cruise, peak)
    return np.where(distance_mm <= 0.0, 0.0, out)


def _ramp_s_many(dv: np.ndarray, acc: np.ndarray, jerk: np.ndarray) -> np.ndarray:
    """:func:`ramp_s` of each element."""
    short = 2.0 * np.sqrt(dv / jerk)
    long = dv / acc + acc / jerk
    return np.where(dv <= 0.0, 0.0, np.where(dv * jerk <= acc * acc, short, long))


def _ramp_mm_many(v0: np.ndarray, v1: np.ndarray, acc: np.ndarray, jerk: np.ndarray) -> np.ndarray:
    """:func:`_ramp_mm` of each element."""
    return 0.5 * (v0 + v1) * _ramp_s_many(v1 - v0, acc, jerk)
