"""State-to-state pieces with three equal phases of constant jerk, in closed form, vectorised.

Between two vertex states (p0, v0, a0) -> (p1, v1, a1) reached in time T, three phases of
length h = T/3 with jerks j1, j2, j3 per axis are fixed by the three end conditions (a jerk
pulse j on [s, s + h] adds j h to a(T), j/2 ((T-s)^2 - (T-s-h)^2) to v(T) and
j/6 ((T-s)^3 - (T-s-h)^3) to p(T)):

    a1 - a0                         = h   (j1 + j2 + j3)
    v1 - v0 - 3h a0                 = h^2 (5/2 j1 + 3/2 j2 + 1/2 j3)
    p1 - p0 - 3h v0 - 9/2 h^2 a0    = h^3 (19/6 j1 + 7/6 j2 + 1/6 j3)

When the states are exact states of a smooth motion along an arc (as the planner's vertex states
are), this interpolant follows it to 5th order: measured on a circle, the distance from the arc is
2e-7 of the chord's sagitta at 0.6 degrees per chord and 5e-3 at 90 degrees, the speed error
5e-4 * phi^4 (phi: chord sweep [rad]), and the jerks stay below the true motion's. Unlike a
Ruckig piece with a ``minimum_duration`` (a time-optimal profile stretched to the duration: it
bangs the jerk between +-J and leaves the arc by about 1/8 of the sagitta, and by more than the
sagitta at low speed), it has no freedom: the motion between the states is the arc's.

Nothing here enforces limits: :func:`piece_limits_ok` checks every piece against them, and the
planner gives the pieces that fail to Ruckig.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gantry_sim.controller.planner.piece_speed import max_speed_squared

_M_INV = np.linalg.inv(np.array([[1.0, 1.0, 1.0], [2.5, 1.5, 0.5], [19 / 6, 7 / 6, 1 / 6]]))


class PiecePhases(NamedTuple):
    """The three phases of n pieces, each array (n, 3 phases, 3 axes): every phase's start
    position [mm], velocity [mm/s], acceleration [mm/s^2], and its jerk [mm/s^3]."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray


def jerk3(p: np.ndarray, v: np.ndarray, a: np.ndarray, dur: np.ndarray) -> PiecePhases:
    """Phases joining consecutive states.

    Args:
        p, v, a: (n + 1, 3) states at the vertices [mm], [mm/s], [mm/s^2].
        dur: (n,) piece durations [s], > 0.
    """
    return jerk3_pairs(p[:-1], v[:-1], a[:-1], p[1:], v[1:], a[1:], dur)


def jerk3_pairs(
    p0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    p1: np.ndarray,
    v1: np.ndarray,
    a1: np.ndarray,
    dur: np.ndarray,
) -> PiecePhases:
    """Like :func:`jerk3` for independent pieces: states (n, 3) at their starts and ends."""
    h = (dur / 3.0)[:, None]
    r0 = (a1 - a0) / h
    r1 = (v1 - v0 - 3.0 * h * a0) / h**2
    r2 = (p1 - p0 - 3.0 * h * v0 - 4.5 * h * h * a0) / h**3
    js = np.einsum("kr,rnd->nkd", _M_INV, np.stack([r0, r1, r2]))
    return PiecePhases(*phase_starts(p0, v0, a0, js, h[:, 0]), js)


