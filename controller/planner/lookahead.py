"""Look-ahead: junction speed caps, and the backward/forward passes that set the junction speeds.

Every move is one *block* of the 1-D speed profile along the path, with its own limits
(:class:`gantry_sim.controller.planner.limits.BlockLimits`); each block starts and ends with
a_t = 0, at the junction speeds found here.

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
and ending with zero acceleration (:func:`max_reachable_speed`; its time:
:func:`gantry_sim.controller.planner.limits.s_curve_time`).
"""

from __future__ import annotations

import math

import numpy as np

from gantry_sim.controller.planner.limits import BlockLimits

#: Tangent-direction change above which a junction involving an arc is a corner [rad] (1 degree).
CORNER_ANGLE_RAD = math.radians(1.0)
#: The smoothing of a junction's jump must take at most 1/CHORD_FIT of the adjacent chord's time
#: (a first guess; the planner then checks the pieces themselves).
CHORD_FIT = 4.0
#: Two straight moves are followed exactly: they keep speed only when collinear within this [rad].
COLLINEAR_ANGLE_RAD = 1e-6


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
