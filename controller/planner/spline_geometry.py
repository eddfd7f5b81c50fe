"""A spline move as the planner takes a curve: by the fraction sigma = s / L of its arc length,
like an arc's sweep fraction (the chord vertices, the exact states at them, the deviation of a
piece from the curve), plus the bounds that its curvature puts on following it exactly.

Derivatives with respect to arc length s, from the spline's own parameter t (speed v = |C'|,
t' = 1/v, t'' = -(C'.C'')/v^4, t''' = -(|C''|^2 + C'.C''')/v^5 + 4 (C'.C'')^2/v^7):

    p'   = C' t'
    p''  = C'' t'^2 + C' t''                    (the curvature vector k, |k| = 1/R)
    p''' = C''' t'^3 + 3 C'' t' t'' + C' t'''

The curvature varies along a spline: the bounds are the largest |p''| and |p'''| over a dense
sampling (:data:`SAMPLES_PER_CHORD` per chord and :data:`SAMPLES_PER_SPAN` per knot span)
times :data:`BOUND_MARGIN`. At a zero-speed end (G5 ``I0 J0``, or the first G5 without I J:
the first control point is the start) the curvature grows without bound towards the end point
(like s^-1/2), so no finite bound holds there: the bounds are taken from the end chord's inner
vertex on. On that end chord the reference passes the exact states at its vertices (more of
them next to a stop, arc_states.py), the junction's cap comes from the end's own (very large)
curvature, and every piece there is held to the limits one by one (see below); measured on
``G1 X1 F3000`` then ``G5 P-2 Q2 X20 Y0``: the reference stays within 0.13 um of the curve and
the move takes 1.2 s, where bounds sampled into the end chord made it crawl for 20 s.
A spline whose direction reverses between two samples (an interior cusp: it stops and turns
back) is refused with its line.

The block limits (limits.py, arc_limits) bound the jerk of exact following as if p''' were
orthogonal to the curvature vector, which holds on circles; along a spline p''' also has a part
dk/ds along it, so where the curvature changes fast those limits can be slightly optimistic.
The reference still keeps every limit: each closed-form piece is checked per axis against the
velocity, acceleration and jerk limits and the feed (pieces.py, jerk3.piece_limits_ok), and one
that breaks a limit is replaced by a Ruckig piece.
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.moves import Spline

SAMPLES_PER_CHORD = 8
SAMPLES_PER_SPAN = 256
#: relative margin on the sampled maxima (what lies between two samples)
BOUND_MARGIN = 1.05
#: samples of :func:`spline_extent_points` and :func:`curvature_bounds` taken at once (the
#: extent's are 5 million for a G5.2 of 5,000 knot spans)
EXTENT_CHUNK = 65_536


def spline_points(move: Spline, sigma: np.ndarray) -> np.ndarray:
    """Points (m, 3) [mm] at arc-length fractions ``sigma`` (ends exact)."""
    sigma = np.asarray(sigma, dtype=float)
    pts = move.curve.frame(sigma)[0]
    pts[sigma <= 0.0] = move.start
    pts[sigma >= 1.0] = move.end
    return pts


def spline_derivatives(move: Spline, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dp/dsigma = L T and d2p/dsigma2 = L^2 k (m, 3) [mm] at ``sigma``."""
    c = move.curve
    _, tangent, k = c.frame(np.asarray(sigma, dtype=float))
    length = c.length_mm
    return tangent * length, k * length * length


def spline_deviation(move: Spline, q: np.ndarray, sigma_hint: float, window: float) -> float:
    """Largest distance [mm] of points ``q`` (k, 3) from the curve, searched near the
    arc-length fraction ``sigma_hint`` (within ``window`` either side, then Newton)."""
    c = move.curve
    lo, hi = max(sigma_hint - window, 0.0), min(sigma_hint + window, 1.0)
    t_lo, t_hi = c.t_of_s(np.array([lo, hi]) * c.length_mm)
    seed = c.seeds(q, float(t_lo), float(t_hi), 33)
    near = c.nurbs.points(c.nearest(q, seed, float(t_hi - t_lo) / 32))
    return float(np.max(np.linalg.norm(q - near, axis=1)))


