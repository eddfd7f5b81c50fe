"""Speed ramps on small arcs that ride the jerk the state leaves: near time-optimal.

Following an arc of curvature k = 1/R [1/mm] at path speed v [mm/s] with tangential acceleration
a [mm/s^2] and jerk j [mm/s^3] needs acceleration a T + v^2 k N and jerk (j - v^3 k^2) T +
3 v a k N (T tangent, N inward normal). Near the curvature speed cap v^3 k^2 takes almost all of
the jerk, so a 1-D profile with constant limits (Ruckig's) must either cruise well below the cap
or ramp with little jerk. A numerical optimal-control solution of a full R 1 circle from rest
(direct transcription) ramps instead with the largest jerk the state allows: up at the highest
jerk until a switch time, then down at the lowest until a = 0, approaching the cap smoothly.

:func:`saturated_profile` builds that shape as constant-jerk steps of at most :data:`STEP_S`:
the ramp from the start, a cruise where the arc is long enough, and the ramp back from the end
(built forwards, reversed in time), with switch times chosen so that both ramps meet at the
highest peak the arc's length allows (a two-phase bridge absorbs what the switch-time search
leaves between their peaks). The bounds come from :mod:`~gantry_sim.controller.planner.ramp_bounds`: ``CircleLimits`` (each plane axis against
its own limits along a plain circle: exact, so the ramps may use the stronger axis where the
tangent points along it) or ``NormLimits`` (orientation-free, as
:func:`gantry_sim.controller.planner.speedup.follow_ok` checks). On the bundled machine an R 1 circle from rest takes
0.205 s (constant-limit profiles: 0.245 s; the direct-transcription optimum with per-axis limits:
0.199 s). The result is a :class:`~gantry_sim.controller.planner.profile.Profile1D`; the planner
checks the pieces built on it against every limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.ramp_bounds import RampLimits

#: Step [s] of the ramps' constant-jerk phases (the jerk follows the state at this rate).
STEP_S = 2.5e-4
#: Longest ramp [s] tried (a ramp whose jerk runs out crawls towards its end: a failure).
MAX_RAMP_S = 2.0
#: Peaks tried for the ramps of one arc (each a few hundredths of a second to build).
PEAK_TRIES = 8
#: Share of the plane's jerk and acceleration the ramps use (the point-by-point check that
#: follows allows 0.97 of them; the rest absorbs the state's change within a step).
SHARE = 0.94


def _advance(h, s, v, a, j):
    """State (s, v, a) after ``h`` [s] of constant jerk ``j`` from (s, v, a)."""
    return s + h * (v + h * (0.5 * a + h * j / 6.0)), v + h * (a + 0.5 * h * j), a + h * j


def _ramps(
    v0: float, tau1: np.ndarray, lim: RampLimits, dt: float, rows: list | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ramps from speed ``v0`` at a = 0, one per switch time in ``tau1`` [s], integrated together
    under the bounds ``lim``. Returns (peak speed, distance, duration) arrays, NaN where the state
    left no jerk to bring the acceleration back to 0. ``rows``: when given, the phases
    (dur, s, v, a, j) of the first ramp are appended to it."""
    n = tau1.size
    v, a, s, t = np.full(n, v0), np.zeros(n), np.zeros(n), np.zeros(n)
    live = np.ones(n, dtype=bool)
    out_v, out_s, out_t = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    tiny = 1e-9 * lim.jerk_min
    for _ in range(200000):
        live &= t < MAX_RAMP_S
        if not live.any():
            break
        j_lo, j_hi, a_hi = lim.bounds(s, v, a)
        up = t < tau1
        h = np.where(up, np.minimum(dt, tau1 - t), dt)
        j = np.where(up, np.minimum(j_hi, np.maximum(a_hi - a, 0.0) / h), j_lo)
        last = ~up & (a + j * h <= 0.0)
        h = np.where(last, a / np.maximum(-j, tiny), h)
        if rows is not None and live[0] and h[0] > 0:
            rows.append((h[0], s[0], v[0], a[0], j[0]))
        s_new, v_new, a_new = _advance(h, s, v, a, j)
        bad = live & ((j_lo > j_hi) | (~up & (j >= -tiny)))
        done = live & last & ~bad
        out_v[done], out_s[done], out_t[done] = v_new[done], s_new[done], (t + h)[done]
        live &= ~(done | bad)
        a_new = np.where(last, 0.0, a_new)
        s, v, a, t = (
            np.where(live, x, y) for x, y in ((s_new, s), (v_new, v), (a_new, a), (t + h, t))
        )
    return out_v, out_s, out_t


def _ramp_rows(v0: float, tau1: float, lim: RampLimits, dt: float) -> tuple[list, float, float]:
    """The phases (dur, s-offset, v, a, j) of one ramp (see :func:`_ramps`), its peak speed and
    its distance (NaN when it fails)."""
    rows: list = []
    vp, d, _ = _ramps(v0, np.array([tau1]), lim, dt, rows)
    return rows, float(vp[0]), float(d[0])


def _scan(
    v0: float,
    lim: RampLimits,
    dt: float,
    hi: float,
    keep: Callable[[np.ndarray], np.ndarray],
) -> float:
    """Largest switch time [s] in [0, hi] whose ramp's peak satisfies ``keep`` (4 scans of 33)."""
    lo = 0.0
    for _ in range(4):
        tau = np.linspace(lo, hi, 33)
        vp, _, _ = _ramps(v0, tau, lim, dt)
        ok = np.flatnonzero(keep(vp))
        if ok.size == 0:
            return 0.0
        i = ok[-1]
        lo, hi = tau[i], tau[min(i + 1, tau.size - 1)]
    return lo


