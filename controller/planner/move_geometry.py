"""Per-move path geometry for the planner: vertices, end tangents and curvatures, 1-D limits,
and the junctions between consecutive moves (speed caps and the direction of the state there).

Curvature vectors k = d2p/ds2 [1/mm] (|k| = 1/R, pointing to the centre); tangents are unit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.arcs import (
    arc_derivatives,
    arc_frame,
    arc_points,
    frenet_many,
    is_spiral,
    spiral_fraction_at,
    spiral_length_at,
    spiral_speed_rate,
)
from gantry_sim.controller.config import Limits, Segmentation
from gantry_sim.controller.moves import Arc, Linear, PathMove, Rapid, Spline, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.arc_batch import (
    arc_end_derivatives_many,
    arc_overrun_mm,
)
from gantry_sim.controller.planner.limits import (
    BlockLimits,
    FollowGeometry,
    arc_limits_many,
    path_feed_mm_per_s,
)
from gantry_sim.controller.planner.segment import chords_of_sweep, segment_arc, segment_arcs
from gantry_sim.controller.planner.spline_geometry import (
    curvature_bounds,
    spline_derivatives,
    spline_deviation,
    spline_points,
)
from gantry_sim.controller.planner.transition_geometry import (
    transition_deviation,
    transition_end_frames_many,
    transition_vertices_many,
)

#: The closed-form arc pieces (:mod:`gantry_sim.controller.planner.jerk3`) overshoot the vertex speed by about
#: 5e-4 * phi^4 (phi: chord sweep [rad]); the arc's speed cap keeps twice that below the feed.
FEED_MARGIN_PER_PHI4 = 1e-3
#: And a relative margin for what the pieces between exact helix states overshoot besides
#: (measured up to 1.4e-6 on helices and S-chains, and 1.0e-5 on a blend arc of a CAM polyline
#: next to its curvature jumps, which passed the feed by 3.6e-8 of it at 1e-5; at 1e-9 those
#: pieces broke the feed, went to Ruckig, and Ruckig's minimum-duration pieces left the path by
#: up to 0.93 mm).
FEED_MARGIN_REL = 5e-5


@dataclass(frozen=True, slots=True)
class MoveGeometry:
    """What the planner needs to know about one move (a straight one; arcs:
    :class:`ArcGeometry`)."""

    move: PathMove
    vertices: np.ndarray  # (k, 3) [mm], read-only
    length_mm: float
    tangent_in: np.ndarray  # unit tangent at the start
    tangent_out: np.ndarray  # unit tangent at the end
    curv_in: np.ndarray  # curvature vector at the start [1/mm]
    curv_out: np.ndarray  # curvature vector at the end [1/mm]
    limits: BlockLimits
    feed_mm_per_s: float  # programmed path speed after override (inf for rapids) [mm/s]

    @property
    def is_arc(self) -> bool:
        return isinstance(self, ArcGeometry)

    @property
    def start(self) -> np.ndarray:
        return self.vertices[0]


@dataclass(frozen=True, slots=True)
class ArcGeometry(MoveGeometry):
    """A curve's :class:`MoveGeometry` (an arc, a helix, a spline or a G2 transition), with its
    exact geometry.

    The curve is parametrised by ``u`` in [0, 1]: an arc's sweep fraction, a spline's
    arc-length fraction (both proportional to arc length; :mod:`.spline_geometry`), a
    transition's Bezier parameter (:mod:`.transition_geometry`)."""

    move: Arc | Spline | Transition
    u: np.ndarray  # the vertices' parameters (sweep, arc-length fractions, Bezier parameter)
    #: What bounds following it exactly (its limits, :func:`~gantry_sim.controller.planner.speedup.follow_ok`).
    follow: FollowGeometry
    #: u is not the arc-length fraction: an arc whose radius changes
    #: (:func:`~gantry_sim.controller.arcs.is_spiral`), or a transition.
    uneven: bool = False
    #: The longest step of u between the vertices next to a stop (1: the end chord itself). An
    #: arc segmented "fixed" (Marlin's 1 mm chords) takes the "chord" method's steps there:
    #: a closed-form piece from rest across a long chord leaves the arc (0.29 um at 1 um
    #: chord tolerance on a Bambu print's R13 arc at M204 S500, against 0.02 on chord steps).
    stop_step_u: float = 1.0
    #: The chord tolerance its vertices were laid within [mm] (the machine's, but a G64 blend
    #: arc's own: :func:`~gantry_sim.controller.planner.prepare.blend_chord_tolerances`; 0: a
    #: transition's). Its pieces between vertices stay within
    #: :data:`~gantry_sim.controller.planner.pieces.JUNCTION_DEVIATION_MAX` of it.
    chord_tolerance_mm: float = 0.0

    def points(self, u: np.ndarray) -> np.ndarray:
        """Points on the curve at fractions ``u`` (u = 0 and 1: start and end exactly)."""
        if isinstance(self.move, Spline):
            return spline_points(self.move, u)
        if isinstance(self.move, Transition):
            return self.move.curve.points(u)
        pts = arc_points(self.move, u)
        pts[u == 0.0] = self.move.start
        return pts

    def deviation(self, q: np.ndarray, u_hint: float) -> float:
        """Largest distance [mm] of points ``q`` (k, 3) near sweep fraction ``u_hint`` from the
        arc: in-plane radius error and normal-axis error at the point's own polar angle (an
        upper bound on the distance to the curve; a spline: the distance to the nearest point
        found by Newton steps from the nearest of samples within two chords of ``u_hint``; a
        transition likewise)."""
        window = 2.0 / max(self.u.size - 1, 1)
        if isinstance(self.move, Spline):
            return spline_deviation(self.move, q, u_hint, window)
        if isinstance(self.move, Transition):
            return transition_deviation(self.move, q, u_hint, window)
        i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(self.move)
        c = self.move.center
        th = np.arctan2(q[:, i2] - c[i2], q[:, i1] - c[i1])
        th_hint = theta0 + sigma * self.move.angle * u_hint
        th = th - 2.0 * np.pi * np.round((th - th_hint) / (2.0 * np.pi))
        u = sigma * (th - theta0) / self.move.angle
        d_r = np.hypot(q[:, i1] - c[i1], q[:, i2] - c[i2]) - (r0 + (r1 - r0) * u)
        d_n = q[:, n] - (h0 + (h1 - h0) * u)
        d_t = arc_overrun_mm(u, self.move.angle, r0, r1, h1 - h0)
        return float(np.max(np.hypot(np.hypot(d_r, d_n), d_t)))

    def derivatives(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dp/du and d2p/du2 (k, 3) [mm] at fractions ``u``."""
        if isinstance(self.move, Spline):
            return spline_derivatives(self.move, u)
        if isinstance(self.move, Transition):
            _, d1, d2 = self.move.curve.derivatives(np.asarray(u, dtype=float), 2)
            return d1, d2
        return arc_derivatives(self.move, u)

    def s_at(self, u: np.ndarray) -> np.ndarray:
        """Path length [mm] from the start to parameters ``u``."""
        if isinstance(self.move, Transition):
            return self.move.curve.s_of_t(u)
        if self.uneven:
            return spiral_length_at(self.move, u)  # type: ignore[arg-type]
        return u * self.length_mm

    def u_at(self, s_mm: np.ndarray) -> np.ndarray:
        """The parameters where the path has run ``s_mm`` [mm] (inverse of :meth:`s_at`)."""
        if isinstance(self.move, Transition):
            return self.move.curve.t_of_s(s_mm)
        if self.uneven:
            return spiral_fraction_at(self.move, s_mm, self.length_mm)  # type: ignore[arg-type]
        return s_mm / self.length_mm

    def speed_rate(self, u: np.ndarray) -> np.ndarray:
        """d|dp/du|/du [mm] at parameters ``u``: 0 where u is proportional to arc length."""
        if isinstance(self.move, Transition):
            return self.move.curve.speed_rate(u)
        if self.uneven:
            return spiral_speed_rate(self.move, u)  # type: ignore[arg-type]
        return np.zeros(np.shape(u))


#: The general name: arcs, helices, splines and transitions are all curves to the planner.
CurveGeometry = ArcGeometry


def move_geometry(
    move: PathMove, limits: Limits, seg: Segmentation, feed_scale: float
) -> MoveGeometry:
    """Vertices (arcs: chords by ``seg``), end tangents/curvatures and 1-D limits of ``move``
    (feed times ``feed_scale``) on a machine of per-axis ``limits``."""
    return move_geometries([move], limits, seg, feed_scale)[0]


def move_geometries(
    moves: Sequence[PathMove], limits: Limits, seg: Segmentation, feed_scale: float
) -> list[MoveGeometry]:
    """:func:`move_geometry` of each move; the curves' limits in one batch
    (:func:`~gantry_sim.controller.planner.limits.arc_limits_many`)."""
    arcs = [m for m in moves if isinstance(m, Arc)]
    d1, d2 = arc_end_derivatives_many(arcs)
    tangents, curvatures = frenet_many(d1.reshape(-1, 3), d2.reshape(-1, 3))
    speeds = np.sqrt(np.vecdot(d1, d1)).tolist()  # |dp/du| at both ends, as norm() gives it
    ends = {
        id(arc): _ArcEnds(tangents[2 * i : 2 * i + 2], curvatures[2 * i : 2 * i + 2], *speeds[i])
        for i, arc in enumerate(arcs)
    }
    chords = dict(
        zip(
            map(id, arcs),
            segment_arcs(arcs, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm),
            strict=True,
        )
    )
    steps = [m for m in moves if isinstance(m, Transition)]
    steps_chords = transition_vertices_many(
        steps, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm
    )
    frames = transition_end_frames_many(steps)
    verts = dict(zip(map(id, steps), zip(steps_chords, frames, strict=True), strict=True))
    lines = [m for m in moves if isinstance(m, Linear | Rapid)]
    straight = dict(
        zip(map(id, lines), _straight_geometries(lines, limits, feed_scale), strict=True)
    )
    geoms = [
        _transition_geometry(m, feed_scale, *verts[id(m)])
        if isinstance(m, Transition)
        else _spline_geometry(m, seg, feed_scale)
        if isinstance(m, Spline)
        else _arc_geometry(m, seg, feed_scale, ends[id(m)], chords[id(m)])
        if isinstance(m, Arc)
        else straight[id(m)]
        for m in moves
    ]
    for even in (False, True):  # arcs and splines; transitions (limits._arc_batch)
        at = [
            i
            for i, g in enumerate(geoms)
            if isinstance(g, ArcGeometry) and isinstance(g.move, Transition) == even
        ]
        curves = [g for g in (geoms[i] for i in at) if isinstance(g, ArcGeometry)]
        lengths = [g.length_mm for g in curves]
        blocks = arc_limits_many([g.follow for g in curves], lengths, limits, even=even)
        for g, block in zip(curves, blocks, strict=True):
            # made here and not yet handed out: set in place (a replace() each was a tenth
            # of preparing a polyline's window)
            object.__setattr__(g, "limits", block)
    return geoms


#: Placeholder limits of a curve until :func:`move_geometries` sets them.
_UNSET = BlockLimits(0.0, 0.0, 0.0, 0.0)


#: A straight move's curvature: none (one read-only array for all of them).
_NO_CURVATURE = np.zeros(3)
_NO_CURVATURE.setflags(write=False)


def _straight_geometries(
    moves: Sequence[Linear | Rapid], limits: Limits, feed_scale: float
) -> list[MoveGeometry]:
    """Each straight move's geometry (its two vertices, length, unit tangent, no curvature,
    :func:`~gantry_sim.controller.planner.limits.straight_limits` and feed [mm/s]), all at
    once with the numbers of the move taken alone: the lengths are the square roots of
    ``np.vecdot`` (which sums as :func:`~gantry_sim.controller.vector.norm`'s dot does), the
    limits IEEE quotients and minima, taken per axis over all moves."""
    if not moves:
        return []
    verts = np.array([(m.start, m.end) for m in moves], dtype=float).reshape(-1, 2, 3)
    verts.setflags(write=False)
    step = verts[:, 1] - verts[:, 0]
    length = np.sqrt(np.vecdot(step, step))
    moving = length > 0
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        tangent = np.where(moving[:, None], step / length[:, None], (1.0, 0.0, 0.0))
        share = np.abs(tangent)
        cap, acc, jerk = (
            np.where(share != 0.0, np.asarray(per_axis, dtype=float) / share, math.inf).min(axis=1)
            for per_axis in limits.per_axis()
        )
    feed = [
        math.inf if isinstance(m, Rapid) else path_feed_mm_per_s(m.feed_mm_per_min, feed_scale)
        for m in moves
    ]
    cap = np.where(cap < feed, cap, feed)  # min(feed, cap)
    zero = _NO_CURVATURE
    return [
        MoveGeometry(m, v, d, t, t, zero, zero, BlockLimits(d, c, a, j), f)
        for m, v, d, t, c, a, j, f in zip(
            moves,
            verts,
            length.tolist(),
            tangent,
            cap.tolist(),
            acc.tolist(),
            jerk.tolist(),
            feed,
            strict=True,
        )
    ]


class _ArcEnds(NamedTuple):
    """An arc's unit tangents and curvature vectors [1/mm] at its start and end (rows), and
    |dp/du| [mm] there (:func:`~gantry_sim.controller.arcs.frenet` of its end derivatives)."""

    tangents: np.ndarray
    curvatures: np.ndarray
    speed_in_mm: float
    speed_out_mm: float


@functools.cache
def _unit_steps(n: int) -> np.ndarray:
    """The parameters of ``n`` equal chords, 0 .. 1 ((n + 1,), read-only: one array shared by
    every arc of ``n`` chords)."""
    u = np.arange(n + 1) / n
    u.setflags(write=False)
    return u


def _arc_geometry(
    move: Arc, seg: Segmentation, feed_scale: float, ends: _ArcEnds, verts: np.ndarray
) -> ArcGeometry:
    """An arc's geometry, its limits left :data:`_UNSET`, from its ``ends`` and its chord
    ``verts`` (made for all arcs at once by :func:`move_geometries`)."""
    n = len(verts) - 1
    u = _unit_steps(n)
    (t_in, t_out), (k_in, k_out), speed_in, speed_out = ends
    frame = arc_frame(move)
    r_max = max(frame.r0_mm, frame.r1_mm)
    speed_u = min(speed_in, speed_out)  # |dp/du| [mm]
    spiral = is_spiral(move)
    if spiral:
        length = float(spiral_length_at(move, np.array([1.0]))[0])
    else:
        length = 0.5 * (speed_in + speed_out)
    ang = move.angle
    curvature = r_max * ang * ang / speed_u**2
    dcurv = r_max * ang**3 / speed_u**3
    rise = abs(frame.h1_mm - frame.h0_mm)
    sin_pitch = rise / speed_u
    # a helical spiral: h is linear in u and |dp/du| is not, so h'' along the path is
    # -rise dr r ang^2 / |dp/du|^4 (dr: the change of radius), bounded at r_max and speed_u
    normal_curvature = rise * abs(frame.r1_mm - frame.r0_mm) * r_max * ang * ang / speed_u**4
    # and its in-plane share is largest where |dp/du| is (its larger radius end)
    plane_share = None
    if spiral and rise > 0:
        plane_share = math.sqrt(max(0.0, 1.0 - (rise / max(speed_in, speed_out)) ** 2))
    feed = path_feed_mm_per_s(move.feed_mm_per_min, feed_scale)
    follow = FollowGeometry(
        PLANE_AXES[move.plane],
        min(sin_pitch, 1.0),
        curvature,
        dcurv,
        feed * (1.0 - FEED_MARGIN_PER_PHI4 * (ang / n) ** 4 - FEED_MARGIN_REL),
        normal_curvature,
        plane_share,
    )
    tol, step_mm = seg.chord_tolerance_mm, seg.segment_length_mm
    stop_step = 1.0
    if seg.method == "fixed":
        stop_step = 1.0 / max(chords_of_sweep(move, r_max, "chord", tol, step_mm), n)
    frames = (t_in, t_out, k_in, k_out)
    return ArcGeometry(
        move, verts, length, *frames, _UNSET, feed, u, follow, spiral, stop_step, tol
    )


def _spline_geometry(move: Spline, seg: Segmentation, feed_scale: float) -> ArcGeometry:
    """A spline's geometry: equal arc-length chords, exact end frames, curvature bounds."""
    verts = segment_arc(move, seg.method, seg.chord_tolerance_mm, seg.segment_length_mm)
    n = len(verts) - 1
    u = np.arange(n + 1) / n
    curve = move.curve
    t_in, k_in, t_out, k_out = curve.end_frames
    length = curve.length_mm
    curvature, dcurv = curvature_bounds(move, n)
    feed = path_feed_mm_per_s(move.feed_mm_per_min, feed_scale)
    sweep = curvature * length / n  # the most a chord turns [rad]
    follow = FollowGeometry(
        (0, 1, 2),
        0.0,
        curvature,
        dcurv,
        feed * (1.0 - FEED_MARGIN_PER_PHI4 * min(sweep, 1.0) ** 4 - FEED_MARGIN_REL),
    )
    frames = (t_in, t_out, k_in, k_out)
    tol = seg.chord_tolerance_mm
    return ArcGeometry(
        move, verts, length, *frames, _UNSET, feed, u, follow, chord_tolerance_mm=tol
    )


def _transition_geometry(
    move: Transition, feed_scale: float, verts: np.ndarray, frames: np.ndarray
) -> ArcGeometry:
    """A G2 transition's geometry: its chord ``verts`` (equal steps of its parameter), its
    end ``frames`` (T_start, k_start, T_end, k_end), the curve's curvature bounds, in its plane
    (:mod:`.transition_geometry`)."""
    n = len(verts) - 1
    u = np.arange(n + 1) / n
    curve = move.curve
    t_in, k_in, t_out, k_out = frames
    length = curve.length_mm
    curvature, dcurv = curve.bounds
    feed = path_feed_mm_per_s(move.feed_mm_per_min, feed_scale)
    sweep = curvature * curve.speed_max / n  # the most a chord turns [rad]
    follow = FollowGeometry(
        PLANE_AXES[move.plane],
        0.0,
        curvature,
        dcurv,
        feed * (1.0 - FEED_MARGIN_PER_PHI4 * min(sweep, 1.0) ** 4 - FEED_MARGIN_REL),
    )
    return ArcGeometry(
        move, verts, length, t_in, t_out, k_in, k_out, _UNSET, feed, u, follow, uneven=True
    )


def path_acc_limits(limits: Limits, path_acc_mm_per_s2: float) -> Limits:
    """``limits`` with every axis' acceleration capped at Marlin's M204 path acceleration
    [mm/s^2] (inf: ``limits`` themselves): what a curve's own limits are chosen with under it
    (a straight move's path acceleration is capped directly: :func:`capped_geometries`)."""
    if not path_acc_mm_per_s2 < math.inf:
        return limits
    ax, ay, az = (min(a, path_acc_mm_per_s2) for a in limits.max_acceleration_mm_per_s2)
    return replace(limits, max_acceleration_mm_per_s2=(ax, ay, az))


def capped_geometries(
    geoms: list[MoveGeometry], path_acc_mm_per_s2: Sequence[float], limits: Limits
) -> list[MoveGeometry]:
    """``geoms`` with their limits under Marlin's M204 path acceleration [mm/s^2] per move (inf:
    none): a straight move's acceleration along the path capped at it (as Marlin's block
    acceleration), a curve's limits chosen again with every axis' acceleration capped at it
    (its speed from curvature then keeps the centripetal acceleration within it, as Marlin's
    segments and junction deviation do)."""
    out = list(geoms)
    curves: dict[tuple[float, bool], list[int]] = {}
    for i, (g, acc) in enumerate(zip(geoms, path_acc_mm_per_s2, strict=True)):
        if not acc < math.inf:
            continue
        if isinstance(g, ArcGeometry):
            curves.setdefault((acc, isinstance(g.move, Transition)), []).append(i)
        elif acc < g.limits.acc_mm_per_s2:
            out[i] = replace(g, limits=replace(g.limits, acc_mm_per_s2=acc))
    for (acc, even), at in curves.items():
        arcs = [g for g in (geoms[i] for i in at) if isinstance(g, ArcGeometry)]
        lim = path_acc_limits(limits, acc)
        blocks = arc_limits_many(
            [g.follow for g in arcs], [g.length_mm for g in arcs], lim, even=even
        )
        for i, g, block in zip(at, arcs, blocks, strict=True):
            out[i] = replace(g, limits=block)
    return out


def limits_for_junctions(
    geoms: list[MoveGeometry],
    caps: np.ndarray,
    limits: Limits,
    path_acc_mm_per_s2: Sequence[float] | None = None,
) -> list[MoveGeometry]:
    """``geoms`` with each arc's limits chosen for its junction caps ``caps`` [mm/s] (and under
    its M204 path acceleration ``path_acc_mm_per_s2`` [mm/s^2] per move: :func:`path_acc_limits`) (see
    :func:`gantry_sim.controller.planner.limits.arc_limits`: inside a tangent chain an arc need
    not ramp from rest, so it may cruise closer to its curvature cap). A transition keeps the
    limits :func:`move_geometries` chose (its junctions never bind: limits._arc_batch), and
    an arc beside one takes its speed cap as that junction's: a junction that does not bind
    is still passed no faster than the transition (an arc between two slower transitions
    chose the cruise limits of an unbounded junction, 1 % of its jerk, and the chain could not
    ramp)."""
    moving = [
        b
        for b, g in enumerate(geoms)
        if isinstance(g, ArcGeometry)
        and not isinstance(g.move, Transition)
        and (caps[b] > 0 or caps[b + 1] > 0)
    ]
    arcs = [g for g in (geoms[b] for b in moving) if isinstance(g, ArcGeometry)]

    def end(b: int) -> float:
        """Junction ``b``'s speed as far as known: its cap, a transition's cap beside it."""
        cap = float(caps[b])
        for k in (b - 1, b):
            if 0 <= k < len(geoms) and isinstance(geoms[k].move, Transition):
                cap = min(cap, geoms[k].limits.cap_mm_per_s)
        return min(cap, 1e300)

    ends = [(end(b), end(b + 1)) for b in moving]
    groups: dict[float, list[int]] = {}  # by M204 path acceleration: the arcs' places in moving
    for k, b in enumerate(moving):
        acc = math.inf if path_acc_mm_per_s2 is None else path_acc_mm_per_s2[b]
        groups.setdefault(acc, []).append(k)
    out = list(geoms)
    for acc, ks in groups.items():
        blocks = arc_limits_many(
            [arcs[k].follow for k in ks],
            [arcs[k].length_mm for k in ks],
            path_acc_limits(limits, acc),
            [ends[k] for k in ks],
        )
        for k, block in zip(ks, blocks, strict=True):
            out[moving[k]] = replace(arcs[k], limits=block)
    return out
