"""Junctions between consecutive moves: their speed caps and the reference's state there.

* A corner (tangent direction turns by more than :data:`CORNER_ANGLE_RAD`, or by more than
  :data:`COLLINEAR_ANGLE_RAD` between two straight moves, which are followed exactly) is an exact
  stop, as are the junctions between a rapid and a feed move (LinuxCNC 2.9 stops there) and the
  program's start and end; two rapids in line are passed through.
* A tangent junction keeps its speed, except that a jump of the velocity direction (a kink of
  angle d: velocity jump v d) or of the curvature (acceleration jump v^2 |k1 - k2|, e.g. line ->
  arc, arc -> arc of another radius) cannot be followed exactly with finite jerk: the pieces
  smooth it within the neighbouring chord, and the junction speed is capped so that the
  smoothing stays within a deviation budget e [mm] (:func:`junction_cap`, :func:`junction_caps`).
* The piece from the junction state to the neighbouring arc's first (or last) chord vertex must
  absorb the jump within one chord: :func:`feasible_junction_caps` lowers each moving junction's
  cap (by bisection, all junctions at once) until those two pieces, at constant speed, keep every
  axis' limits and the feed (:func:`gantry_sim.controller.planner.jerk3.piece_limits_ok`). The
  planner still checks the real pieces afterwards and lowers a cap further when needed; this only
  saves re-planning rounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.arcs import frenet_many
from gantry_sim.controller.config import Limits
from gantry_sim.controller.moves import Arc, Rapid, Transition
from gantry_sim.controller.planes import Vec3
from gantry_sim.controller.planner.arc_batch import arc_derivatives_many
from gantry_sim.controller.planner.jerk3 import jerk3_pairs, piece_limits_ok
from gantry_sim.controller.planner.move_geometry import ArcGeometry, MoveGeometry
from gantry_sim.controller.planner.transition_geometry import (
    transition_derivatives_many,
    transition_lengths_many,
)
from gantry_sim.controller.vector import norm

#: Tangent-direction change above which a junction involving an arc is a corner [rad] (1 degree).
CORNER_ANGLE_RAD = math.radians(1.0)
#: Two straight moves are followed exactly: they keep speed only when collinear within this [rad].
COLLINEAR_ANGLE_RAD = 1e-6
#: The smoothing of a junction's jump must take at most 1/CHORD_FIT of the adjacent chord's time
#: (a first guess; the planner then checks the pieces themselves).
CHORD_FIT = 4.0
#: CHORD_FIT next to a G64 blend arc, whose budget comes from the blend tolerance: a looser
#: first guess (the pieces next to the junction are checked against that budget anyway).
CHORD_FIT_BLEND = 1.5
#: Share of the chord tolerance that the smoothing of a junction's velocity/acceleration jump may
#: use (see :func:`junction_cap`).
JUNCTION_DEVIATION_SHARE = 0.1
#: Bisection steps on the junction speed (the cap is found to within 2^-10 of its start value).
STEPS = 10
#: Pieces checked per batch in :func:`feasible_junction_caps`: its arrays take about 3 KB a
#: piece, so the whole program at once was a transient of hundreds of MB at 100,000 blocks.
BATCH_PIECES = 4096


class EndState(NamedTuple):
    """The reference's velocity [mm/s] and acceleration [mm/s^2] (3,) where a move starts or
    ends."""

    vel_mm_per_s: np.ndarray
    acc_mm_per_s2: np.ndarray

    @property
    def moving(self) -> bool:
        return self.vel_mm_per_s.tolist() != [0.0, 0.0, 0.0]  # NaN counts (as np.any's)


@dataclass(frozen=True, eq=False, slots=True)
class JunctionState:
    """The reference's state at a junction per unit speed: passing at speed v it has velocity
    v * ``direction`` and acceleration v^2 * ``curvature_per_mm`` plus its tangential acceleration along
    ``direction`` (0 where a move's own profile starts or ends).

    Attributes:
        direction: unit velocity direction (3,) (zeros at the start of an empty program).
        curvature_per_mm: curvature vector (3,) [1/mm].
    """

    direction: np.ndarray
    curvature_per_mm: np.ndarray

    def at(self, speed_mm_per_s: float, acc_t_mm_per_s2: float = 0.0) -> EndState:
        """The state when passed at ``speed_mm_per_s`` with the tangential acceleration
        ``acc_t_mm_per_s2`` (non-zero only inside a chain, see
        :mod:`~gantry_sim.controller.planner.chains`)."""
        acc = self.curvature_per_mm * speed_mm_per_s**2 + self.direction * acc_t_mm_per_s2
        return EndState(self.direction * speed_mm_per_s, acc)


def junction_cap(
    kink_rad: float,
    curvature_jump_per_mm: float,
    deviation_mm: float,
    jerk_mm_per_s3: float,
    chord_mm: float,
    chord_fit: float = CHORD_FIT,
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
            (j * chord_mm**2 / (4.0 * chord_fit**2 * kink_rad)) ** (1.0 / 3.0),
        )
    if curvature_jump_per_mm > 0:
        da = (6.0 * e * j**2) ** (1.0 / 3.0)
        cap = min(
            cap,
            math.sqrt(da / curvature_jump_per_mm),
            (j * chord_mm / (chord_fit * curvature_jump_per_mm)) ** (1.0 / 3.0),
        )
    return cap


def junction_caps(
    geoms: list[MoveGeometry],
    limits: Limits,
    chord_tolerance_mm: float,
    smoothing_mm: list[float] | None = None,
) -> tuple[np.ndarray, list[JunctionState]]:
    """Speed caps and states at the junctions of consecutive moves (the smoothing of a jump may
    use :data:`JUNCTION_DEVIATION_SHARE` of ``chord_tolerance_mm``, or next to a G64 blend arc
    its ``smoothing_mm`` [mm] per move, when larger).

    Returns:
        caps: (len(geoms) + 1,) [mm/s]; 0 at the program's start and end, at corners, and
            between a rapid and a feed move (two rapids in line are passed through).
        states: per junction, the :class:`JunctionState`. Next to a straight move, its own
            direction and no curvature (straight moves are followed exactly); between two arcs,
            the mean of both sides.
    """
    n = len(geoms)
    caps = np.zeros(n + 1)
    zero = np.zeros(3)
    states = [JunctionState(g.tangent_in, zero) for g in geoms] + [
        JunctionState(geoms[-1].tangent_out if n else zero, zero)
    ]
    jerk = float(min(limits.max_jerk_mm_per_s3))
    dev = JUNCTION_DEVIATION_SHARE * chord_tolerance_mm
    # every junction's kink and curvature jump at once (np.vecdot sums as np.dot does: the
    # numbers of the junction-by-junction form)
    t_out = np.array([g.tangent_out for g in geoms[:-1]], dtype=float).reshape(-1, 3)
    t_in = np.array([g.tangent_in for g in geoms[1:]], dtype=float).reshape(-1, 3)
    kinks = [math.acos(c) for c in np.clip(np.vecdot(t_out, t_in), -1.0, 1.0).tolist()]
    for b in range(1, n):
        g0, g1 = geoms[b - 1], geoms[b]
        rapids = isinstance(g0.move, Rapid), isinstance(g1.move, Rapid)
        kink = kinks[b - 1]
        if any(rapids):  # a rapid and a feed move: a stop, as LinuxCNC 2.9 makes it; two
            # rapids in line are passed through (they may overlap at a corner: stop_overlap)
            if all(rapids) and kink <= COLLINEAR_ANGLE_RAD:
                caps[b] = math.inf
                states[b] = JunctionState(g1.tangent_in, zero)
            continue
        if not (g0.is_arc or g1.is_arc):
            if kink <= COLLINEAR_ANGLE_RAD:
                caps[b] = math.inf
                states[b] = JunctionState(g1.tangent_in, zero)
            continue
        if kink > CORNER_ANGLE_RAD:
            continue
        if g0.is_arc and g1.is_arc:
            d = g0.tangent_out + g1.tangent_in
            states[b] = JunctionState(d / norm(d), 0.5 * (g0.curv_out + g1.curv_in))
        else:
            straight = g1 if g0.is_arc else g0
            states[b] = JunctionState(straight.tangent_in, zero)
        own = [smoothing_mm[i] for i in (b - 1, b)] if smoothing_mm else []
        if own and min(own) > dev:  # both sides in G64: its tolerance is the budget
            caps[b] = smoothing_cap(g0, g1, kink, min(own), jerk, CHORD_FIT_BLEND)
        else:
            caps[b] = smoothing_cap(g0, g1, kink, dev, jerk, CHORD_FIT)
    return caps, states


def smoothing_cap(
    g0: MoveGeometry,
    g1: MoveGeometry,
    kink_rad: float,
    deviation_mm: float,
    jerk_mm_per_s3: float,
    chord_fit: float,
) -> float:
    """:func:`junction_cap` of the tangent junction between ``g0`` and ``g1`` (one of them
    curved) whose jumps are smoothed within ``deviation_mm`` and the chord next to it: the jump
    of curvature between them (halved between two curves: the junction state takes the mean,
    each side smooths half) and the shorter of their chords there."""
    jump = norm(g0.curv_out - g1.curv_in)
    if g0.is_arc and g1.is_arc:
        jump *= 0.5
    chords = [norm(g0.vertices[-1] - g0.vertices[-2])] if g0.is_arc else []
    chords += [norm(g1.vertices[1] - g1.vertices[0])] if g1.is_arc else []
    return junction_cap(kink_rad, jump, deviation_mm, jerk_mm_per_s3, min(chords), chord_fit)


def _piece_ok(
    p0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    p1: np.ndarray,
    v1: np.ndarray,
    a1: np.ndarray,
    dur: np.ndarray,
    lim: tuple[Vec3, Vec3, Vec3],
    feed: np.ndarray,
) -> np.ndarray:
    """Vectorised: each row one piece (states (m, 3), dur (m,)); True where it keeps the
    per-axis limits ``lim`` and the path speeds ``feed`` [mm/s]."""
    _ps, vs, as_, js = jerk3_pairs(p0, v0, a0, p1, v1, a1, dur)
    return piece_limits_ok(vs, as_, js, dur, a1, *lim, feed)


def feasible_junction_caps(
    geoms: list[MoveGeometry],
    caps: np.ndarray,
    states: list[JunctionState],
    limits: Limits,
) -> np.ndarray:
    """Return ``caps`` lowered where the pieces next to a junction could not keep the
    per-axis ``limits`` or the feed."""
    per_axis = limits.per_axis()
    rows = []  # (junction, p0, t0, k0, p1, t1, k1, chord length along the path, feed, side)
    caps = caps.copy()
    sides = []  # (junction, arc, side) of every arc next to a moving junction
    for b in range(1, len(geoms)):
        caps[b] = min(caps[b], geoms[b - 1].limits.cap_mm_per_s, geoms[b].limits.cap_mm_per_s)
        if not caps[b] > 0.0:
            continue
        for g, side in ((geoms[b], "after"), (geoms[b - 1], "before")):
            if isinstance(g, ArcGeometry):
                sides.append((b, g, side))
    frames = _side_frames(sides)
    steps = [i for i, (_, g, _) in enumerate(sides) if isinstance(g.move, Transition)]
    reach = dict(zip(steps, _transition_reach([sides[i] for i in steps]), strict=True))
    for i, ((b, g, side), (t, k)) in enumerate(zip(sides, frames, strict=True)):
        d, kv = states[b].direction, states[b].curvature_per_mm
        u = g.u[1] if side == "after" else g.u[-2]
        pv = g.vertices[1] if side == "after" else g.vertices[-2]
        s = reach[i] if i in reach else (u if side == "after" else 1.0 - u) * g.length_mm
        if side == "after":
            rows.append((b, g.vertices[0], d, kv, pv, t, k, s, g.feed_mm_per_s))
        else:
            rows.append((b, pv, t, k, g.vertices[-1], d, kv, s, g.feed_mm_per_s))
    out = caps.copy()
    for first in range(0, len(rows), BATCH_PIECES):
        _lower_caps(rows[first : first + BATCH_PIECES], caps, out, per_axis)
    return out


def _lower_caps(
    rows: list[tuple], caps: np.ndarray, out: np.ndarray, per_axis: tuple[Vec3, Vec3, Vec3]
) -> None:
    """Lower ``out`` [mm/s] (in place) to the highest speed, found by bisection below
    ``caps``, at which each row's piece (see :func:`feasible_junction_caps`) keeps the
    limits."""
    jb = np.array([r[0] for r in rows])
    p0, t0, k0, p1, t1, k1 = (np.array([r[i] for r in rows]) for i in range(1, 7))
    length = np.array([r[7] for r in rows])
    feed = np.array([r[8] for r in rows])
    hi = caps[jb].copy()
    lo = np.zeros_like(hi)

    def ok_at(v):
        vv = v[:, None]
        return _piece_ok(
            p0, vv * t0, vv * vv * k0, p1, vv * t1, vv * vv * k1, length / v, per_axis, feed
        )

    good = ok_at(hi)
    if good.all():
        return
    idx = np.flatnonzero(~good)
    lo_i, hi_i = lo[idx], hi[idx]
    sub = _subset(idx, p0, t0, k0, p1, t1, k1, length, feed)
    for _ in range(STEPS):
        mid = 0.5 * (lo_i + hi_i)
        okm = _piece_ok(
            sub[0],
            mid[:, None] * sub[1],
            (mid * mid)[:, None] * sub[2],
            sub[3],
            mid[:, None] * sub[4],
            (mid * mid)[:, None] * sub[5],
            sub[6] / mid,
            per_axis,
            sub[7],
        )
        lo_i = np.where(okm, mid, lo_i)
        hi_i = np.where(okm, hi_i, mid)
    for j, v in zip(jb[idx], lo_i, strict=True):
        out[j] = min(out[j], v)


def _transition_reach(sides: list[tuple[int, ArcGeometry, str]]) -> list[float]:
    """Path length [mm] of each transition's chord next to the junction (its parameter is not
    its arc-length fraction), in one batch."""
    if not sides:
        return []
    moves = [m for m in (g.move for _, g, _ in sides) if isinstance(m, Transition)]
    us = [np.array([g.u[1] if side == "after" else g.u[-2]]) for _, g, side in sides]
    s = transition_lengths_many(moves, us)
    return [
        float(x) if side == "after" else g.length_mm - float(x)
        for x, (_, g, side) in zip(s, sides, strict=True)
    ]


def _subset(idx, *arrays):
    return tuple(a[idx] for a in arrays)


def _side_frames(sides: list[tuple[int, ArcGeometry, str]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Unit tangent and curvature vector at the vertex next to the junction of each (junction,
    arc, side): the arcs' derivatives in one batch, the transitions' in another, the splines'
    one by one."""
    us = [np.array([g.u[1] if side == "after" else g.u[-2]]) for _, g, side in sides]
    arcs = [i for i, (_, g, _) in enumerate(sides) if isinstance(g.move, Arc)]
    d1 = np.empty((len(sides), 3))
    d2 = np.empty((len(sides), 3))
    if arcs:
        moves = [m for m in (sides[i][1].move for i in arcs) if isinstance(m, Arc)]
        d1[arcs], d2[arcs] = arc_derivatives_many(moves, [us[i] for i in arcs])
    steps = [i for i, (_, g, _) in enumerate(sides) if isinstance(g.move, Transition)]
    if steps:
        curves = [m for m in (sides[i][1].move for i in steps) if isinstance(m, Transition)]
        d1[steps], d2[steps] = transition_derivatives_many(curves, [us[i] for i in steps])
    for i, (_, g, _) in enumerate(sides):
        if not isinstance(g.move, Arc | Transition):
            d1[i : i + 1], d2[i : i + 1] = g.derivatives(us[i])
    t, k = frenet_many(d1, d2)
    return list(zip(t, k, strict=True))
