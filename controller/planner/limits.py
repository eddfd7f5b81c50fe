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
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.config import Limits

#: Fractions of the curvature speed caps tried, and shares of the jerk left by the centripetal
#: term given to the tangential acceleration's 3 v a_t / R term (see :func:`arc_limits`).
CURVATURE_MARGINS = (0.99, 0.97, 0.94, 0.9, 0.85, 0.8, 0.7, 0.6, 0.5)
JERK_SHARES = (0.2, 0.35, 0.5, 0.65, 0.8)


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
    tangent chains, keep ramps short on short arcs between stops).
    """
    i1, i2, n = follow.plane_axes
    vmax, amax, jmax = limits.per_axis()
    sin_pitch, feed_mm_per_s = follow.sin_pitch, follow.feed_cap_mm_per_s
    a_pl = min(amax[i1], amax[i2])
    j_pl = min(jmax[i1], jmax[i2])
    cap = min(feed_mm_per_s, min(vmax[i1], vmax[i2]) / max(follow.plane_share, 1e-12))
    if sin_pitch > 0:
        cap = min(cap, vmax[n] / sin_pitch)
    k, dk = follow.curvature_per_mm, follow.dcurv_per_mm2
    kn = follow.normal_curvature_per_mm if sin_pitch > 0 else 0.0
    # Every (margin, share) pair at once, margins outer: the first pair of least cost wins.
    margins = np.array(CURVATURE_MARGINS[:1] if k == 0 and dk == 0 else CURVATURE_MARGINS)
    shares = np.array(JERK_SHARES[:1] if k == 0 else JERK_SHARES)
    cap_m = np.full(margins.shape, cap)
    if k > 0:
        cap_m = np.minimum(cap_m, np.sqrt(margins * a_pl / k))
    if dk > 0:
        cap_m = np.minimum(cap_m, (margins * j_pl / dk) ** (1.0 / 3.0))
    if kn > 0:
        with np.errstate(over="ignore"):  # kn ~1e-310: no cap from it
            cap_m = np.minimum(cap_m, np.sqrt(margins * amax[n] / kn))
    a_max = np.sqrt(np.maximum(a_pl * a_pl - (cap_m * cap_m * k) ** 2, 0.0))[:, None]
    j_left = (j_pl - cap_m**3 * dk)[:, None]
    cap_c = cap_m[:, None]
    if k > 0:
        a_t = np.minimum(a_max, shares[None, :] * j_left / (3.0 * cap_c * k))
    else:
        a_t = np.broadcast_to(a_max, (margins.size, shares.size))
    j_t = np.sqrt(np.maximum(j_pl * j_pl - (3.0 * cap_c * a_t * k) ** 2, 0.0)) - cap_c**3 * dk
    if sin_pitch > 0:
        a_t = np.minimum(a_t, (amax[n] - cap_c * cap_c * kn) / sin_pitch)
        j_t = np.minimum(j_t, jmax[n] / sin_pitch)
    ok = (a_t > 0) & (j_t > 0)
    # margin < 1 leaves acceleration and jerk to the tangential terms: some pair always fits
    assert ok.any(), "arc_limits found no (cap, a_t, j_t): limits must be > 0"
    a_s, j_s = np.where(ok, a_t, 1.0), np.where(ok, j_t, 1.0)
    cost = length_mm / cap_c
    for v_end in ends_mm_per_s:  # a ramp from v to the cap loses (cap - v) / (2 cap)
        dv = np.maximum(cap_c - v_end, 0.0)
        ramp = np.where(dv * j_s >= a_s * a_s, dv / a_s + a_s / j_s, 2.0 * np.sqrt(dv / j_s))
        cost = cost + ramp * dv / (2.0 * cap_c)
    cost = np.where(ok, cost, np.inf)
    m, sh = np.unravel_index(int(np.argmin(cost)), cost.shape)
    cap, a_t_best, j_t_best = float(cap_m[m]), float(a_t[m, sh]), float(j_t[m, sh])
    return BlockLimits(length_mm, cap, a_t_best, j_t_best)


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
