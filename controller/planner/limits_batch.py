""":func:`~gantry_sim.controller.planner.limits.arc_limits` for many arcs at once.

Each arc's numbers are computed with the same operations as :func:`arc_limits` does for it
alone, element by element (its (margin, share) table is one row of a batch), so the limits are
the same bit for bit; planning 100,000 arcs then costs a few numpy calls instead of about forty
per arc. Arcs without curvature (none in practice) go through :func:`arc_limits` itself.
The batch is taken :data:`BATCH_ARCS` arcs at a time: each arc's table is 45 numbers in some
thirty temporary arrays (about 10 KB an arc), which for a whole 100,000-block program made a
transient of half a gigabyte, the planner's largest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.config import Limits
from gantry_sim.controller.planner.limits import (
    CURVATURE_MARGINS,
    JERK_SHARES,
    BlockLimits,
    FollowGeometry,
    arc_limits,
)

#: Arcs per batch: the temporaries stay near 40 MB whatever the program's length, and a batch
#: is still long enough for numpy's per-call cost not to count.
BATCH_ARCS = 4096


def arc_limits_many(
    follows: Sequence[FollowGeometry],
    lengths_mm: Sequence[float],
    limits: Limits,
    ends_mm_per_s: Sequence[tuple[float, float]] | None = None,
    even: bool = False,
) -> list[BlockLimits]:
    """``[arc_limits(f, length, limits, ends) ...]`` for each arc (``ends``: (0, 0) when
    ``ends_mm_per_s`` is None); ``even``: the choice for G2 transitions instead
    (:func:`_curved`: the cruise cap and the most even shares; every transition is curved)."""
    n = len(follows)
    ends = [(0.0, 0.0)] * n if ends_mm_per_s is None else list(ends_mm_per_s)
    curved = [i for i, f in enumerate(follows) if f.curvature_per_mm > 0]
    out: list[BlockLimits | None] = [None] * n
    for i in sorted(set(range(n)) - set(curved)):
        out[i] = arc_limits(follows[i], lengths_mm[i], limits, ends[i])
    for k in range(0, len(curved), BATCH_ARCS):
        batch = curved[k : k + BATCH_ARCS]
        found = _curved(
            [follows[i] for i in batch],
            [lengths_mm[i] for i in batch],
            limits,
            [ends[i] for i in batch],
            even,
        )
        for i, b in zip(batch, found, strict=True):
            out[i] = b
    return [b for b in out if b is not None]


def _curved(
    follows: list[FollowGeometry],
    lengths_mm: list[float],
    limits: Limits,
    ends: list[tuple[float, float]],
    even: bool = False,
) -> list[BlockLimits]:
    """The batch of arcs with curvature > 0 (all margins and shares tried). ``even``: of the
    first margin's pairs (the highest cap), the share whose tangential acceleration and jerk
    are the most even shares of the plane's (the largest of their smaller share), not the
    cheapest: a G2 transition's junctions never bind, so it always cruises inside a chain,
    whose ramps run on the lowest limits of its moves; the cheapest pair of a cruise, the
    least tangential acceleration, made a chain of arcs ramp at a fifth of their own."""
    vmax, amax, jmax = limits.per_axis()
    a_pl, j_pl, cap, sin_p, amax_n, jmax_n, k_n = [], [], [], [], [], [], []
    for f in follows:
        i1, i2, nrm = f.plane_axes
        sin_pitch = f.sin_pitch
        c = min(f.feed_cap_mm_per_s, min(vmax[i1], vmax[i2]) / max(f.plane_share, 1e-12))
        if sin_pitch > 0:
            c = min(c, vmax[nrm] / sin_pitch)
        a_pl.append(min(amax[i1], amax[i2]))
        j_pl.append(min(jmax[i1], jmax[i2]))
        cap.append(c)
        sin_p.append(sin_pitch)
        amax_n.append(amax[nrm])
        jmax_n.append(jmax[nrm])
        k_n.append(f.normal_curvature_per_mm if sin_pitch > 0 else 0.0)

    def col(values: list[float]) -> np.ndarray:
        return np.array(values, dtype=float)[:, None, None]

    a_p, j_p, k = col(a_pl), col(j_pl), col([f.curvature_per_mm for f in follows])
    dk = col([f.dcurv_per_mm2 for f in follows])
    margins = np.array(CURVATURE_MARGINS)[None, :, None]
    shares = np.array(JERK_SHARES)[None, None, :]
    cap_m = np.broadcast_to(col(cap), (len(follows), margins.size, 1))
    cap_m = np.minimum(cap_m, np.sqrt(margins * a_p / k))
    with np.errstate(divide="ignore", invalid="ignore"):
        by_jerk = (margins * j_p / dk) ** (1.0 / 3.0)
    cap_m = np.where(dk > 0, np.minimum(cap_m, by_jerk), cap_m)
    kn = col(k_n)  # a helical spiral's normal curvature: v^2 kn of the normal axis' acceleration
    with np.errstate(divide="ignore", over="ignore"):  # kn 0 or ~1e-310: no cap from it
        cap_m = np.where(kn > 0, np.minimum(cap_m, np.sqrt(margins * col(amax_n) / kn)), cap_m)
    a_max = np.sqrt(np.maximum(a_p * a_p - (cap_m * cap_m * k) ** 2, 0.0))
    j_left = j_p - cap_m**3 * dk
    a_t = np.minimum(a_max, shares * j_left / (3.0 * cap_m * k))
    j_t = np.sqrt(np.maximum(j_p * j_p - (3.0 * cap_m * a_t * k) ** 2, 0.0)) - cap_m**3 * dk
    sp = col(sin_p)
    pitched = sp > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # sp ~ 1e-310: inf
        a_t = np.where(pitched, np.minimum(a_t, (col(amax_n) - cap_m * cap_m * kn) / sp), a_t)
        j_t = np.where(pitched, np.minimum(j_t, col(jmax_n) / sp), j_t)
    ok = (a_t > 0) & (j_t > 0)
    assert ok.any(axis=(1, 2)).all(), "arc_limits found no (cap, a_t, j_t): limits must be > 0"
    a_s, j_s = np.where(ok, a_t, 1.0), np.where(ok, j_t, 1.0)
    cost = col(lengths_mm) / cap_m
    for side in (0, 1):
        dv = np.maximum(cap_m - col([e[side] for e in ends]), 0.0)
        ramp = np.where(dv * j_s >= a_s * a_s, dv / a_s + a_s / j_s, 2.0 * np.sqrt(dv / j_s))
        cost = cost + ramp * dv / (2.0 * cap_m)
    cost = np.where(ok, cost, np.inf)
    best = cost.reshape(len(follows), -1).argmin(axis=1)
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
