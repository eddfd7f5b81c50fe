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
from gantry_sim.controller.planner.ramp_family import MAX_RAMP_S, RampFamily, advance

#: Step [s] of the ramps' constant-jerk phases (the jerk follows the state at this rate).
STEP_S = 2.5e-4
#: Most steps a ramp's switch times span: where the ramps reach further (a machine of low jerk,
#: down to the machine file's 1 mm/s^3, reaches the 2 s of ``MAX_RAMP_S``) the step grows to
#: reach / this. Each search steps every switch time's ramp down, so its cost grows with the
#: square of the steps: 8,000 steps of STEP_S took 8 s an arc, a full circle a minute.
MAX_RAMP_STEPS = 2048
#: Peaks tried for the ramps of one arc (each a few hundredths of a second to build).
PEAK_TRIES = 8
#: Share of the plane's jerk and acceleration the ramps use (the point-by-point check that
#: follows allows 0.97 of them; the rest absorbs the state's change within a step).
SHARE = 0.94


#: Switch times of each pass that refines a search between two up steps' starts, and passes.
REFINE_POINTS = 33
REFINE_PASSES = 3


def _search(
    fam: RampFamily,
    peaks: np.ndarray,
    keep: Callable[[np.ndarray], np.ndarray],
    seen: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
) -> float:
    """Largest switch time [s] whose ramp's peak satisfies ``keep``: the last of the family's
    step starts that does (``peaks``: their ramps' peaks), refined towards the next one; 0 when
    none does. ``seen``: when given, the (switch times, peaks, distances) of the ramps the
    refining made are appended to it."""
    ok = np.flatnonzero(keep(peaks))
    if ok.size == 0:
        return 0.0
    i = int(ok[-1])
    grid = fam.grid
    lo, hi = grid[i], grid[min(i + 1, grid.size - 1)]
    for _ in range(REFINE_PASSES):
        if hi <= lo:
            break
        tau = np.linspace(lo, hi, REFINE_POINTS)
        vp, d, _ = fam.ramps(tau)
        if seen is not None:
            seen.append((tau, vp, d))
        sel = np.flatnonzero(keep(vp))
        if sel.size == 0:
            break
        k = int(sel[-1])
        lo, hi = tau[k], tau[min(k + 1, tau.size - 1)]
    return float(lo)


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
    dt = max(dt, min(hi, MAX_RAMP_S) / MAX_RAMP_STEPS)
    ends, tables = [], []
    for v0, lim in ((v_in, lim_up), (v_out, lim_dn)):
        fam = RampFamily(v0, lim, dt, hi)
        peaks, dist, _ = fam.ramps(fam.grid)  # every up step's start as a switch time
        # the peak climbs steeply in the last step before the edge (the last switch time
        # whose ramp still ends): the table takes the refining's ramps there too
        seen = [(fam.grid, peaks, dist)]
        _search(fam, peaks, np.isfinite, seen)
        tau, vp, d = (np.concatenate(x) for x in zip(*seen, strict=True))
        order = np.argsort(tau, kind="stable")
        vp, d = vp[order], d[order]
        keep = np.isfinite(vp)
        if not keep.any():
            return None
        tables.append((np.maximum.accumulate(vp[keep]), d[keep]))
        ends.append((fam, peaks))
    top = min(cap, tables[0][0].max(), tables[1][0].max())
    grid = np.linspace(max(v_in, v_out), top, 400)
    # the ramps' distances, and the bridge between their peaks: at least 2 BRIDGE_S at the
    # peak speed (7 % of an arc of 0.27 mm at 10 mm/s)
    need = sum(np.interp(grid, vp, d) for vp, d in tables) + 2.0 * BRIDGE_S * grid
    # the highest peak that fits once the ramps are exact: where a peak falls short by some
    # length, the next one tried is the highest whose estimate leaves that much more room
    room, below_idx = length_mm, grid.size
    for _ in range(PEAK_TRIES):
        fits = np.flatnonzero(need[:below_idx] <= room)
        if fits.size == 0:
            return None
        idx = below_idx = int(fits[-1])
        peak = grid[idx]
        ramps = []
        for fam, peaks in ends:
            switch = _search(fam, peaks, _peak_at_most(peak))
            rows: list = []
            vp1, d1, _ = fam.ramps(np.array([switch]), rows)
            ramps.append((rows, float(vp1[0]), float(d1[0])))
        up, dn = ramps
        if not (up[0] and dn[0]) or not np.isfinite(up[2] + dn[2]):
            continue  # no ramp reaches this peak (too short an arc, or an end already there)
        bridge = _bridge(up[1], dn[1], up[2], jerk)
        cruise = length_mm - up[2] - dn[2] - bridge[1]
        if cruise >= 0.0 and max(up[1], dn[1]) <= cap:
            return Profile1D(_assemble(up[0], bridge[0], dn[1], up[2] + bridge[1], dn[0], cruise))
        room += min(cruise, 0.0)
    return None


def _peak_at_most(peak: float) -> Callable[[np.ndarray], np.ndarray]:
    """For :func:`_search`: True where a ramp's peak speed is at most ``peak`` (False: failed)."""

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
    s_end, v_end, a_end = advance(h, s, v, a, j)
    total_dn = s_end[0]
    s0 = s_up + cruise
    rows = [up]
    if cruise > 0:
        rows.append(np.array([[cruise / v_peak, s_up, v_peak, 0.0, 0.0]]))
    rows.append(np.column_stack([h, s0 + (total_dn - s_end), v_end, -a_end, j]))
    return np.vstack(rows)
