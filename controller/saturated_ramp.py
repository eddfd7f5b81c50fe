"""Speed ramps on small arcs that ride the jerk the curvature leaves: near time-optimal.

Following an arc of curvature k [1/mm] (and |p'''| = dk [1/mm^2]) at path speed v [mm/s] with
tangential acceleration a [mm/s^2] and jerk j [mm/s^3] needs, per axis of the plane (the bounds
of :mod:`controller.lookahead`), (|j| + v^3 dk)^2 + (3 v a k)^2 <= J^2 and a^2 + (v^2 k)^2 <= A^2.
Near the curvature speed cap v^3 dk takes almost all of J, so a 1-D profile with constant limits
(Ruckig's) must either cruise well below the cap or ramp with little jerk. A numerical optimal
control solution of a full R 1 circle from rest (direct transcription, these constraints) ramps
instead with the largest jerk the state allows: up at +J_left(v, a) until a switch time, then down
at -J_left(v, a) until a = 0, at a peak speed approached smoothly. :func:`saturated_profile`
builds that shape (the ramp from the end speed mirrored for the way down, a cruise between them
where the arc is long enough) as constant-jerk steps of at most ``dt``, choosing the switch times
so that both ramps meet at the highest peak the arc's length allows. Rows (dur, s, v, a, j), the
planner's 1-D profile format; the caller checks the result point by point
(:func:`controller.boost.follow_ok`) before using it.
"""

from __future__ import annotations

import math

import numpy as np

#: Step [s] of the ramps' constant-jerk phases (the jerk follows the state at this rate).
STEP_S = 2.5e-4
#: Longest ramp [s] tried (a ramp whose jerk runs out crawls towards its end: a failure).
MAX_RAMP_S = 2.0
#: Share of the plane's jerk and acceleration the ramps use (the point-by-point check that
#: follows allows 0.97 of them; the rest absorbs the state's change within a step).
SHARE = 0.94


def _ramps(v0: float, tau1: np.ndarray, k: float, dk: float, acc: float, jerk: float, dt: float):
    """Ramps from speed ``v0`` at a = 0, one per switch time in ``tau1`` [s], integrated together.

    Returns (peak speed, distance, duration) arrays, NaN where the state left no jerk."""
    n = tau1.size
    v, a, s, t = np.full(n, v0), np.zeros(n), np.zeros(n), np.zeros(n)
    live = np.ones(n, dtype=bool)
    out_v, out_s, out_t = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    for _ in range(200000):
        if not live.any():
            break
        live &= t < MAX_RAMP_S
        jm = np.sqrt(np.maximum(jerk * jerk - (3.0 * v * a * k) ** 2, 0.0)) - v**3 * dk
        up = t < tau1
        h = np.where(up, np.minimum(dt, tau1 - t), dt)
        a_cap = np.sqrt(np.maximum(acc * acc - (v * v * k) ** 2, 0.0))
        j = np.where(up, np.minimum(jm, np.maximum(a_cap - a, 0.0) / h), -jm)
        last = ~up & (a + j * h <= 0.0)
        h = np.where(last, a / np.maximum(jm, 1e-9 * jerk), h)
        s_new = s + h * (v + h * (0.5 * a + h * j / 6.0))
        v_new = v + h * (a + 0.5 * h * j)
        bad = live & (jm <= 1e-9 * jerk)
        done = live & last & ~bad
        out_v[done], out_s[done], out_t[done] = v_new[done], s_new[done], (t + h)[done]
        live &= ~(done | bad)
        a_new = np.where(last, 0.0, a + j * h)
        s, v, a, t = (
            np.where(live, x, y) for x, y in ((s_new, s), (v_new, v), (a_new, a), (t + h, t))
        )
    return out_v, out_s, out_t


def _ramp_rows(v0: float, tau1: float, k: float, dk: float, acc: float, jerk: float, dt: float):
    """The phases (dur, s-offset, v, a, j) of one ramp (see :func:`_ramps`)."""
    v, a, s, t, rows = v0, 0.0, 0.0, 0.0, []
    while True:
        jm = math.sqrt(max(jerk * jerk - (3.0 * v * a * k) ** 2, 0.0)) - v**3 * dk
        if t < tau1:
            h = min(dt, tau1 - t)
            a_cap = math.sqrt(max(acc * acc - (v * v * k) ** 2, 0.0))
            j, last = min(jm, max(a_cap - a, 0.0) / h), False
        else:
            h, j = dt, -jm
            last = a + j * h <= 0.0
            if last:
                h = a / jm if jm > 0 else 0.0
        if h > 0:
            rows.append((h, s, v, a, j))
        s += h * (v + h * (0.5 * a + h * j / 6.0))
        v += h * (a + 0.5 * h * j)
        a = 0.0 if last else a + j * h
        t += h
        if last:
            return rows, v, s


