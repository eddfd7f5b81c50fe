"""Look-ahead: the backward and forward passes that set the junction speeds.

Every move is one *block* of the 1-D speed profile along the path, with its own limits
(:class:`gantry_sim.controller.planner.limits.BlockLimits`); each block starts and ends with
a_t = 0, at the junction speeds found here, below the junctions' caps
(:mod:`gantry_sim.controller.planner.junctions`: 0 at stops).

Passes: v_out[b] <= reach(v_in[b]) forward and v_in[b] <= reach(v_out[b]) backward, with
``reach`` the highest speed reachable over the block's length by a jerk-limited S-curve starting
and ending with zero acceleration (:func:`max_reachable_speed`; its time:
:func:`gantry_sim.controller.planner.limits.s_curve_time`).
"""

from __future__ import annotations

import math

import numpy as np

from gantry_sim.controller.planner.limits import BlockLimits


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


def plan_junction_speeds(
    blocks: list[BlockLimits], junction_caps: np.ndarray, memo: dict | None = None
) -> np.ndarray:
    """Junction speeds [mm/s] of a chain of blocks (backward then forward pass).

    Args:
        blocks: the chain's blocks in order.
        junction_caps: (len(blocks) + 1,) speed caps at the junctions [mm/s]; 0 is a stop. The
            first and last entries are normally 0 (the chain starts and ends at rest).
        memo: :func:`max_reachable_speed` by its arguments, filled here: the planner's rounds
            pass the same blocks again with a few speeds changed, and reuse the rest.

    Returns:
        (len(blocks) + 1,) speeds: v[b] entering block b, v[b + 1] leaving it. Every block can
        reach v[b + 1] from v[b] within its length (a hair of length is kept in reserve).
    """
    n = len(blocks)
    # Python floats: the same numbers, without NumPy scalars per block
    speeds = np.array(junction_caps, dtype=float).tolist()
    for b in range(n):
        cap = blocks[b].cap_mm_per_s
        speeds[b] = min(speeds[b], cap)
        speeds[b + 1] = min(speeds[b + 1], cap)
    shrink = 1.0 - 1e-9
    memo = {} if memo is None else memo
    for b in range(n - 1, -1, -1):
        blk = blocks[b]
        key = (speeds[b + 1], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3)
        reach = memo.get(key)
        if reach is None:
            reach = memo[key] = max_reachable_speed(*key)
        speeds[b] = min(speeds[b], reach)
    for b in range(n):
        blk = blocks[b]
        key = (speeds[b], blk.length_mm * shrink, blk.acc_mm_per_s2, blk.jerk_mm_per_s3)
        reach = memo.get(key)
        if reach is None:
            reach = memo[key] = max_reachable_speed(*key)
        speeds[b + 1] = min(speeds[b + 1], reach)
    return np.array(speeds)