def phase_starts(
    p0: np.ndarray, v0: np.ndarray, a0: np.ndarray, js: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each phase's start position, velocity, acceleration (n, 3 phases, 3 axes) of n pieces
    from their start states (n, 3), jerks ``js`` (n, 3, 3) and phase length ``h`` (n,) [s]
    (the same operations whenever called: a piece stored by its start state is rebuilt
    bit for bit)."""
    hc = h[:, None]
    n = h.size
    ps, vs, as_ = (np.empty((n, 3, 3)) for _ in range(3))
    cp, cv, ca = p0, v0, a0
    for k in range(3):
        ps[:, k], vs[:, k], as_[:, k] = cp, cv, ca
        jk = js[:, k]
        cp = cp + hc * (cv + hc * (0.5 * ca + hc * jk / 6.0))
        cv = cv + hc * (ca + 0.5 * hc * jk)
        ca = ca + hc * jk
    return ps, vs, as_


def piece_limits_ok(
    vs: np.ndarray,
    as_: np.ndarray,
    js: np.ndarray,
    dur: np.ndarray,
    a_end: np.ndarray,
    vmax,
    amax,
    jmax,
    speed_cap,
) -> np.ndarray:
    """(n,) True where a piece keeps every axis' limits and the path-speed cap.

    Jerk: per phase. Acceleration: linear per phase, so at the phase ends. Velocity per axis:
    quadratic per phase, so at its ends and its stationary point. Path speed: at 5 points per
    phase (including the ends), and exactly
    (:func:`~gantry_sim.controller.planner.piece_speed.max_speed_squared`) on the phases where
    what lies between those points could pass the cap (:func:`_between_samples`; the arc's speed
    cap keeps a margin below the feed for it, see move_geometry.FEED_MARGIN_PER_PHI4, so few
    phases need it). ``speed_cap`` [mm/s]: a number or one per piece.
    """
    vmax, amax, jmax = (np.asarray(x, dtype=float) for x in (vmax, amax, jmax))
    ok = np.all(np.abs(js) <= jmax, axis=(1, 2))
    ok &= np.all(np.abs(as_) <= amax, axis=(1, 2)) & np.all(np.abs(a_end) <= amax, axis=1)
    keep = np.flatnonzero(ok)
    if keep.size < ok.size:  # the speeds of the pieces still ok only (row by row: the same)
        cap = np.asarray(speed_cap, dtype=float)
        cap = cap[keep] if cap.ndim else cap
        ok[keep] = _speeds_ok(vs[keep], as_[keep], js[keep], dur[keep], vmax, cap)
        return ok
    return ok & _speeds_ok(vs, as_, js, dur, vmax, speed_cap)


def phase_speeds(
    v: np.ndarray, a: np.ndarray, j: np.ndarray, dur: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray]:
    """Constant-jerk phases starting at velocity ``v``, acceleration ``a`` with jerk ``j``
    for ``dur`` [s] (arrays that broadcast): their velocity where the acceleration passes zero
    inside the phase (its start, or its end, where it does not) and at their end. With the
    start, these bound the velocity over the phase (it is quadratic in time)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(j != 0.0, -a / j, 0.0)
    tau = np.clip(tau, 0.0, dur)
    return v + tau * (a + 0.5 * tau * j), v + dur * (a + 0.5 * dur * j)


def _speeds_ok(
    vs: np.ndarray,
    as_: np.ndarray,
    js: np.ndarray,
    dur: np.ndarray,
    vmax: np.ndarray,
    speed_cap: np.ndarray | float,
) -> np.ndarray:
    """(n,) True where the pieces keep the axes' speed limits ``vmax`` and the path-speed cap
    (see :func:`piece_limits_ok`)."""
    h = (dur / 3.0)[:, None, None]
    v_stat, v_end = phase_speeds(vs, as_, js, h)
    ok = np.all(np.abs(v_stat) <= vmax, axis=(1, 2)) & np.all(np.abs(v_end) <= vmax, axis=(1, 2))
    cap2 = (np.asarray(speed_cap, dtype=float) ** 2).reshape(-1, 1)
    sampled = np.zeros(js.shape[:2])  # (n, 3 phases): the largest |v|^2 of the 5 points
    for f in np.linspace(0.0, 1.0, 5):
        tf = f * h
        vel = vs + tf * (as_ + 0.5 * tf * js)
        sampled = np.maximum(sampled, np.einsum("nkd,nkd->nk", vel, vel))
    ok &= np.all(sampled <= cap2, axis=1)
    near = ok[:, None] & (sampled + _between_samples(vs, as_, js, h) > cap2)
    if near.any():
        rows, phase = np.nonzero(near)
        exact = max_speed_squared(vs[rows, phase], as_[rows, phase], js[rows, phase], h[rows, 0, 0])
        cap2_rows = np.broadcast_to(cap2, near.shape)[rows, phase]
        ok[rows[exact > cap2_rows]] = False
    return ok


def _between_samples(vs, as_, js, h) -> np.ndarray:
    """(n, 3) a bound on how far |v|^2 [mm^2/s^2] rises above the larger of two neighbouring
    samples of :func:`piece_limits_ok` (h/4 apart) within a phase: d^2/8 max|f''| for
    f = |v|^2, f'' = 2 (|a|^2 + v . j), with |a| and |v| bounded over the phase per axis."""
    hh = h[..., 0]
    a_max = np.maximum(np.abs(as_), np.abs(as_ + h * js))
    v_max = np.abs(vs) + h * (np.abs(as_) + 0.5 * h * np.abs(js))
    f2 = 2.0 * ((a_max * a_max).sum(axis=2) + (v_max * np.abs(js)).sum(axis=2))
    return (hh / 4.0) ** 2 / 8.0 * f2 * (1.0 + 1e-9)


def jerk3_points(ps, vs, as_, js, dur: float, per_phase: int = 8) -> np.ndarray:
    """Positions (3 * per_phase + 1, 3) along one piece (phases as returned by :func:`jerk3`)."""
    h = dur / 3.0
    tau = np.linspace(0.0, h, per_phase, endpoint=False)[None, :, None]
    p, v, a, j = (x[:, None, :] for x in (ps, vs, as_, js))
    pts = p + tau * (v + tau * (0.5 * a + tau * j / 6.0))
    last = ps[2] + h * (vs[2] + h * (0.5 * as_[2] + h * js[2] / 6.0))
    return np.vstack([pts.reshape(-1, 3), last])
