"""A spline whose curvature varies a lot, cut into parts planned at their own speeds.

The planner caps a move's speed with one number per move: for an arc the curvature is the same
everywhere, but a spline's varies along it, and its caps (``spline_geometry.curvature_bounds``:
v^2 |k| <= a and v^3 |p'''| <= j with the largest |k| and |p'''| along the curve) come from its
tightest point. A G5 whose control points make it turn sharply in one place (a near-cusp: it
slows almost to a stop there and turns back on itself within microns) was followed at that
point's speed over its whole length: a 35 mm cubic of LinuxCNC's G5 tests at 0.11 mm/s, 332 s,
where the part outside the first and last tenth of a millimetre round its kink allows 25 mm/s.

:func:`split_slow_parts` cuts such a spline into consecutive splines, together the same curve
(knot insertion, :func:`~gantry_sim.controller.nurbs.split_bspline`: position, tangent and
curvature continuous where they meet, so those junctions keep their speed in every path mode
and the reference stays on the programmed curve as before):

1. The cap profile v(t) = min(F, sqrt(a / |k|), (j / |p'''|)^(1/3)) is sampled
   (:data:`SAMPLES_PER_SPAN` per knot span, finer where it changes fast; a, j: the smaller
   limits of X and Y, the splines' plane).
2. Greedily, the part whose cut saves the most is cut around its slowest sample: that sample's
   neighbourhood, to where v reaches :data:`CORE_RATIO` times its speed (or the part's highest),
   becomes a part of its own, when the time at the sampled caps (length / the slowest sample)
   falls to :data:`KEEP_SHARE` of the part's; at most :data:`MAX_PARTS` parts, none shorter
   than :data:`MIN_PART_MM`.
3. The cut is kept only where the parts' time at the caps the planner itself gives each (its
   bounds, sampled per chord and per knot span), with the ramps between them
   (:func:`traverse_s`, from rest to rest), is at most :data:`KEEP_SHARE` of the uncut move's.
   Sampled along a short part, the bounds may find a spike of curvature that the profile and
   the uncut move's samples missed (a loop far smaller than the chord tolerance, which the
   reference, within the tolerance of the curve, cuts), and a part around it would crawl (a
   random NURBS: 8.2 s for 1 um, where the uncut move took 0.76 s); a part the planner would
   refuse as reversing at a cusp keeps the move uncut, as before. No cut leaves a part with a
   zero-speed end one chord long (:func:`_ends_kept`).

Each part is then planned as any spline. The parts keep the move's line, feed and path control;
the path's ``sources`` map them all to the program's move. Near a zero-speed end (G5 ``I0 J0``)
the curvature grows without bound and the planner follows the end chord piece by piece
(spline_geometry's docstring): no cut is made within :data:`ZERO_SPEED_END_SHARE` of the length
of such an end. NURBS with a weight <= 0 are not cut.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import weakref

import numpy as np

from gantry_sim.controller.config import Limits, Segmentation
from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.moves import Spline
from gantry_sim.controller.nurbs import split_bspline
from gantry_sim.controller.planner.limits import path_feed_mm_per_s, s_curve_time
from gantry_sim.controller.planner.lookahead import max_reachable_speed
from gantry_sim.controller.planner.segment import spline_segment_count
from gantry_sim.controller.planner.spline_geometry import arc_length_derivatives, curvature_bounds

__all__ = ["split_slow_parts"]

#: cap profile samples per knot span, and where the cap changes by more than REFINE_RATIO
#: between two samples, REFINE_SAMPLES more between them, for at most REFINE_ROUNDS rounds and
#: MAX_SAMPLES samples
SAMPLES_PER_SPAN = 1024
REFINE_RATIO = 1.25
REFINE_SAMPLES = 7
REFINE_ROUNDS = 8
MAX_SAMPLES = 65_536
#: a part around the slowest sample reaches to where the cap is this many times its speed
CORE_RATIO = 2.0
#: a cut is kept where the parts' estimated time is at most this share of the uncut time
KEEP_SHARE = 0.8
MAX_PARTS = 32
MIN_PART_MM = 5e-3
#: no cut within this share of the length of a zero-speed end
ZERO_SPEED_END_SHARE = 0.05
#: samples whose derivatives are taken at once (a hostile G5.2 of 5,000 knot spans has 5
#: million samples: their third derivatives and speed caps held 1.8 GB at once)
CAP_CHUNK = 65_536


def split_slow_parts(
    move: Spline, limits: Limits, segmentation: Segmentation, feed_scale: float = 1.0
) -> list[Spline]:
    """``move`` as consecutive splines planned at their own caps (module docstring), or
    ``[move]`` where cutting saves too little. ``segmentation``: the machine's chords (the
    uncut move's caps are the planner's, from bounds sampled per chord); ``feed_scale``: the
    feed override [1]. The parts are kept per move (the planner makes its path again where
    it finds blends slower than stops, and would cut every spline again)."""
    key = (limits, segmentation, feed_scale)
    kept = _PARTS.setdefault(move, {})
    if key not in kept:
        parts = _made_parts(move, limits, segmentation, feed_scale)
        kept[key] = parts if len(parts) > 1 else None  # (not the move itself: a weak key)
    return kept[key] or [move]


#: per spline move, its parts by (limits, segmentation, feed scale); None: left whole
_PARTS: weakref.WeakKeyDictionary[Spline, dict[tuple, list[Spline] | None]] = (
    weakref.WeakKeyDictionary()
)


def _made_parts(
    move: Spline, limits: Limits, segmentation: Segmentation, feed_scale: float
) -> list[Spline]:
    """:func:`split_slow_parts`, made."""
    if min(move.weights) <= 0.0:
        return [move]
    curve = move.curve
    nurbs = curve.nurbs
    spans = len(np.unique(move.knots)) - 1
    t = np.linspace(nurbs.t_min, nurbs.t_max, SAMPLES_PER_SPAN * max(spans, 1) + 1)
    s, cap = _cap_profile(move, t, limits, feed_scale)
    for _ in range(REFINE_ROUNDS):  # finer where the cap changes fast between two samples
        lo, hi = np.minimum(cap[:-1], cap[1:]), np.maximum(cap[:-1], cap[1:])
        steep = np.flatnonzero(np.isfinite(hi) & (hi > REFINE_RATIO * lo))
        if not steep.size or len(t) + REFINE_SAMPLES * steep.size > MAX_SAMPLES:
            break
        inner = (np.arange(1, REFINE_SAMPLES + 1) / (REFINE_SAMPLES + 1))[None, :]
        extra = (t[steep, None] + inner * (t[steep + 1] - t[steep])[:, None]).ravel()
        t = np.union1d(t, extra)
        s, cap = _cap_profile(move, t, limits, feed_scale)
    length = s[-1]
    if not length > 2.0 * MIN_PART_MM:
        return [move]
    cuts = _cuts(s, cap)
    if not cuts:
        return [move]
    ramps = _plane_limits(move, limits, feed_scale)[1:]
    try:
        parts = _ends_kept(move, [float(t[i]) for i in cuts], segmentation)
        if len(parts) < 2:
            return [move]
        caps = [_planner_cap(p, limits, segmentation, feed_scale) for p in parts]
        cut_s = traverse_s([p.length_mm for p in parts], caps, *ramps)
        whole_cap = _planner_cap(move, limits, segmentation, feed_scale)
    except PlanningError:  # (a part needing more chords than the planner makes): left whole,
        return [move]  # for the planner to take or refuse as before
    whole_s = traverse_s([length], [whole_cap], *ramps)
    return parts if cut_s <= KEEP_SHARE * whole_s else [move]


def _ends_kept(move: Spline, cuts: list[float], segmentation: Segmentation) -> list[Spline]:
    """``move`` cut at ``cuts`` (:func:`_pieces`), without the cuts that leave a part with a
    zero-speed end one chord long: the planner follows that chord state by state and caps the
    junction at its other end by the end's unbounded curvature (a 31 um part of a G5 without
    I J: 0.01 mm/s there, its spline 7 % slower cut than whole)."""
    zero = move.curve.zero_speed_ends
    parts = _pieces(move, cuts)
    while len(parts) > 1 and zero[0] and _chords(parts[0], segmentation) < 2:
        cuts = cuts[1:]
        parts = _pieces(move, cuts) if cuts else [move]
    while len(parts) > 1 and zero[1] and _chords(parts[-1], segmentation) < 2:
        cuts = cuts[:-1]
        parts = _pieces(move, cuts) if cuts else [move]
    return parts


def traverse_s(
    lengths_mm: list[float], caps_mm_per_s: list[float], acc: float, jerk: float
) -> float:
    """Time [s] to run consecutive stretches of ``lengths_mm`` from rest to rest, each at most
    at its cap, speed changes as S-curves under ``acc`` [mm/s^2] and ``jerk`` [mm/s^3]: the
    junction speeds by a forward and a backward pass of the reachable speeds, then each stretch
    up to the highest speed whose ramps fit in it (bisection), cruising between them. An
    estimate (each stretch alone, its ramps from zero acceleration): inf where a cap is 0."""
    if min(caps_mm_per_s) <= 0.0:
        return math.inf
    n = len(lengths_mm)
    w = [0.0] + [min(a, b) for a, b in itertools.pairwise(caps_mm_per_s)] + [0.0]
    for k in range(1, n + 1):
        w[k] = min(w[k], max_reachable_speed(w[k - 1], lengths_mm[k - 1], acc, jerk))
    for k in range(n - 1, 0, -1):
        w[k] = min(w[k], max_reachable_speed(w[k + 1], lengths_mm[k], acc, jerk))
    return sum(
        _stretch_s(length, cap, w[k], w[k + 1], acc, jerk)
        for k, (length, cap) in enumerate(zip(lengths_mm, caps_mm_per_s, strict=True))
    )


def _stretch_s(length: float, cap: float, v0: float, v1: float, acc: float, jerk: float) -> float:
    """Time [s] over ``length`` [mm] from ``v0`` to ``v1`` [mm/s], at most ``cap``."""

    def ramp(a: float, b: float) -> tuple[float, float]:  # (time, distance) of an S-curve
        t = s_curve_time(b - a, acc, jerk)
        return t, 0.5 * (a + b) * t

    def fits(v: float) -> bool:
        return ramp(v0, v)[1] + ramp(v, v1)[1] <= length

    top = cap
    if not fits(top):
        low = max(v0, v1)
        for _ in range(60):
            mid = 0.5 * (low + top)
            low, top = (mid, top) if fits(mid) else (low, mid)
        top = low
    (t_up, d_up), (t_down, d_down) = ramp(v0, top), ramp(top, v1)
    cruise = max(length - d_up - d_down, 0.0)
    return t_up + t_down + (cruise / top if top > 0.0 else 0.0)


def _planner_cap(
    move: Spline, limits: Limits, segmentation: Segmentation, feed_scale: float
) -> float:
    """A spline's speed cap [mm/s] from the bounds the planner takes (sampled per chord of its
    segmentation, :func:`~gantry_sim.controller.planner.spline_geometry.curvature_bounds`;
    its chord count is kept on the curve for the planner); 0 where the planner refuses it as
    reversing at a cusp."""
    feed, a, j = _plane_limits(move, limits, feed_scale)
    try:
        k, dk = curvature_bounds(move, _chords(move, segmentation))
    except PlanningError:
        return 0.0
    with np.errstate(divide="ignore"):
        return float(min(feed, np.sqrt(a / k), np.cbrt(j / dk)))


def _chords(move: Spline, segmentation: Segmentation) -> int:
    """The chords the planner gives ``move`` under ``segmentation`` (kept on its curve)."""
    return spline_segment_count(
        move, segmentation.method, segmentation.chord_tolerance_mm, segmentation.segment_length_mm
    )


def _plane_limits(move: Spline, limits: Limits, feed_scale: float) -> tuple[float, float, float]:
    """(speed cap [mm/s]: the feed under the override and the X and Y velocity limits;
    acceleration [mm/s^2]; jerk [mm/s^3]): the smaller limits of X and Y, the splines' plane."""
    vmax, amax, jmax = limits.per_axis()
    feed = path_feed_mm_per_s(move.feed_mm_per_min, feed_scale)
    return min(feed, vmax[0], vmax[1]), min(amax[0], amax[1]), min(jmax[0], jmax[1])


