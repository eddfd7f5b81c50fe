"""Junction speeds the closed-form pieces can take: a vectorised check before planning.

At a junction with a curvature or direction jump the reference leaves the geometry briefly: the
piece from the junction state to the neighbouring arc's first (or last) chord vertex must absorb
the jump within one chord. :func:`feasible_junction_caps` lowers each moving junction's cap (by
bisection, all junctions at once) until those two pieces, at constant speed, keep every axis'
limits and the feed (:func:`gantry_sim.controller.planner.jerk3.piece_limits_ok`). The planner still checks the real
pieces afterwards and lowers a cap further when needed; this only saves re-planning rounds.
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.arcs import frenet
from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.planner.jerk3 import jerk3_pairs, piece_limits_ok

#: Bisection steps on the junction speed (the cap is found to within 2^-10 of its start value).
STEPS = 10


def _piece_ok(p0, v0, a0, p1, v1, a1, dur, lim, feed) -> np.ndarray:
    """Vectorised: each row one piece (states (m, 3), dur (m,)); True where it keeps the limits."""
    _ps, vs, as_, js = jerk3_pairs(p0, v0, a0, p1, v1, a1, dur)
    return piece_limits_ok(vs, as_, js, dur, a1, *lim, feed)


def feasible_junction_caps(geoms, caps: np.ndarray, states, machine: MachineConfig) -> np.ndarray:
    """Return ``caps`` lowered where the pieces next to a junction could not keep the limits."""
    lim = machine.limits
    limits = (lim.max_velocity_mm_per_s, lim.max_acceleration_mm_per_s2, lim.max_jerk_mm_per_s3)
    rows = []  # (junction, p0, t0, k0, p1, t1, k1, chord length along the path, feed, side)
    caps = caps.copy()
    for b in range(1, len(geoms)):
        caps[b] = min(caps[b], geoms[b - 1].limits.cap_mm_per_s, geoms[b].limits.cap_mm_per_s)
        if not caps[b] > 0.0:
            continue
        d, kv = states[b]
        for g, side in ((geoms[b], "after"), (geoms[b - 1], "before")):
            if not g.is_arc:
                continue
            u = g.u[1] if side == "after" else g.u[-2]
            d1, d2 = g.derivatives(np.array([u]))
            t, k = frenet(d1[0], d2[0])
            pv = g.vertices[1] if side == "after" else g.vertices[-2]
            s = (u if side == "after" else 1.0 - u) * g.length_mm
            if side == "after":
                rows.append((b, g.vertices[0], d, kv, pv, t, k, s, g.feed_mm_per_s))
            else:
                rows.append((b, pv, t, k, g.vertices[-1], d, kv, s, g.feed_mm_per_s))
    if not rows:
        return caps
    jb = np.array([r[0] for r in rows])
    p0, t0, k0, p1, t1, k1 = (np.array([r[i] for r in rows]) for i in range(1, 7))
    length = np.array([r[7] for r in rows])
    feed = np.array([r[8] for r in rows])
    hi = caps[jb].copy()
    lo = np.zeros_like(hi)

    def ok_at(v):
        vv = v[:, None]
        return _piece_ok(
            p0, vv * t0, vv * vv * k0, p1, vv * t1, vv * vv * k1, length / v, limits, feed
        )

    good = ok_at(hi)
    if good.all():
        return caps
    idx = np.flatnonzero(~good)
    lo_i, hi_i = lo[idx], hi[idx]
    for _ in range(STEPS):
        mid = 0.5 * (lo_i + hi_i)
        sub = _subset(idx, p0, t0, k0, p1, t1, k1, length, feed)
        okm = _piece_ok(
            sub[0],
            mid[:, None] * sub[1],
            (mid * mid)[:, None] * sub[2],
            sub[3],
            mid[:, None] * sub[4],
            (mid * mid)[:, None] * sub[5],
            sub[6] / mid,
            limits,
            sub[7],
        )
        lo_i = np.where(okm, mid, lo_i)
        hi_i = np.where(okm, hi_i, mid)
    out = caps.copy()
    for j, v in zip(jb[idx], lo_i, strict=True):
        out[j] = min(out[j], v)
    return out


def _subset(idx, *arrays):
    return tuple(a[idx] for a in arrays)
