"""What each move may do: the limits of its 1-D profile and what bounds following it exactly.

Every move is one *block* of the 1-D speed profile along the path: arc length s [mm], path speed
v [mm/s], tangential acceleration a_t [mm/s^2] and jerk j_t [mm/s^3]. A block has its own limits
(:class:`BlockLimits`) chosen so that following the geometry exactly never exceeds any axis'
limits; each block starts and ends with a_t = 0.

Ideal motion along a curve p(s) with unit tangent T and curvature vector k = p'' (|k| = 1/R):
    velocity  v T
    accel     a_t T + v^2 k
    jerk      j_t T + 3 v a_t k + v^3 p'''
so per axis |a_i| <= sqrt(a_t^2 + (v^2/R)^2) (T is orthogonal to k) and, since p''' has no
component along k (circle: -T/R^2; a helix adds the binormal),
|j_i| <= sqrt((|j_t| + v^3 |p'''|)^2 + (3 v a_t / R)^2).

Straight moves give each axis |T_i| of the path (:func:`straight_limits`); arcs and helices are
bounded through their :class:`FollowGeometry` (:func:`arc_limits`, :func:`curvature_speed_cap`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.units import mm_per_min_to_mm_per_s

#: Fractions of the curvature speed caps tried, and shares of the jerk left by the centripetal
#: term given to the tangential acceleration's 3 v a_t / R term (see :func:`arc_limits`).
CURVATURE_MARGINS = (0.99, 0.97, 0.94, 0.9, 0.85, 0.8, 0.7, 0.6, 0.5)
JERK_SHARES = (0.2, 0.35, 0.5, 0.65, 0.8)
#: Arcs per batch of :func:`arc_limits_many`: each arc's table is 45 numbers in some thirty
#: temporary arrays (about 10 KB an arc), which for a whole 100,000-block program made a
#: transient of half a gigabyte, the planner's largest; at 4,096 the temporaries stay near
#: 40 MB, and a batch is still long enough for numpy's per-call cost not to count.
BATCH_ARCS = 4096


@dataclass(frozen=True, slots=True)
class BlockLimits:
    """Limits of the 1-D profile along one move.

    Attributes:
        length_mm: path length [mm].
        cap_mm_per_s: path-speed cap [mm/s] (feed, axis velocities, curvature).
        acc_mm_per_s2: tangential acceleration limit [mm/s^2].
        jerk_mm_per_s3: tangential jerk limit [mm/s^3].
    """

    length_mm: float
    cap_mm_per_s: float
    acc_mm_per_s2: float
    jerk_mm_per_s3: float


def braking_mm(v: float, a: float, j: float) -> float:
    """Distance [mm] to come to rest from ``v`` [mm/s] with acceleration ``a`` [mm/s^2] and
    jerk ``j`` [mm/s^3]: an upper bound, v^2 / 2a + v a / j (the jerk-limited stop takes
    v^2 / 2a + v a / 2j, or v sqrt(v / j) when v < a^2 / j; inf for a speed that is not
    finite)."""
    return v * v / (2.0 * a) + v * a / j if math.isfinite(v) else math.inf


#: the highest path feed planned [mm/s]: a feed above it (``F`` of 160 digits, or a feed
#: override of 1e308 %) is this one. No axis reaches it, so it changes no plan, and its
#: square stays a finite number (the feed checks square it).
MAX_PATH_FEED_MM_PER_S = 1e9


def path_feed_mm_per_s(feed_mm_per_min: float, feed_scale: float) -> float:
    """A feed move's path-speed cap [mm/s]: its programmed feed [mm/min] times the feed
    override ``feed_scale`` (1: 100 %), at most :data:`MAX_PATH_FEED_MM_PER_S`."""
    return min(mm_per_min_to_mm_per_s(feed_mm_per_min) * feed_scale, MAX_PATH_FEED_MM_PER_S)


def straight_limits(
    direction: np.ndarray, length_mm: float, feed_mm_per_s: float, limits: Limits
) -> BlockLimits:
    """Limits along a straight move of unit ``direction`` (each axis gets |T_i| of the path)."""
    vmax, amax, jmax = limits.per_axis()
    t = [abs(x) for x in direction.tolist()]  # in floats: 4 x faster than numpy on 3 numbers
    v = min(m / ti if ti else math.inf for m, ti in zip(vmax, t, strict=True))
    a = min(m / ti if ti else math.inf for m, ti in zip(amax, t, strict=True))
    j = min(m / ti if ti else math.inf for m, ti in zip(jmax, t, strict=True))
    return BlockLimits(length_mm, min(feed_mm_per_s, v), a, j)


def arc_limits(
    follow: FollowGeometry,
    length_mm: float,
    limits: Limits,
    ends_mm_per_s: tuple[float, float] = (0.0, 0.0),
) -> BlockLimits:
    """Limits along an arc/helix (conservative, see the module docstring).

    Args:
        follow: the arc's curvature, its derivative, pitch and feed cap.
        length_mm: path length [mm].
        limits: the machine's per-axis limits.
        ends_mm_per_s: the highest speeds the arc may start and end with [mm/s] (its junction
            caps; 0: at rest).

    The speed cap uses a fraction (:data:`CURVATURE_MARGINS`) of the curvature caps v^2/R <= a
    and v^3/R^2 <= j, and what the centripetal terms leave of the acceleration and jerk is split
    between a_t and j_t (:data:`JERK_SHARES`): the pair is chosen that minimises L/cap plus the
    time lost ramping between the end speeds and the cap (cruise fast on long arcs and inside
    tangent chains, keep ramps short on short arcs between stops). One arc of
    :func:`arc_limits_many`.
    """
    return arc_limits_many([follow], [length_mm], limits, [ends_mm_per_s])[0]


def arc_limits_many(
    follows: Sequence[FollowGeometry],
    lengths_mm: Sequence[float],
    limits: Limits,
    ends_mm_per_s: Sequence[tuple[float, float]] | None = None,
    even: bool = False,
) -> list[BlockLimits]:
    """``[arc_limits(f, length, limits, ends) ...]`` for each arc (``ends``: (0, 0) when
    ``ends_mm_per_s`` is None), computed in arrays :data:`BATCH_ARCS` arcs at a time: every
    (margin, share) pair of every arc at once, a few numpy calls for the batch instead of
    about forty per arc. ``even``: the choice for G2 transitions instead (the cruise cap and
    the most even shares, :func:`_arc_batch`)."""
    n = len(follows)
    ends = [(0.0, 0.0)] * n if ends_mm_per_s is None else list(ends_mm_per_s)
    out: list[BlockLimits] = []
    for k in range(0, n, BATCH_ARCS):
        stop = min(n, k + BATCH_ARCS)
        out += _arc_batch(
            list(follows[k:stop]), list(lengths_mm[k:stop]), limits, ends[k:stop], even
        )
    return out


def _arc_batch(
    follows: list[FollowGeometry],
    lengths_mm: list[float],
    limits: Limits,
    ends: list[tuple[float, float]],
    even: bool = False,
) -> list[BlockLimits]:
    """One batch of :func:`arc_limits_many` (all margins and shares tried; an arc without
    curvature has no curvature cap, and its tangential acceleration is the plane's). ``even``:
    of the first margin's pairs (the highest cap), the share whose tangential acceleration
    and jerk are the most even shares of the plane's (the largest of their smaller share), not
    the cheapest: a G2 transition's junctions never bind, so it always cruises inside a chain,
    whose ramps run on the lowest limits of its moves; the cheapest pair of a cruise, the
    least tangential acceleration, made a chain of arcs ramp at a fifth of their own."""
    vmax, amax, jmax = limits.per_axis()
    a_pl, j_pl, cap, sin_p, amax_n, jmax_n, k_n = [], [], [], [], [], [], []
    for f in follows:
        i1, i2, nrm = f.plane_axes
        a_pl.append(min(amax[i1], amax[i2]))
        j_pl.append(min(jmax[i1], jmax[i2]))
        cap.append(f.speed_cap(vmax))
        sin_p.append(f.sin_pitch)
        amax_n.append(amax[nrm])
        jmax_n.append(jmax[nrm])
        k_n.append(f.normal_curvature_per_mm if f.sin_pitch > 0 else 0.0)

    def col(values: list[float]) -> np.ndarray:
        return np.array(values, dtype=float)[:, None, None]

    a_p, j_p, k = col(a_pl), col(j_pl), col([f.curvature_per_mm for f in follows])
    dk = col([f.dcurv_per_mm2 for f in follows])
    margins = np.array(CURVATURE_MARGINS)[None, :, None]
    shares = np.array(JERK_SHARES)[None, None, :]
    cap_m = np.broadcast_to(col(cap), (len(follows), margins.size, 1))
    # a straight "arc" (k 0): no cap from k, and a_t is the plane's whatever the share (every
    # pair then costs the same, and the first wins)
    with np.errstate(divide="ignore", invalid="ignore"):
        cap_m = np.where(k > 0, np.minimum(cap_m, np.sqrt(margins * a_p / k)), cap_m)
        by_jerk = (margins * j_p / dk) ** (1.0 / 3.0)
    cap_m = np.where(dk > 0, np.minimum(cap_m, by_jerk), cap_m)
    kn = col(k_n)  # a helical spiral's normal curvature: v^2 kn of the normal axis' acceleration
    with np.errstate(divide="ignore", over="ignore"):  # kn 0 or ~1e-310: no cap from it
        cap_m = np.where(kn > 0, np.minimum(cap_m, np.sqrt(margins * col(amax_n) / kn)), cap_m)
    a_max = np.sqrt(np.maximum(a_p * a_p - (cap_m * cap_m * k) ** 2, 0.0))
    j_left = j_p - cap_m**3 * dk
    with np.errstate(divide="ignore", invalid="ignore"):
        a_t = np.where(k > 0, np.minimum(a_max, shares * j_left / (3.0 * cap_m * k)), a_max)
    j_t = np.sqrt(np.maximum(j_p * j_p - (3.0 * cap_m * a_t * k) ** 2, 0.0)) - cap_m**3 * dk
    sp = col(sin_p)
    pitched = sp > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # sp ~ 1e-310: inf
        a_t = np.where(pitched, np.minimum(a_t, (col(amax_n) - cap_m * cap_m * kn) / sp), a_t)
        j_t = np.where(pitched, np.minimum(j_t, col(jmax_n) / sp), j_t)
    ok = (a_t > 0) & (j_t > 0)
    # margin < 1 leaves acceleration and jerk to the tangential terms: some pair always fits
    assert ok.any(axis=(1, 2)).all(), "arc_limits found no (cap, a_t, j_t): limits must be > 0"
    a_s, j_s = np.where(ok, a_t, 1.0), np.where(ok, j_t, 1.0)
    cost = col(lengths_mm) / cap_m
    for side in (0, 1):  # a ramp from v to the cap loses (cap - v) / (2 cap) of its time
        dv = np.maximum(cap_m - col([e[side] for e in ends]), 0.0)
        ramp = np.where(dv * j_s >= a_s * a_s, dv / a_s + a_s / j_s, 2.0 * np.sqrt(dv / j_s))
        cost = cost + ramp * dv / (2.0 * cap_m)
    cost = np.where(ok, cost, np.inf)
    best = cost.reshape(len(follows), -1).argmin(axis=1)  # the first pair of least cost
    m, sh = np.unravel_index(best, cost.shape[1:])
    if even:
        even_share = np.minimum(a_t[:, 0, :] / a_p[:, 0, :], j_t[:, 0, :] / j_p[:, 0, :])
        sh = np.where(ok[:, 0, :], even_share, -np.inf).argmax(axis=1)
        m = np.zeros_like(sh)
    rows = np.arange(len(follows))
    caps = cap_m[rows, m, 0].tolist()
    a_best, j_best = a_t[rows, m, sh].tolist(), j_t[rows, m, sh].tolist()
    return [
        BlockLimits(length, c, a, j)
        for length, c, a, j in zip(lengths_mm, caps, a_best, j_best, strict=True)
    ]


@dataclass(frozen=True, slots=True)
class FollowGeometry:
    """What bounds the exact following of an arc/helix (the bounds in this module's docstring).

    Attributes:
        plane_axes: (first, second, normal) axis indices of the arc's plane.
        sin_pitch: |T_n|, the tangent's normal-axis component (0 for a plain arc).
        curvature_per_mm: largest |p''| = 1/R [1/mm].
        dcurv_per_mm2: largest |p'''| [1/mm^2].
        feed_cap_mm_per_s: the feed (after override, less the closed-form pieces' margin) [mm/s].
        normal_curvature_per_mm: largest |p''_n|, the curvature vector's normal-axis component
            [1/mm]: 0 on a helix, whose pitch is constant; on a helical spiral (an end radius
            off the start's, as CAM posts round them) the pitch changes with the radius, and
            the normal axis takes v^2 |p''_n| of acceleration besides a_t |T_n|.
        plane_share_max: largest in-plane share of the tangent, sqrt(1 - T_n^2) where the pitch
            is least (a helical spiral's larger radius end), or None: sqrt(1 - sin_pitch^2), a
            helix' (:attr:`plane_share`).
    """

    plane_axes: tuple[int, int, int]
    sin_pitch: float
    curvature_per_mm: float
    dcurv_per_mm2: float
    feed_cap_mm_per_s: float
    normal_curvature_per_mm: float = 0.0
    plane_share_max: float | None = None

    @property
    def plane_share(self) -> float:
        """The largest in-plane share of the tangent: the plane axes' speeds are at most
        v times this."""
        if self.plane_share_max is not None:
            return self.plane_share_max
        return math.sqrt(max(0.0, 1.0 - self.sin_pitch * self.sin_pitch))

    def speed_cap(self, vmax) -> float:
        """Path-speed cap from the feed and the axis velocities alone [mm/s]."""
        i1, i2, n = self.plane_axes
        sp = self.sin_pitch
        cap = min(self.feed_cap_mm_per_s, min(vmax[i1], vmax[i2]) / max(self.plane_share, 1e-12))
        return min(cap, vmax[n] / sp) if sp > 0 else cap


def curvature_speed_cap(
    cap: float,
    curvature_per_mm: float,
    dcurv_per_mm2: float,
    a_plane: float,
    j_plane: float,
    margin: float,
) -> float:
    """``cap`` [mm/s] lowered so that following the curve at that speed uses at most ``margin``
    of the plane's acceleration (v^2 k <= margin a) and jerk (v^3 dk <= margin j)."""
    if curvature_per_mm > 0:
        cap = min(cap, math.sqrt(margin * a_plane / curvature_per_mm))
    if dcurv_per_mm2 > 0:
        cap = min(cap, (margin * j_plane / dcurv_per_mm2) ** (1.0 / 3.0))
    return cap


def s_curve_time(dv: float, acc: float, jerk: float) -> float:
    """Time [s] of the fastest speed change by ``dv`` [mm/s] from and to zero acceleration."""
    dv = abs(dv)
    if dv * jerk >= acc * acc:
        return dv / acc + acc / jerk
    return 2.0 * math.sqrt(dv / jerk)
