"""Faster ("boosted") 1-D profiles for arcs that ramp: exact following checked point by point.

A block's limits (:func:`gantry_sim.controller.planner.limits.arc_limits`) hold at its worst
speed and acceleration at once. Where an arc ramps, a faster profile may use more jerk and
acceleration where the speed is low: the arc's
:class:`~gantry_sim.controller.planner.limits.FollowGeometry` bounds its exact following
(curvature [1/mm], its derivative [1/mm^2], pitch, feed cap [mm/s]), :func:`follow_ok` checks a
profile against the axis limits [mm/s^2], [mm/s^3] point by point, :func:`boost_candidates`
lists the (cap [mm/s], jerk [mm/s^3], acceleration [mm/s^2]) to try and :func:`boosted_profile`
searches them with the 1-D solver
(:meth:`~gantry_sim.controller.planner.ruckig_solver.RuckigSolver.profile`), and the saturated
ramps (:mod:`~gantry_sim.controller.planner.saturated_ramp`) where they are faster still.
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.config import Limits
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import Vec3
from gantry_sim.controller.planner.limits import FollowGeometry, curvature_speed_cap
from gantry_sim.controller.planner.move_geometry import ArcGeometry
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.ramp_bounds import CircleLimits, NormLimits
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver, SolverFailure
from gantry_sim.controller.planner.saturated_ramp import SHARE as SATURATED_SHARE
from gantry_sim.controller.planner.saturated_ramp import saturated_profile
from gantry_sim.controller.planner.tangent_limits import tangent_profile

#: An arc whose entry or exit speed is below this share of its cap tries a faster profile.
BOOST_RAMP_SHARE = 0.9
#: Tangential accelerations tried for each boosted (cap, jerk), as shares of the most useful.
BOOST_ACC_SHARES = (1.0, 0.85, 0.7, 0.55, 0.42, 0.3, 0.2)
#: ... and only when its profile takes longer than this times cruising at the fastest candidate.
BOOST_MIN_GAIN = 1.005


#: Share of the axis limits a profile checked by :func:`follow_ok` may use (the closed-form
#: pieces between vertices are checked again, exactly, by the planner).
FOLLOW_MARGIN = 0.97
#: Fractions of the curvature caps and shares of the jerk they leave (:func:`boost_candidates`).
BOOST_MARGINS = (0.99, 0.95, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4)
BOOST_JERK_SHARES = (0.95, 0.8, 0.65, 0.5, 0.35)


def follow_ok(profile: Profile1D, fg: FollowGeometry, cap: float, amax, jmax) -> bool:
    """True when following the arc exactly with ``profile`` keeps every axis within :data:`FOLLOW_MARGIN` of its acceleration and jerk limits
    and the path speed within ``cap`` [mm/s] (to rounding: the arc caps keep a margin below the
    feed): the bounds of :mod:`gantry_sim.controller.planner.limits`, evaluated at
    9 points of every phase instead of at their worst combination (speed-dependent limits)."""
    i1, i2, n = fg.plane_axes
    k, dk, sp = fg.curvature_per_mm, fg.dcurv_per_mm2, fg.sin_pitch
    vv, acc, j = profile.speeds_at()
    if vv.max() > cap * (1.0 + 1e-12):  # Ruckig reaches its cap to rounding; cap < feed
        return False
    aa = np.abs(acc)
    m = FOLLOW_MARGIN
    v2k = vv * vv * k
    if (aa * aa + v2k * v2k).max() > (m * min(amax[i1], amax[i2])) ** 2:
        return False
    jj = np.abs(j) + vv * v2k * (dk / k) if k > 0 else np.abs(j) + 0.0 * vv
    ja = 3.0 * vv * aa * k
    if (jj * jj + ja * ja).max() > (m * min(jmax[i1], jmax[i2])) ** 2:
        return False
    return sp == 0 or (aa.max() * sp <= m * amax[n] and np.abs(j).max() * sp <= m * jmax[n])


def boost_candidates(fg: FollowGeometry, vmax, amax, jmax) -> list[tuple[float, float, float]]:
    """(cap, jerk, acc_hi) triples to try for a profile checked by :func:`follow_ok`: caps at
    fractions of the curvature caps, shares of the jerk left at that speed, and the largest
    tangential acceleration worth trying (the caller tries shares of it)."""
    i1, i2, n = fg.plane_axes
    a_pl, j_pl = min(amax[i1], amax[i2]), min(jmax[i1], jmax[i2])
    k, dk, sp = fg.curvature_per_mm, fg.dcurv_per_mm2, fg.sin_pitch
    base = fg.speed_cap(vmax)
    a_hi = a_pl if sp == 0 else min(a_pl, amax[n] / sp)
    out: list[tuple[float, float, float]] = []
    for margin in BOOST_MARGINS:
        cap = curvature_speed_cap(base, k, dk, a_pl, j_pl, margin)
        j_left = FOLLOW_MARGIN * j_pl - cap**3 * dk
        if sp > 0:
            j_left = min(j_left, FOLLOW_MARGIN * jmax[n] / sp)
        out.extend((cap, share * j_left, a_hi) for share in BOOST_JERK_SHARES if j_left > 0)
        if cap >= base:
            break
    return out


def _solve(solver: RuckigSolver, *args: float) -> Profile1D | None:
    """``solver.profile(*args)``, or None where the solver fails (the candidate is skipped)."""
    try:
        return solver.profile(*args)
    except SolverFailure:
        return None


def boosted_profile(
    g: ArcGeometry,
    v_in: float,
    v_out: float,
    profile: Profile1D,
    limits: Limits,
    solver: RuckigSolver,
    cache: dict,
    saturated: bool = True,
) -> tuple[Profile1D, ...]:
    """Faster 1-D profiles for an arc that ramps (speed-dependent limits), fastest first; the
    planner uses the first whose closed-form pieces keep every limit.

    The block's limits hold at its worst speed and acceleration at once; a profile whose
    exact following is checked point by point (:func:`follow_ok`) may use more jerk and
    acceleration where the speed is low, or cruise a little below the curvature cap to keep
    jerk for the ramps. Tried only where the block ramps (an end below
    :data:`BOOST_RAMP_SHARE` of its cap); the fastest checked candidate wins, preceded by the
    saturated ramps (:func:`saturated_candidates`) where they are faster still.

    Args:
        g: the arc's geometry; ``v_in``, ``v_out``: its end speeds [mm/s]; ``profile``: its
            profile.
        limits: the machine's per-axis limits.
        solver: makes the 1-D profiles (:meth:`RuckigSolver.profile`).
        cache: results by (length, follow geometry, end speeds), filled here.
        saturated: whether the saturated ramps may be tried (not on G64 blend arcs).
    """
    fg, lim = g.follow, g.limits
    if min(v_in, v_out) >= BOOST_RAMP_SHARE * lim.cap_mm_per_s:
        return ()
    vmax, amax, jmax = limits.per_axis()
    candidates = boost_candidates(fg, vmax, amax, jmax)
    t_now = profile.duration_s
    if not candidates or t_now <= BOOST_MIN_GAIN * g.length_mm / candidates[0][0]:
        return ()  # even cruising at the highest candidate cap would not gain enough
    key = (g.length_mm, fg, v_in, v_out, saturated)
    if key in cache:
        return cache[key]
    best, best_t = None, t_now * (1.0 - 1e-6)
    base = fg.speed_cap(vmax)
    for cap, jerk, a_hi in candidates:
        if cap < max(v_in, v_out) or jerk <= 0:
            continue
        fastest = _solve(solver, g.length_mm, v_in, v_out, cap, a_hi, jerk)
        if fastest is None or fastest.duration_s >= best_t:
            continue  # more acceleration is never slower: nothing to gain here
        for share in BOOST_ACC_SHARES:  # the first that passes is this pair's fastest
            cand = fastest if share == 1.0 else None
            if cand is None:
                cand = _solve(solver, g.length_mm, v_in, v_out, cap, share * a_hi, jerk)
            if cand is None:
                continue
            t_cand = cand.duration_s
            if t_cand >= best_t:
                break  # less acceleration is never faster
            if follow_ok(cand, fg, base, amax, jmax):
                best, best_t = cand, t_cand
                break
    found = () if best is None else (best,)
    # the saturated ramps (a few tenths of a second to build) cannot beat cruising the whole
    # arc at its speed cap: skip them where that could save less than SATURATED_MIN_GAIN_S
    if saturated and best_t - g.length_mm / base >= SATURATED_MIN_GAIN_S:
        sat = saturated_candidates(g, v_in, v_out, base, amax, jmax, solver)
        found = (*(p for p in sat if p.duration_s < best_t), *found)
    cache[key] = found
    return found


#: An arc that starts and ends below this share of its cap (near rest: the ramps start from an
#: exact arc state, not from a junction whose curvature jump the first piece must absorb), and
#: whose centripetal jerk or acceleration at the cap is at least SATURATED_MIN_USE of the limit,
#: also tries the saturated ramps (:mod:`gantry_sim.controller.planner.saturated_ramp`; a few tenths of a second).
SATURATED_END_SHARE = 0.1
SATURATED_MIN_USE = 0.25
#: ... and the saturated ramps themselves only where that share is at least this (below it,
#: the tangent's profile alone). What they save grows with the share, what they cost does not:
#: on the 104 arcs from rest of a 20,000-line PrusaSlicer arc-fitted print in G61 (Marlin's
#: M201 X500 Y500), the 61 where the curvature takes 0.25-0.5 (R 3-5, capped by the feed) cost
#: 37.7 s of planning to save 0.67 s of a 1,992 s cycle, the 37 above 0.9 cost 6.1 s to save
#: 0.44 s. The bundled machine's full R 10 circle from rest at F6000 (0.4) then runs 0.710 s
#: instead of 0.703; R 1, 2 and 5 (0.8 and more) keep their ramps.
SATURATED_RAMP_MIN_USE = 0.5
#: Least time [s] the saturated ramps could save on an arc for them to be built (a blend arc of
#: a polyline passed near rest could save microseconds, for 0.36 s of planning each: measured on
#: 1,000 blended G1 moves, 13 of them took 4.7 s of a 5 s plan).
SATURATED_MIN_GAIN_S = 0.002
#: Where the profile under the tangent's limits peaks below this share of the curvature cap,
#: the saturated ramps are not built: on the first 3,000 lines of a Bambu Studio arc-fitted
#: print (2,389 moves) they took 47 s of a 52 s plan to shorten a 228 s cycle by 2 ms at 0.5
#: (and 71 s, 0.3 s, without the tangent's profile). A full circle from rest peaks at its cap.
TANGENT_ENOUGH = 0.85


def _plain_circle(g: ArcGeometry) -> bool:
    """An arc of constant radius in its plane (no helix, no spiral; not a spline)."""
    if not isinstance(g.move, Arc):
        return False
    f = arc_frame(g.move)
    return abs(f.r1_mm - f.r0_mm) <= 1e-9 * f.r0_mm and f.h0_mm == f.h1_mm


def saturated_candidates(
    g: ArcGeometry,
    v_in: float,
    v_out: float,
    base: float,
    amax: Vec3,
    jmax: Vec3,
    solver: RuckigSolver,
    try_spirals: bool = False,
) -> tuple[Profile1D, ...]:
    """The profiles of an arc from and to near rest on which the curvature takes much of the
    jerk or acceleration (see :data:`SATURATED_END_SHARE`), fastest first (none elsewhere).
    On a plain circle: the profile under the tangent's per-axis limits
    (:func:`tangent_profile`, a few Ruckig calls) and the saturated ramps, which use each plane
    axis' own limits (:class:`CircleLimits`) and cost tenths of a second an arc (an arc-fitted
    print has thousands of such arcs): they are built only where the curvature takes at least
    :data:`SATURATED_RAMP_MIN_USE` of the limits at the cap and the tangent's profile peaks
    above :data:`TANGENT_ENOUGH` of the curvature cap (elsewhere they gain too little for what
    they cost).
    Elsewhere (an arc whose end radii differ, as rounded CAM output's do) the orientation-free
    bounds, checked by :func:`follow_ok`, only with ``try_spirals``: measured on 2,000 mixed CAM
    blocks, 41 such arcs cost 27 s of a 29 s plan and none passed the check, so the planner
    does not try them."""
    fg = g.follow
    i1, i2, _ = fg.plane_axes
    a_pl, j_pl = min(amax[i1], amax[i2]), min(jmax[i1], jmax[i2])
    k, dk = fg.curvature_per_mm, fg.dcurv_per_mm2
    cap = curvature_speed_cap(base, k, dk, a_pl, j_pl, SATURATED_SHARE)
    use = max(cap**3 * dk / j_pl, cap * cap * k / a_pl)
    if fg.sin_pitch > 0 or use < SATURATED_MIN_USE or max(v_in, v_out) > SATURATED_END_SHARE * cap:
        return ()
    sh = SATURATED_SHARE
    if isinstance(g.move, Arc) and _plain_circle(g):
        # Exact per-axis bounds: the planner checks every closed-form piece against the limits
        # before using the profile. The cap stays the orientation-free curvature cap: the cruise
        # (and the bridge between the ramps' peaks) must hold wherever on the circle it lies.
        f = arc_frame(g.move)
        acc, jerk = (amax[i1], amax[i2]), (jmax[i1], jmax[i2])
        tang = tangent_profile(f, g.length_mm, v_in, v_out, cap, acc, jerk, solver)
        found = () if tang is None else (tang,)
        if use < SATURATED_RAMP_MIN_USE or (
            tang is not None and tang.rows[:, 2].max() <= TANGENT_ENOUGH * cap
        ):
            return found
        ends = CircleLimits.ends(f, g.length_mm, acc, jerk, sh)
        sat = saturated_profile(g.length_mm, v_in, v_out, cap, ends)
        if sat is not None:
            found = tuple(sorted((*found, sat), key=lambda p: p.duration_s))
        return found
    if not try_spirals:
        return ()
    norm = NormLimits(k, dk, sh * a_pl, sh * j_pl)
    prof = saturated_profile(g.length_mm, v_in, v_out, cap, (norm, norm))
    return (prof,) if prof is not None and follow_ok(prof, fg, base, amax, jmax) else ()