def _feasible_edge(v0, k, dk, acc, jerk, dt, hi):
    """The latest switch time [s] whose ramp from ``v0`` keeps some jerk all the way (later
    switches build more acceleration than the curvature lets the ramp take back)."""
    lo = 0.0
    for _ in range(4):
        tau = np.linspace(lo, hi, 33)
        vp, _, _ = _ramps(v0, tau, k, dk, acc, jerk, dt)
        ok = np.flatnonzero(np.isfinite(vp))
        i = ok[-1] if ok.size else 0
        lo, hi = tau[i], tau[min(i + 1, tau.size - 1)]
    return lo


def _switch_for_peak(v0, peak, k, dk, acc, jerk, dt, hi):
    """Switch time [s] whose ramp from ``v0`` peaks just below ``peak`` (two vectorised scans)."""
    lo = 0.0
    for _ in range(4):
        tau = np.linspace(lo, hi, 33)
        vp, _, _ = _ramps(v0, tau, k, dk, acc, jerk, dt)
        ok = np.flatnonzero(np.nan_to_num(vp, nan=np.inf) <= peak)
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
    curvature_per_mm: float,
    dcurv_per_mm2: float,
    acc_plane: float,
    jerk_plane: float,
    dt: float = STEP_S,
) -> np.ndarray | None:
    """1-D profile (rows: dur [s], s [mm], v [mm/s], a [mm/s^2], j [mm/s^3]) along an arc of
    ``length_mm`` from ``v_in`` to ``v_out`` (a = 0 at both ends), path speed <= ``cap``, with
    ramps that ride the jerk left by the curvature; None when it cannot be built."""
    k, dk = curvature_per_mm, dcurv_per_mm2
    acc, jerk = SHARE * acc_plane, SHARE * jerk_plane
    if k <= 0 or length_mm <= 0 or max(v_in, v_out) >= cap:
        return None
    hi = 2.0 * (cap / jerk) ** 0.5 + 2.0 * cap / acc  # switch times beyond this overshoot cap
    tables = []
    for v0 in (v_in, v_out):
        edge = _feasible_edge(v0, k, dk, acc, jerk, dt, hi)
        tau = edge * (1.0 - np.linspace(1.0, 0.0, 49) ** 2)  # denser near the edge
        vp, d, _ = _ramps(v0, tau, k, dk, acc, jerk, dt)
        keep = np.isfinite(vp)
        if not keep.any():
            return None
        vp, d = np.maximum.accumulate(vp[keep]), d[keep]
        tables.append((vp, d))
    top = min(cap, tables[0][0].max(), tables[1][0].max())
    grid = np.linspace(max(v_in, v_out), top, 400)
    need = sum(np.interp(grid, vp, d) for vp, d in tables)
    fits = np.flatnonzero(need <= length_mm)
    if fits.size == 0:
        return None
    for idx in fits[::-1][:8]:  # the highest peak that fits once the ramps are exact
        peak = grid[idx]
        up = _ramp_rows(
            v_in, _switch_for_peak(v_in, peak, k, dk, acc, jerk, dt, hi), k, dk, acc, jerk, dt
        )
        dn = _ramp_rows(
            v_out, _switch_for_peak(v_out, peak, k, dk, acc, jerk, dt, hi), k, dk, acc, jerk, dt
        )
        bridge = _bridge(up[1], dn[1], up[2], jerk)
        cruise = length_mm - up[2] - dn[2] - bridge[1]
        if cruise >= 0.0:
            return _assemble(up[0], bridge[0], dn[1], up[2] + bridge[1], dn[0], cruise)
    return None


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
    v_end = v + h * (a + 0.5 * h * j)
    a_end = a + h * j
    s_end = s + h * (v + h * (0.5 * a + h * j / 6.0))
    total_dn = s_end[0]
    s0 = s_up + cruise
    rows = [up]
    if cruise > 0:
        rows.append(np.array([[cruise / v_peak, s_up, v_peak, 0.0, 0.0]]))
    rows.append(np.column_stack([h, s0 + (total_dn - s_end), v_end, -a_end, j]))
    return np.vstack(rows)