def saturated_profile(
    length_mm: float,
    v_in: float,
    v_out: float,
    cap: float,
    limits: tuple[RampLimits, RampLimits],
    dt: float = STEP_S,
) -> Profile1D | None:
    """1-D profile along an arc of ``length_mm`` from ``v_in`` to ``v_out`` (a = 0 at both ends), path speed <= ``cap``, with
    ramps that ride the jerk the state leaves; None when it cannot be built (among others, on
    an arc too short for the ramps: the planner then uses its other candidates).

    ``limits``: the bounds of the ramp from the start and of the ramp back from the end
    (:class:`~gantry_sim.controller.planner.ramp_bounds.NormLimits` or
    :class:`~gantry_sim.controller.planner.ramp_bounds.CircleLimits`), already scaled by :data:`SHARE`.
    """
    if length_mm <= 0 or max(v_in, v_out) >= cap:
        return None
    lim_up, lim_dn = limits
    acc, jerk = lim_up.acc_min, lim_up.jerk_min
    hi = 2.0 * (cap / jerk) ** 0.5 + 2.0 * cap / acc  # switch times beyond this overshoot cap
    tables = []
    for v0, lim in ((v_in, lim_up), (v_out, lim_dn)):
        edge = _scan(v0, lim, dt, hi, np.isfinite)
        tau = edge * (1.0 - np.linspace(1.0, 0.0, 49) ** 2)  # denser near the edge
        vp, d, _ = _ramps(v0, tau, lim, dt)
        keep = np.isfinite(vp)
        if not keep.any():
            return None
        vp, d = np.maximum.accumulate(vp[keep]), d[keep]
        tables.append((vp, d))
    top = min(cap, tables[0][0].max(), tables[1][0].max())
    grid = np.linspace(max(v_in, v_out), top, 400)
    need = sum(np.interp(grid, vp, d) for vp, d in tables)
    # the highest peak that fits once the ramps are exact: the table's distances leave out the
    # bridge between the ramps' peaks (2 BRIDGE_S at about the peak speed, 7 % of an arc of 0.27
    # mm at 10 mm/s), so where a peak falls short by some length, the next one tried is the
    # highest whose table distance leaves that much more room
    room, below = length_mm, grid.size
    for _ in range(PEAK_TRIES):
        fits = np.flatnonzero(need[:below] <= room)
        if fits.size == 0:
            return None
        idx = below = int(fits[-1])
        peak = grid[idx]
        ramps = []
        for v0, lim in ((v_in, lim_up), (v_out, lim_dn)):
            switch = _scan(v0, lim, dt, hi, _peak_at_most(peak))
            ramps.append(_ramp_rows(v0, switch, lim, dt))
        up, dn = ramps
        if not (up[0] and dn[0]):
            continue  # no ramp reaches this peak (too short an arc, or an end already there)
        bridge = _bridge(up[1], dn[1], up[2], jerk)
        cruise = length_mm - up[2] - dn[2] - bridge[1]
        if cruise >= 0.0 and max(up[1], dn[1]) <= cap:
            return Profile1D(_assemble(up[0], bridge[0], dn[1], up[2] + bridge[1], dn[0], cruise))
        room += min(cruise, 0.0)
    return None


def _peak_at_most(peak: float) -> Callable[[np.ndarray], np.ndarray]:
    """For :func:`_scan`: True where a ramp's peak speed is at most ``peak`` (False: failed)."""

    def keep(vp: np.ndarray) -> np.ndarray:
        return np.nan_to_num(vp, nan=np.inf) <= peak

    return keep


#: Shortest duration [s] of each half of the S-curve that joins the two ramps' peaks, and the
#: share of the jerk it may use (the ramps leave 1 - SHARE of it to the point-by-point check).
BRIDGE_S = 1e-3
BRIDGE_JERK_SHARE = 0.01


def _bridge(v_up: float, v_dn: float, s0: float, jerk: float):
    """Two constant-jerk phases from v_up to v_dn (a = 0 at both ends), each at least
    :data:`BRIDGE_S` long and using at most :data:`BRIDGE_JERK_SHARE` of the jerk: (rows,
    distance). The peaks differ where a ramp's peak is sensitive to its switch time."""
    dv = v_dn - v_up
    h = max(BRIDGE_S, math.sqrt(abs(dv) / (BRIDGE_JERK_SHARE * jerk)))
    j = dv / h**2
    rows = np.array(
        [[h, s0, v_up, 0.0, j], [h, s0 + h * v_up + j * h**3 / 6.0, v_up + 0.5 * dv, j * h, -j]]
    )
    return rows, (v_up + v_dn) * h


def _assemble(rows_up, bridge, v_peak, s_up, rows_dn, cruise):
    """Up-ramp, bridge, cruise at ``v_peak`` (the down-ramp's peak) from ``s_up`` [mm], and the
    down-ramp (the ramp from the end speed, reversed in time)."""
    up = np.vstack([np.array(rows_up), bridge])
    dn = np.array(rows_dn)[::-1].copy()  # time-reversed: dur, start state of each phase
    # A phase (h, s, v, a, j) of the ramp from the end speed, reversed, starts at its end state
    # with the tangential acceleration and velocity mirrored: v_end, -a_end, jerk j.
    h, s, v, a, j = dn.T
    s_end, v_end, a_end = _advance(h, s, v, a, j)
    total_dn = s_end[0]
    s0 = s_up + cruise
    rows = [up]
    if cruise > 0:
        rows.append(np.array([[cruise / v_peak, s_up, v_peak, 0.0, 0.0]]))
    rows.append(np.column_stack([h, s0 + (total_dn - s_end), v_end, -a_end, j]))
    return np.vstack(rows)
