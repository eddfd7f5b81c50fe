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
from dataclasses import dataclass

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
        return max(v0 + x, v0)  # never below the start, even where rounding would put it
    b = acc * acc / jerk
    c = v0 * b - v0 * v0 - 2.0 * acc * L
    return max(0.5 * (-b + math.sqrt(b * b - 4.0 * c)), v0)


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
    ends = np.arange(len(blocks) + 1)
    return np.array(junction_speeds_again(blocks, junction_caps, ends, memo).speeds)


#: The share of a block's length the passes use (a hair is kept in reserve).
SHRINK = 1.0 - 1e-9


@dataclass(frozen=True)
class Passes:
    """One look-ahead (:func:`junction_speeds_again`), kept for the next: the junction each
    block starts at (and the last one's end), the blocks, and per junction its cap after the
    blocks' own caps, its speed after the backward pass and after both (the result) [mm/s]."""

    ends: np.ndarray
    blocks: list[BlockLimits]
    caps: np.ndarray
    backward: list[float]
    speeds: list[float]


def junction_speeds_again(
    blocks: list[BlockLimits],
    junction_caps: np.ndarray,
    ends: np.ndarray,
    memo: dict | None = None,
    before: Passes | None = None,
) -> Passes:
    """:func:`plan_junction_speeds` of ``blocks`` under ``junction_caps`` [mm/s], the same
    numbers, computing again only what can differ from ``before`` (the look-ahead of the round
    before). ``ends``: (len(blocks) + 1,) the junction (an index that names it in both rounds:
    the planner's move index) each block starts at, and where the last one ends.

    A planning round lowers a few junctions' caps and splits a few chains; the passes'
    recurrences are v_bw[k] = min(cap[k], reach(v_bw[k + 1], block k)) and v[k + 1] =
    min(v_bw[k + 1], reach(v[k], block k)). A value whose inputs (its cap, its block, the
    value it follows from) are those of ``before`` at the same junction is ``before``'s: so
    each pass computes only from where an input changed until the values it gives are the old
    ones again, and skips to the next change."""
    n = len(blocks)
    tops = np.array([b.cap_mm_per_s for b in blocks], dtype=float)
    caps = np.array(junction_caps, dtype=float)
    caps[:n] = np.minimum(caps[:n], tops)
    caps[1:] = np.minimum(caps[1:], tops)
    lengths = [b.length_mm * SHRINK for b in blocks]
    accs = [b.acc_mm_per_s2 for b in blocks]
    jerks = [b.jerk_mm_per_s3 for b in blocks]
    memo = {} if memo is None else memo

    def reach(v: float, k: int) -> float:
        key = (v, lengths[k], accs[k], jerks[k])
        got = memo.get(key)
        if got is None:
            got = memo[key] = max_reachable_speed(*key)
        return got

    old_caps, old_bw, old_v, same = _before_at(ends, blocks, before)
    at = caps.tolist()  # Python floats: the same numbers, without NumPy scalars per block
    # backward, from the last junction down: v_bw[k] needs computing where its cap or block k
    # changed (the last junction has no block), or v_bw[k + 1] did
    bw = list(old_bw)
    anew = np.flatnonzero(~(caps == old_caps) | np.append(~same, False))[::-1].tolist()
    k, i, follows = n, 0, False
    while k >= 0:
        if not follows:  # skip to the next junction whose own inputs changed
            while i < len(anew) and anew[i] > k:
                i += 1
            if i == len(anew):
                break
            k = anew[i]
        # reach(v) >= v: a cap at or below the speed after needs no reach
        bw[k] = at[k] if k == n or at[k] <= bw[k + 1] else min(at[k], reach(bw[k + 1], k))
        follows = not bw[k] == old_bw[k]
        k -= 1
    # forward, from the first junction up: v[k + 1] needs computing where block k or
    # v_bw[k + 1] changed, or v[k] did
    v = list(old_v)
    v[0] = bw[0]
    moved = ~(np.array(bw) == np.array(old_bw))
    anew = np.flatnonzero(moved[1:] | ~same).tolist()
    k, i, follows = 0, 0, not v[0] == old_v[0]
    while k < n:
        if not follows:
            while i < len(anew) and anew[i] < k:
                i += 1
            if i == len(anew):
                break
            k = anew[i]
        v[k + 1] = bw[k + 1] if bw[k + 1] <= v[k] else min(bw[k + 1], reach(v[k], k))
        follows = not v[k + 1] == old_v[k + 1]
        k += 1
    return Passes(np.asarray(ends), blocks, caps, bw, v)


def _before_at(
    ends: np.ndarray, blocks: list[BlockLimits], before: Passes | None
) -> tuple[np.ndarray, list[float], list[float], np.ndarray]:
    """``before``'s caps, backward speeds and speeds at the junctions ``ends`` (NaN where
    it had no such junction, or no ``before``), and per block whether ``before`` had it:
    the same limits (the same object) between the same two junctions."""
    count = len(ends)
    if before is None or not len(before.ends):
        nan = np.full(count, np.nan)
        return nan, nan.tolist(), nan.tolist(), np.zeros(count - 1, dtype=bool)
    top = int(max(before.ends[-1], ends[-1] if count else 0)) + 1
    where = np.full(top, -1)
    where[before.ends] = np.arange(len(before.ends))
    j = where[ends]
    had = j >= 0
    jj = np.where(had, j, 0)
    caps = np.where(had, before.caps[jj], np.nan)
    bw = np.where(had, np.array(before.backward)[jj], np.nan).tolist()
    v = np.where(had, np.array(before.speeds)[jj], np.nan).tolist()
    same = had[:-1] & had[1:] & (j[1:] == j[:-1] + 1)
    old, at = before.blocks, j.tolist()
    for k in np.flatnonzero(same).tolist():
        same[k] = old[at[k]] is blocks[k]
    return caps, bw, v, same
