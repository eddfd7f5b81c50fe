"""G64 blends of corners that involve an arc: line -> arc, arc -> line, arc -> arc.

A corner between two straight moves has a closed-form blend (:mod:`.blend`). Where one side is
an arc (in the corner's plane, no helix), the blend is still a circular arc tangent to both
moves: it leaves the first move ``s0`` mm before the corner and joins the second ``s1`` mm after
it, where the two tangent lines meet at equal distances from those points (the condition for a
circle tangent to both lines at both points). For a given ``s0`` that ``s1`` is found by the
secant method; ``s0`` is the largest (at most half of either move) whose blend stays within the
geometry budget of the corner, found by bisection. The deviation is measured, not assumed: the
largest distance of the cut-away parts of both moves from the blend circle.

Conventions: millimetres; an arc's sweep fraction u runs from 0 at its start to 1 at its end;
tangents are unit vectors in the direction of motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.arcs import arc_derivatives, arc_frame, arc_points
from gantry_sim.controller.moves import Arc, Linear
from gantry_sim.controller.planes import PLANE_AXES, Plane, plane_of
from gantry_sim.controller.planner.arc_batch import arc_end_derivatives_many
from gantry_sim.controller.planner.junctions import CHORD_FIT_BLEND
from gantry_sim.controller.planner.spaced import spaced

#: Bisection steps on the length cut from the first move, and secant steps on the second.
BISECTION_STEPS = 20
SECANT_STEPS = 40
#: The secant stops where the two tangent lengths differ by this share of the cut [1]; where
#: rounding stops it first (the gap no longer changes from one step to the next, or the steps
#: run out), a gap within GAP_ROUNDING_REL of the cut is taken (a blend whose end lies 1e-9 of
#: the cut off its circle: far below any tolerance; rejecting it turned about one corner search
#: in ten on a printed part's arcs into a smaller blend, by rounding luck).
GAP_REL = 1e-12
GAP_ROUNDING_REL = 1e-9
#: Samples of each cut-away part checked against the blend circle.
CHECK_SAMPLES = 17


@dataclass(frozen=True)
class CornerCut:
    """A blended corner: path length cut from the end of the first move and from the start of
    the second [mm], the blend arc, and its largest distance from the cut-away path [mm]."""

    before_mm: float
    after_mm: float
    arc: Arc
    deviation_mm: float


def in_plane(m: Linear | Arc, plane: Plane) -> bool:
    """Whether ``m`` lies in ``plane`` (an arc: in that plane, with no helix)."""
    n = PLANE_AXES[plane][2]
    if isinstance(m, Arc):
        return m.plane == plane and m.start[n] == m.end[n]
    return abs(m.end[n] - m.start[n]) <= 1e-12


_Pose = Callable[[float], tuple[list[float], list[float]]]


def _pose(m: Linear | Arc, from_end: bool) -> _Pose:
    """The function s -> (point, unit tangent) of ``m`` at path distance ``s`` [mm] from its
    end (or start), in plain floats: the corner search asks for one point at a time, hundreds
    of times a corner, where numpy's per-call overhead was most of the cost (the formulas of
    :func:`~gantry_sim.controller.arcs.arc_points` and ``arc_derivatives``)."""
    if isinstance(m, Linear):
        a, b = m.start, m.end
        length = math.dist(a, b)
        d = [(y - x) / length for x, y in zip(a, b, strict=True)]
        if from_end:
            return lambda s: ([y - dk * s for y, dk in zip(b, d, strict=True)], d)
        return lambda s: ([x + dk * s for x, dk in zip(a, d, strict=True)], d)
    i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(m)
    a_rad, dr, c, length, end = sigma * m.angle, r1 - r0, m.center, m.length_mm, m.end

    def at(s: float) -> tuple[list[float], list[float]]:
        u = 1.0 - s / length if from_end else s / length
        theta, r = theta0 + a_rad * u, r0 + dr * u
        cos_t, sin_t = math.cos(theta), math.sin(theta)
        p = [0.0, 0.0, 0.0]
        p[i1], p[i2], p[n] = c[i1] + r * cos_t, c[i2] + r * sin_t, h0 + (h1 - h0) * u
        d = [0.0, 0.0, 0.0]
        d[i1], d[i2], d[n] = dr * cos_t - r * a_rad * sin_t, dr * sin_t + r * a_rad * cos_t, h1 - h0
        norm = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        return (list(end) if u == 1.0 else p), [x / norm for x in d]

    return at


def _tangent_lengths(pa, ta, pb, tb, i1, i2) -> tuple[float, float] | None:
    """(lambda, mu) with pa + lambda ta = pb - mu tb in the plane, or None (parallel)."""
    det = ta[i1] * tb[i2] - tb[i1] * ta[i2]
    if abs(det) < 1e-15:
        return None
    r1, r2 = pb[i1] - pa[i1], pb[i2] - pa[i2]
    return (r1 * tb[i2] - tb[i1] * r2) / det, (ta[i1] * r2 - ta[i2] * r1) / det


def _cut(m0, m1, s0: float, s1_max: float, plane: Plane):
    """The blend leaving ``m0`` ``s0`` mm before the corner: (s1, pa, ta, pb, tb, lam), or
    None when no ``s1`` <= ``s1_max`` gives equal tangent lengths."""
    i1, i2, _ = PLANE_AXES[plane]
    pa, ta = _pose(m0, True)(s0)
    pose1 = _pose(m1, False)

    def gap(s1: float):
        pb, tb = pose1(s1)
        lm = _tangent_lengths(pa, ta, pb, tb, i1, i2)
        return (None, pb, tb, None) if lm is None else (lm[0] - lm[1], pb, tb, lm[0])

    scale = max(s0, 1e-9)
    x0, x1 = s0, min(1.1 * s0, s1_max)
    g0 = gap(x0)[0]
    g1, pb, tb, lam = gap(x1)
    for _ in range(SECANT_STEPS):
        if g0 is None or g1 is None or g1 == g0:
            break
        x2 = min(max(x1 - g1 * (x1 - x0) / (g1 - g0), 1e-12), s1_max)
        x0, g0 = x1, g1
        x1 = x2
        g1, pb, tb, lam = gap(x1)
        if g1 is not None and abs(g1) <= GAP_REL * scale:
            break
    # converged, or stopped at rounding (the secant's step no longer changes the gap)
    if g1 is None or abs(g1) > GAP_ROUNDING_REL * scale or lam is None or lam <= 0:
        return None
    return x1, np.array(pa), np.array(ta), np.array(pb), np.array(tb), lam


_Sampler = Callable[[float], np.ndarray]


def _sampler(m: Linear | Arc, from_end: bool) -> _Sampler:
    """The function s -> points (:data:`CHECK_SAMPLES`, 3) of ``m`` at the path distances
    ``np.linspace(0, s, CHECK_SAMPLES)`` [mm] from its end (or start), with what does not
    depend on s made once (a corner's search asks for about 40 of them)."""
    if isinstance(m, Linear):
        a, b = np.asarray(m.start, float), np.asarray(m.end, float)
        d = (b - a) / np.linalg.norm(b - a)
        if from_end:
            return lambda s: b - np.outer(spaced(s, CHECK_SAMPLES), d)
        return lambda s: a + np.outer(spaced(s, CHECK_SAMPLES), d)
    length = m.length_mm
    if from_end:
        return lambda s: arc_points(m, 1.0 - spaced(s, CHECK_SAMPLES) / length)
    return lambda s: arc_points(m, spaced(s, CHECK_SAMPLES) / length)


def _deviation(
    sample0: _Sampler, sample1: _Sampler, s0: float, s1: float, center, radius, plane
) -> float:
    """Largest distance of the cut-away parts of the two moves (``sample0`` of the first, from
    its end; ``sample1`` of the second, from its start) from the blend circle."""
    i1, i2, _ = PLANE_AXES[plane]
    q = np.vstack([sample0(s0), sample1(s1)])
    r = np.hypot(q[:, i1] - center[i1], q[:, i2] - center[i2])
    return float(np.max(np.abs(r - radius)))


def _blend(m0, m1, s0, s1_max, plane, samplers: tuple[_Sampler, _Sampler]):
    """The blend that leaves ``m0`` ``s0`` mm before the corner, or None: (s1 [mm], its start
    and end points, centre, radius [mm], sweep [rad], True when counter-clockwise, its largest
    distance from the cut-away path [mm]); ``samplers``: of ``m0`` from its end and ``m1``
    from its start (:func:`_sampler`)."""
    found = _cut(m0, m1, s0, s1_max, plane)
    if found is None:
        return None
    s1, pa, ta, pb, tb, lam = found
    i1, i2, n = PLANE_AXES[plane]
    cross = ta[i1] * tb[i2] - ta[i2] * tb[i1]
    phi = math.acos(float(np.clip(ta @ tb, -1.0, 1.0)))
    if phi <= 0.0:
        return None
    radius = lam / math.tan(0.5 * phi)
    normal = np.zeros(3)
    side = 1.0 if cross > 0 else -1.0  # the centre lies left of the motion on a ccw turn
    normal[i1], normal[i2] = -side * ta[i2], side * ta[i1]
    center = pa + radius * normal
    center[n] = pa[n]
    dev = _deviation(*samplers, s0, s1, center, radius, plane)
    return s1, pa, pb, center, radius, phi, cross > 0, dev


def corner_blend(
    m0: Linear | Arc, m1: Linear | Arc, budget_mm: float, plane: Plane
) -> CornerCut | None:
    """The blend of the corner where ``m0`` ends and ``m1`` starts (both in ``plane``): the
    largest cut (at most half of either move) whose blend stays within ``budget_mm`` of the
    path, or None when no blend fits (the corner stays an exact stop)."""
    s_max = 0.5 * min(m0.length_mm, m1.length_mm)
    s1_max = 0.5 * m1.length_mm
    best = None
    lo, hi = 0.0, s_max
    samplers = (_sampler(m0, True), _sampler(m1, False))
    top = _blend(m0, m1, hi, s1_max, plane, samplers)
    if top is not None and top[-1] <= budget_mm:
        best, lo = (hi, top), hi
    else:
        for _ in range(BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            got = _blend(m0, m1, mid, s1_max, plane, samplers)
            if got is not None and got[-1] <= budget_mm:
                best, lo = (mid, got), mid
            else:
                hi = mid
    if best is None:
        return None
    s0, (s1, pa, pb, center, _radius, phi, ccw, dev) = best
    i1, i2, _ = PLANE_AXES[plane]
    arc = Arc(
        line=m0.line,
        start=_v3(pa),
        end=_v3(pb),
        feed_mm_per_min=min(m0.feed_mm_per_min, m1.feed_mm_per_min),
        plane=plane,
        direction="ccw" if ccw else "cw",
        center=_v3(center),
        radius=math.hypot(pa[i1] - center[i1], pa[i2] - center[i2]),
        turns=1,
        angle=phi,
        path=m0.path,
    )
    return CornerCut(s0, s1, arc, dev)


def trimmed_arc(m: Arc, cut_start_mm: float, cut_end_mm: float) -> Arc:
    """``m`` without ``cut_start_mm`` of path at its start and ``cut_end_mm`` at its end."""
    if cut_start_mm <= 0 and cut_end_mm <= 0:
        return m
    length = m.length_mm
    u0, u1 = cut_start_mm / length, 1.0 - cut_end_mm / length
    start = m.start if u0 <= 0 else _v3(arc_points(m, u0)[0])
    end = m.end if u1 >= 1 else _v3(arc_points(m, u1)[0])
    i1, i2, _ = PLANE_AXES[m.plane]
    radius = math.hypot(start[i1] - m.center[i1], start[i2] - m.center[i2])
    return Arc(
        line=m.line,
        start=start,
        end=end,
        feed_mm_per_min=m.feed_mm_per_min,
        plane=m.plane,
        direction=m.direction,
        center=m.center,
        radius=radius,
        turns=m.turns,
        angle=m.angle * (u1 - u0),
        path=m.path,
    )


def blend_tangent_mm(deviation_mm: float, turn_rad: float, len0_mm: float, len1_mm: float) -> float:
    """Tangent length L [mm] of the circle blending a turn of ``turn_rad`` between two straight
    moves of lengths ``len0_mm`` and ``len1_mm``: the longest whose blend leaves the corner by
    at most ``deviation_mm`` (radius R leaves it by R (1/cos(phi/2) - 1) and uses L =
    R tan(phi/2) of each move), and at most half of either move."""
    half = 0.5 * turn_rad
    reach = deviation_mm / (1.0 / math.cos(half) - 1.0) * math.tan(half)
    return min(reach, 0.5 * len0_mm, 0.5 * len1_mm)


def _v3(a: np.ndarray) -> tuple[float, float, float]:
    return (float(a[0]), float(a[1]), float(a[2]))


#: A junction involving an arc turning by less than this [rad] is tangent, not a corner: the
#: planner keeps its speed and smooths the kink (junctions.CORNER_ANGLE_RAD, the same 1 degree).
ARC_CORNER_MIN_RAD = math.radians(1.0)
#: A corner with an arc whose estimated blend speed is below this share of the feed is not
#: searched for a blend (:func:`_worth_blending`; the planner keeps only blends it estimates
#: faster than an exact stop, prepare.slow_blends).
ARC_BLEND_MIN_FEED_SHARE = 0.5


@dataclass(frozen=True)
class ArcCorner:
    """How a G64 corner with an arc may be blended: the corner's budget (P less the reference's
    share) [mm], the share of it the blend's geometry may use, the largest turn blended [rad],
    and the machine's lowest axis jerk [mm/s^3] (for :func:`_worth_blending`)."""

    budget_mm: float
    geometry_share: float
    max_turn_rad: float
    jerk_mm_per_s3: float


def arc_corner(
    m0: Linear | Arc,
    m1: Linear | Arc,
    corner: ArcCorner,
    chord_tolerance_mm: float,
    tangents: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> CornerCut | None:
    """The blend of a corner with an arc on one side (:func:`corner_blend`), or None: not a
    corner (a turn below :data:`ARC_CORNER_MIN_RAD` is a tangent junction, smoothed by the
    planner), a near-reversal, not in one principal plane, or not worth blending.
    ``tangents``: the arcs' :func:`arc_end_tangents`, when made for a whole path."""
    t0 = end_tangent(m0, at_end=True, known=tangents)
    t1 = end_tangent(m1, at_end=False, known=tangents)
    phi = math.acos(float(np.clip(t0 @ t1, -1.0, 1.0)))
    plane = plane_of(t0, t1)
    if isinstance(m0, Arc):
        plane = m0.plane if plane is None or plane == m0.plane else None
    if isinstance(m1, Arc) and plane != m1.plane:
        plane = None
    if not (ARC_CORNER_MIN_RAD < phi < corner.max_turn_rad) or plane is None:
        return None
    if not (in_plane(m0, plane) and in_plane(m1, plane)):
        return None
    if not _worth_blending(m0, m1, phi, corner, chord_tolerance_mm):
        return None
    return corner_blend(m0, m1, corner.geometry_share * corner.budget_mm, plane)


def _worth_blending(
    m0: Linear | Arc, m1: Linear | Arc, phi: float, corner: ArcCorner, chord_tolerance_mm: float
) -> bool:
    """A quick estimate before the blend's geometry is searched: the line-line blend of the
    same turn (radius R from the budget, at most half of either move) is passed at about
    sqrt((6 e J^2)^(1/3) R) (its curvature jump, smoothed within e = the budget's share left
    for it, and within the blend's first chord; see junctions.junction_cap); below
    :data:`ARC_BLEND_MIN_FEED_SHARE` of the feed the planner would make it an exact stop
    anyway (prepare.slow_blends), so it is not searched."""
    share, budget, jerk = corner.geometry_share, corner.budget_mm, corner.jerk_mm_per_s3
    tangent = blend_tangent_mm(share * budget, phi, m0.length_mm, m1.length_mm)
    radius = tangent / math.tan(0.5 * phi)
    e = (1.0 - share) * budget
    chord = 2.0 * math.sqrt(2.0 * radius * chord_tolerance_mm)  # the blend's first chord
    speed = min(
        math.sqrt((6.0 * e * jerk**2) ** (1.0 / 3.0) * radius),
        (jerk * chord * radius / CHORD_FIT_BLEND) ** (1.0 / 3.0),
    )
    feed = min(m0.feed_mm_per_min, m1.feed_mm_per_min) / 60.0
    return speed >= ARC_BLEND_MIN_FEED_SHARE * feed


def arc_end_tangents(moves: Sequence[object]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Unit tangents (direction of motion) at the start and end of every arc among ``moves``,
    by ``id`` of the arc, from one batch (:func:`arc_end_derivatives_many`; 0.6 s of path
    making at 20,000 arcs, one by one)."""
    arcs = [m for m in moves if isinstance(m, Arc)]
    d1, _ = arc_end_derivatives_many(arcs)
    unit = d1 / np.sqrt(np.einsum("kij,kij->ki", d1, d1))[:, :, None]
    return {id(a): (unit[k, 0], unit[k, 1]) for k, a in enumerate(arcs)}


def end_tangent(
    m: Linear | Arc,
    at_end: bool,
    known: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> np.ndarray:
    """Unit tangent (direction of motion) at the end or start of ``m`` (as :func:`_pose` at 0
    mm, without the point); an arc's from ``known`` (:func:`arc_end_tangents`) when there."""
    if isinstance(m, Linear):
        return np.array(_pose(m, at_end)(0.0)[1])
    if known is not None and id(m) in known:
        return known[id(m)][1 if at_end else 0]
    d1, _ = arc_derivatives(m, 1.0 if at_end else 0.0)
    return d1[0] / np.linalg.norm(d1[0])