def _cap_profile(
    move: Spline, t: np.ndarray, limits: Limits, feed_scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """Arc length [mm] (trapezoids of the speed) and the speed cap [mm/s] at parameters ``t``
    (inf where no cut may be made: next to a zero-speed end), the curve's derivatives taken
    :data:`CAP_CHUNK` samples at a time (each sample is its own: the same numbers)."""
    curve = move.curve
    feed, a, j = _plane_limits(move, limits, feed_scale)
    speed, cap = np.empty(len(t)), np.full(len(t), np.inf)
    ok = np.empty(len(t), dtype=bool)
    for first in range(0, len(t), CAP_CHUNK):
        rows = slice(first, first + CAP_CHUNK)
        _, d1, d2, d3 = curve.nurbs.derivatives(t[rows], 3)
        speed[rows] = np.linalg.norm(d1, axis=1)
        good = ok[rows] = ~curve.zero_speed(d1)
        if good.any():
            _, p2, p3 = arc_length_derivatives(d1[good], d2[good], d3[good])
            with np.errstate(divide="ignore"):
                k_cap = np.sqrt(a / np.linalg.norm(p2, axis=1))
                dk_cap = np.cbrt(j / np.linalg.norm(p3, axis=1))
            cap[rows][good] = np.minimum(feed, np.minimum(k_cap, dk_cap))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    end = ZERO_SPEED_END_SHARE * s[-1]
    if not ok[0]:
        cap[s <= end] = np.inf
    if not ok[-1]:
        cap[s >= s[-1] - end] = np.inf
    return s, cap


def _cuts(s: np.ndarray, cap: np.ndarray) -> list[int]:
    """Sample indices to cut at, in order: the part whose cut saves the most time is cut, until
    no cut keeps :data:`KEEP_SHARE` or there are :data:`MAX_PARTS` parts (module docstring)."""
    parts = [(0, len(s) - 1)]
    while len(parts) < MAX_PARTS:
        best, best_saving = None, 0.0
        for k, (lo, hi) in enumerate(parts):
            split = _split(s, cap, lo, hi)
            if split is not None and split[1] > best_saving:
                best, best_saving = (k, split[0]), split[1]
        if best is None:
            break
        k, new = best
        if len(parts) + len(new) - 1 > MAX_PARTS:
            break
        parts[k : k + 1] = new
    return [lo for lo, _ in parts[1:]]


def _split(
    s: np.ndarray, cap: np.ndarray, lo: int, hi: int
) -> tuple[list[tuple[int, int]], float] | None:
    """Samples ``lo`` .. ``hi`` cut around their slowest sample (its part reaching to where the
    cap is :data:`CORE_RATIO` times its speed, or their highest) and the time that saves [s],
    or None where the parts would take more than :data:`KEEP_SHARE` of the uncut time."""
    seg = cap[lo : hi + 1]
    if not np.isfinite(seg).any():
        return None
    i = lo + int(np.argmin(seg))
    slowest = cap[i]
    top = float(np.max(seg[np.isfinite(seg)]))  # (the feed caps the profile)
    if not top > slowest:
        return None
    fast = np.flatnonzero(seg >= min(CORE_RATIO * slowest, top)) + lo
    before, after = fast[fast < i], fast[fast > i]
    a = int(before[-1]) + 1 if before.size else lo
    b = int(after[0]) - 1 if after.size else hi
    a, b = _widened(s, a, b, lo, hi)
    parts = [(x, y) for x, y in ((lo, a), (a, b), (b, hi)) if y > x]
    if len(parts) < 2:
        return None
    whole = (s[hi] - s[lo]) / slowest
    cut = sum((s[y] - s[x]) / np.min(cap[x : y + 1]) for x, y in parts)
    if not cut <= KEEP_SHARE * whole:
        return None
    return parts, float(whole - cut)


def _widened(s: np.ndarray, a: int, b: int, lo: int, hi: int) -> tuple[int, int]:
    """The part ``a`` .. ``b`` widened within ``lo`` .. ``hi`` to at least
    :data:`MIN_PART_MM`, and its ends moved onto ``lo`` / ``hi`` where they would leave a
    part shorter than that there."""
    while s[b] - s[a] < MIN_PART_MM and (a > lo or b < hi):
        a, b = max(lo, a - 1), min(hi, b + 1)
    if s[a] - s[lo] < MIN_PART_MM:
        a = lo
    if s[hi] - s[b] < MIN_PART_MM:
        b = hi
    return a, b


def _pieces(move: Spline, cuts: list[float]) -> list[Spline]:
    """``move`` cut at the parameters ``cuts`` (increasing, inside its range), each part a
    :class:`Spline` with its own control points, weights and knots (homogeneous knot
    insertion); the outer ends are the move's own, each inner end the point both parts share."""
    w = np.asarray(move.weights, dtype=float)
    rest = (
        np.column_stack([np.asarray(move.control_points, dtype=float) * w[:, None], w]),
        np.asarray(move.knots, dtype=float),
    )
    homogeneous = []
    for u in cuts:
        first, rest = split_bspline(*rest, move.degree, u)
        homogeneous.append(first)
    homogeneous.append(rest)
    out: list[Spline] = []
    start = move.start
    for k, (q, knots) in enumerate(homogeneous):
        ctrl = [(float(x), float(y), float(z)) for x, y, z in (q[:, :3] / q[:, 3:4]).tolist()]
        last = k == len(homogeneous) - 1
        ctrl[0] = start
        end = move.end if last else ctrl[-1]
        ctrl[-1] = end
        out.append(
            dataclasses.replace(
                move,
                start=start,
                end=end,
                control_points=tuple(ctrl),
                weights=tuple(float(x) for x in q[:, 3]),
                knots=tuple(float(x) for x in knots),
            )
        )
        start = end
    return out