def arc_length_derivatives(
    d1: np.ndarray, d2: np.ndarray, d3: np.ndarray
) -> tuple[np.ndarray, ...]:
    """(p', p'', p''') with respect to arc length from dC/dt, d2C/dt2, d3C/dt3 (m, 3)."""
    v2 = np.einsum("ij,ij->i", d1, d1)
    v = np.sqrt(v2)
    c12 = np.einsum("ij,ij->i", d1, d2)
    t1 = 1.0 / v
    t2 = -c12 / v2**2
    t3 = -(np.einsum("ij,ij->i", d2, d2) + np.einsum("ij,ij->i", d1, d3)) / (v2**2 * v) + (
        4.0 * c12 * c12 / (v2**3 * v)
    )
    p1 = d1 * t1[:, None]
    p2 = d2 * (t1 * t1)[:, None] + d1 * t2[:, None]
    p3 = d3 * (t1**3)[:, None] + 3.0 * d2 * (t1 * t2)[:, None] + d1 * t3[:, None]
    return p1, p2, p3


def curvature_bounds(move: Spline, chords: int) -> tuple[float, float]:
    """(largest |p''| [1/mm], largest |p'''| [1/mm^2]) along the spline, sampled (see the
    module docstring) and times :data:`BOUND_MARGIN`."""
    c = move.curve
    spans = len(np.unique(move.knots)) - 1
    n = max(SAMPLES_PER_CHORD * chords, SAMPLES_PER_SPAN * spans)
    t_all = np.linspace(c.nurbs.t_min, c.nurbs.t_max, n + 1)
    # next to a zero-speed end the bounds start at the end chord's inner vertex (see the
    # module docstring: the end chord's pieces are held to the limits one by one)
    start_stops, end_stops = c.zero_speed_ends
    t_first, t_last = c.t_of_s(np.array([1.0, chords - 1.0]) / chords * c.length_mm)
    k = dk = 0.0
    before = None  # the last unit tangent of the samples before (the cusp test spans blocks)
    for first in range(0, t_all.size, EXTENT_CHUNK):
        t = t_all[first : first + EXTENT_CHUNK]
        _, d1, d2, d3 = c.nurbs.derivatives(t, 3)
        ok = ~c.zero_speed(d1)  # a zero-speed end: its curvature is unbounded (docstring)
        p1, p2, p3 = arc_length_derivatives(d1[ok], d2[ok], d3[ok])
        turns = p1 if before is None else np.vstack([before, p1])
        if (np.einsum("ij,ij->i", turns[:-1], turns[1:]) < 0.0).any():
            raise PlanningError(
                f"this {move.code} spline reverses its direction at a cusp (its control points "
                "make it stop and turn back), which no machine follows without stopping there; "
                "split it at the cusp or move its control points",
                line=move.line,
                file=move.file,
            )
        before = turns[-1:] if len(turns) else before
        inner = np.ones(len(t), dtype=bool)
        if start_stops:
            inner &= t >= t_first
        if end_stops:
            inner &= t <= t_last
        p2, p3 = p2[inner[ok]], p3[inner[ok]]
        k = max(k, float(np.max(np.linalg.norm(p2, axis=1))) if len(p2) else 0.0)
        dk = max(dk, float(np.max(np.linalg.norm(p3, axis=1))) if len(p3) else 0.0)
    return BOUND_MARGIN * k, BOUND_MARGIN * dk


def spline_extent_points(move: Spline) -> np.ndarray:
    """Points (k, 3) [mm] whose bounding box is the spline's extent (dense samples: the
    extent is found to within curvature * step^2 / 8, far below a micrometre): of each
    :data:`EXTENT_CHUNK` samples, the lowest and highest along each axis."""
    c = move.curve
    spans = len(np.unique(move.knots)) - 1
    t_all = np.linspace(c.nurbs.t_min, c.nurbs.t_max, 1024 * spans + 1)
    kept = [np.array([move.start, move.end], dtype=float)]
    for first in range(0, t_all.size, EXTENT_CHUNK):
        pts = c.nurbs.points(t_all[first : first + EXTENT_CHUNK])
        kept.append(pts[np.concatenate([pts.argmin(axis=0), pts.argmax(axis=0)])])
    return np.vstack(kept)
