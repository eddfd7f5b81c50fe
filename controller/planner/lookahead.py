"""Look-ahead: path-speed caps per move, junction speeds, and the backward/forward passes.

Every move is one *block* of the 1-D speed profile along the path: arc length s [mm], path speed
v [mm/s], tangential acceleration a_t [mm/s^2] and jerk j_t [mm/s^3]. A block has its own limits
(:class:`BlockLimits`) chosen so that following the geometry exactly never exceeds any axis'
limits; each block starts and ends with a_t = 0, at the junction speeds found here.

Ideal motion along a curve p(s) with unit tangent T and curvature vector k = p'' (|k| = 1/R):
    velocity  v T
    accel     a_t T + v^2 k
    jerk      j_t T + 3 v a_t k + v^3 p'''
so per axis |a_i| <= sqrt(a_t^2 + (v^2/R)^2) (T is orthogonal to k) and, since p''' has no
component along k (circle: -T/R^2; a helix adds the binormal),
|j_i| <= sqrt((|j_t| + v^3 |p'''|)^2 + (3 v a_t / R)^2).

Junctions (between consecutive feed moves):
* a corner (tangent direction turns by more than :data:`CORNER_ANGLE_RAD`, or by more than
  :data:`COLLINEAR_ANGLE_RAD` between two straight moves, which are followed exactly) is an exact
  stop, as is every rapid's start and end and the program's end;
* a tangent junction keeps its speed, except that a jump of the velocity direction (a kink of
  angle d: velocity jump v d) or of the curvature (acceleration jump v^2 |k1 - k2|, e.g. line ->
  arc, arc -> arc of another radius) cannot be followed exactly with finite jerk: Ruckig smooths
  it within the neighbouring chord, and the junction speed is capped so that the smoothing stays
  within a deviation budget e [mm] (see :func:`junction_cap`).

Passes: v_out[b] <= reach(v_in[b]) forward and v_in[b] <= reach(v_out[b]) backward, with
``reach`` the highest speed reachable over the block's length by a jerk-limited S-curve starting
and ending with zero acceleration (:func:`max_reachable_speed`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Re-exported: the boosted-profile checks lived here (controller.boost owns them now).
from gantry_sim.controller.planner.speedup import FOLLOW_MARGIN as FOLLOW_MARGIN
from gantry_sim.controller.planner.speedup import FollowGeometry as FollowGeometry
from gantry_sim.controller.planner.speedup import boost_candidates as boost_candidates
from gantry_sim.controller.planner.speedup import curvature_speed_cap
from gantry_sim.controller.planner.speedup import follow_ok as follow_ok

#: Tangent-direction change above which a junction involving an arc is a corner [rad] (1 degree).
CORNER_ANGLE_RAD = math.radians(1.0)
#: Fractions of the curvature speed caps tried, and shares of the jerk left by the centripetal
#: term given to the tangential acceleration's 3 v a_t / R term (see :func:`arc_limits`).
CURVATURE_MARGINS = (0.99, 0.97, 0.94, 0.9, 0.85, 0.8, 0.7, 0.6, 0.5)
JERK_SHARES = (0.2, 0.35, 0.5, 0.65, 0.8)
#: The smoothing of a junction's jump must take at most 1/CHORD_FIT of the adjacent chord's time
#: (a first guess; the planner then checks the pieces themselves).
CHORD_FIT = 4.0
#: Two straight moves are followed exactly: they keep speed only when collinear within this [rad].
COLLINEAR_ANGLE_RAD = 1e-6


@dataclass(frozen=True)
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
    direction: np.ndarray, length_mm: float, feed_mm_per_s: float, vmax, amax, jmax
) -> BlockLimits:
    """Limits along a straight move of unit ``direction`` (each axis gets |T_i| of the path)."""
    t = np.abs(direction)
    with np.errstate(divide="ignore"):
        v = float(np.min(np.asarray(vmax) / t))
        a = float(np.min(np.asarray(amax) / t))
        j = float(np.min(np.asarray(jmax) / t))
    return BlockLimits(length_mm, min(feed_mm_per_s, v), a, j)


def arc_limits(
    plane_axes: tuple[int, int, int],
    length_mm: float,
    sin_pitch: float,
    curvature_per_mm: float,
    dcurv_per_mm2: float,
    feed_mm_per_s: float,
    vmax,
    amax,
    jmax,
    ends_mm_per_s: tuple[float, float] = (0.0, 0.0),
) -> BlockLimits:
    """Limits along an arc/helix (conservative, see the module docstring).

    Args:
        plane_axes: (first, second, normal) axis indices of the arc's plane.
        length_mm: path length [mm].
        sin_pitch: |T_n|, the tangent's normal-axis component (0 for a plain arc).
        curvature_per_mm: largest |p''| = 1/R along the arc [1/mm].
        dcurv_per_mm2: largest |p'''| along the arc [1/mm^2] (1/R^2 for a circle).
        feed_mm_per_s: programmed feed (after override) [mm/s].
        vmax, amax, jmax: per-axis limits [mm/s], [mm/s^2], [mm/s^3].
        ends_mm_per_s: the highest speeds the arc may start and end with [mm/s] (its junction
            caps; 0: at rest).

    The speed cap uses a fraction (:data:`CURVATURE_MARGINS`) of the curvature caps v^2/R <= a
    and v^3/R^2 <= j, and what the centripetal terms leave of the acceleration and jerk is split
    between a_t and j_t (:data:`JERK_SHARES`): the pair is chosen that minimises L/cap plus the
    time lost ramping between the end speeds and the cap (cruise fast on long arcs and inside
    tangent chains, keep ramps short on short arcs between stops).
    """
    i1, i2, n = plane_axes
    cos_pitch = math.sqrt(max(0.0, 1.0 - sin_pitch * sin_pitch))
    a_pl = min(amax[i1], amax[i2])
    j_pl = min(jmax[i1], jmax[i2])
    cap = min(feed_mm_per_s, min(vmax[i1], vmax[i2]) / max(cos_pitch, 1e-12))
    if sin_pitch > 0:
        cap = min(cap, vmax[n] / sin_pitch)
    k, dk = curvature_per_mm, dcurv_per_mm2
    best = None
    for margin in CURVATURE_MARGINS:
        cap_m = curvature_speed_cap(cap, k, dk, a_pl, j_pl, margin)
        a_max = math.sqrt(max(a_pl * a_pl - (cap_m * cap_m * k) ** 2, 0.0))
        j_left = j_pl - cap_m**3 * dk
        for share in JERK_SHARES:
            a_t = min(a_max, share * j_left / (3.0 * cap_m * k)) if k > 0 else a_max
            j_t = math.sqrt(max(j_pl * j_pl - (3.0 * cap_m * a_t * k) ** 2, 0.0)) - cap_m**3 * dk
            if sin_pitch > 0:
                a_t = min(a_t, amax[n] / sin_pitch)
                j_t = min(j_t, jmax[n] / sin_pitch)
            if a_t <= 0 or j_t <= 0:
                continue
            cost = length_mm / cap_m
            for v_end in ends_mm_per_s:  # a ramp from v to the cap loses (cap - v) / (2 cap)
                dv = max(cap_m - v_end, 0.0)
                cost += s_curve_time(dv, a_t, j_t) * dv / (2.0 * cap_m)
            if best is None or cost < best[0]:
                best = (cost, cap_m, a_t, j_t)
            if k == 0:
                break
        if k == 0 and dk == 0:
            break
    _, cap, a_t, j_t = best
    return BlockLimits(length_mm, cap, a_t, j_t)


def junction_cap(
    kink_rad: float,
    curvature_jump_per_mm: float,
    deviation_mm: float,
    jerk_mm_per_s3: float,
    chord_mm: float,
) -> float:
    """Highest speed [mm/s] through a tangent junction so that the jerk-limited smoothing of its
    velocity and acceleration jumps stays within ``deviation_mm`` and fits in the adjacent chord.

    A velocity jump dv, smoothed with jerk J, takes 2 sqrt(dv/J) and deviates by about
    dv^1.5 / (2 sqrt J): dv <= (2 e sqrt J)^(2/3). An acceleration jump da takes da/J and deviates
    by about da^3 / (6 J^2): da <= (6 e J^2)^(1/3). With dv = v * kink and da = v^2 * |k1 - k2|.
    The smoothing must also be done well within the chord's time T = chord / v, since the piece
    ends on the arc's exact state: da / J <= T / CHORD_FIT and 2 sqrt(dv / J) <= T / CHORD_FIT.
    The planner checks the pieces next to every moving junction and lowers the cap further where
    needed.
    """
    cap = math.inf
    j, e = jerk_mm_per_s3, deviation_mm
    if kink_rad > 0:
        cap = min(
            (2.0 * e * math.sqrt(j)) ** (2.0 / 3.0) / kink_rad,
            (j * chord_mm**2 / (4.0 * CHORD_FIT**2 * kink_rad)) ** (1.0 / 3.0),
        )
    if curvature_jump_per_mm > 0:
        da = (6.0 * e * j**2) ** (1.0 / 3.0)
        cap = min(
            cap,
            math.sqrt(da / curvature_jump_per_mm),
            (j * chord_mm / (CHORD_FIT * curvature_jump_per_mm)) ** (1.0 / 3.0),
        )
    return cap


def s_curve_time(dv: float, acc: float, jerk: float) -> float:
    """Time [s] of the fastest speed change by ``dv`` [mm/s] from and to zero acceleration."""
    dv = abs(dv)
    if dv * jerk >= acc * acc:
        return dv / acc + acc / jerk
    return 2.0 * math.sqrt(dv / jerk)


def max_reachable_speed(v_from: float, length_mm: float, acc: float, jerk: float) -> float:
    """Highest speed [mm/s] reachable from ``v_from`` (or from which ``v_from`` is reachable)
    over ``length_mm`` by an S-curve with zero acceleration at both ends.

    The S-curve's distance is (v0 + v1)/2 * s_curve_time(v1 - v0) (it is point-symmetric). With
    x = v1 - v0: for x >= a^2/j, x/a + a/j time, a quadratic in v1; below, (2 v0 + x) sqrt(x/j) = L,
    the cubic x^3 + 4 v0 x^2 + 4 v0^2 x - L^2 j = 0, solved by Newton from above (convex).
    """
    if length_mm <= 0:
        return v_from
    v0, L = v_from, length_mm
    x = (L * L * jerk) ** (1.0 / 3.0)  # the root for v0 = 0: an upper bound
    for _ in range(200):
        f = x * (x + 2.0 * v0) ** 2 - L * L * jerk
        df = (x + 2.0 * v0) * (3.0 * x + 2.0 * v0)
        step = f / df
        x -= step
        if abs(step) <= 1e-15 * x or x <= 0.0:
            break
    if x * jerk < acc * acc:
        return v0 + x
    b = acc * acc / jerk
    c = v0 * b - v0 * v0 - 2.0 * acc * L
    return 0.5 * (-b + math.sqrt(b * b - 4.0 * c))


def plan_junction_speeds(blocks: list[BlockLimits], junction_caps: np.ndarray) -> np.ndarray:
    """Junction speeds [mm/s] of a chain of blocks (backward then forward pass).

    Args:
        blocks: the chain's blocks in order.
        junction_caps: (len(blocks) + 1,) speed caps at the junctions [mm/s]; 0 is a stop. The
            first and last entries are normally 0 (the chain starts and ends at rest).

    Returns:
        (len(blocks) + 1,) speeds: v[b] entering block b, v[b + 1] leaving it. Every block can
        reach v[b + 1] from v[b] within its length (a hair of length is kept in reserve).
    """
    n = len(blocks)
    v = np.array(junction_caps, dtype=float)
    for b in range(n):
        cap = blocks[b].cap_mm_per_s
        v[b] = min(v[b], cap)
        v[b + 1] = min(v[b + 1], cap)
    shrink = 1.0 - 1e-9
    for b in range(n - 1, -1, -1):
        blk = blocks[b]
        reach = max_reachable_speed(
            v[b + 1], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3
        )
        v[b] = min(v[b], reach)
    for b in range(n):
        blk = blocks[b]
        reach = max_reachable_speed(
            v[b], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3
        )
        v[b + 1] = min(v[b + 1], reach)
    return v
