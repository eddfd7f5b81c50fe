"""Arcs -> chords: how many, and where the chord vertices lie.

Two methods (``[segmentation] method`` in the machine file):

* ``"chord"`` (grbl's ``mc_arc``): the fewest chords whose sagitta stays within the chord
  tolerance ``tol`` [mm]. A chord spanning the angle ``phi`` of a circle of radius ``r`` has the
  sagitta ``r (1 - cos(phi/2))``; sagitta <= tol gives a chord length
  ``2 sqrt(tol (2r - tol))``, hence ``n = ceil(theta r / (2 sqrt(tol (2r - tol))))`` for a sweep
  ``theta``. When ``r <= tol`` the whole arc already lies within the tolerance of any chord through
  it; the only rule left is the next one.
* ``"fixed"`` (Marlin's ``plan_arc`` in G2_G3.cpp): ``n = floor(length / segment_length_mm)``
  (MM_PER_ARC_SEGMENT, Marlin 2.x: MAX_ARC_SEGMENT_MM = 1.0 mm), but never fewer than
  ``ceil(MIN_CIRCLE_SEGMENTS * theta / 2pi)`` with MIN_CIRCLE_SEGMENTS = 72 (Marlin 2.x
  Configuration_adv.h: "Minimum number of segments in a complete circle").

Both: every chord spans at most 90 degrees (so a full circle is never one zero-length chord and
the sagitta formula stays meaningful), the vertices are computed from ``u_i = i/n`` directly on
the arc/helix/spiral (:func:`gantry_sim.controller.arcs.arc_points`, no accumulated rotation), and the last
vertex is the programmed end exactly. A helix's chord midpoint lies at the helix's mid height, so
its distance from the helix is at most the in-plane sagitta.

Splines (G5, G5.1, G5.2/G5.3; :func:`segment_spline`): n chords of equal arc length (the
planner's parameter is the arc-length fraction, like an arc's sweep fraction), the fewest whose
largest distance from the curve, measured on :data:`CHECK_SAMPLES` points per chord, stays within
:data:`SPLINE_TOLERANCE_SHARE` of the chord tolerance (method "chord"); method "fixed" also takes
at least floor(length / segment_length_mm) chords.

An absurd program (``G2 ... P1000000``) must not exhaust memory: an arc needing more than
:data:`MAX_SEGMENTS_PER_ARC` chords is refused with a :class:`PlanningError` naming its line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.arcs import arc_frame, arc_length_mm
from gantry_sim.controller.errors import ConfigError, PlanningError
from gantry_sim.controller.moves import Arc, Spline
from gantry_sim.controller.planner.arc_batch import arc_points_many
from gantry_sim.controller.planner.spline_geometry import spline_points

#: Upper bound on chords per arc (about 100 MB of planner state): beyond it the arc is refused.
MAX_SEGMENTS_PER_ARC = 1_000_000
#: Marlin 2.x Configuration_adv.h, ARC_SUPPORT: minimum number of segments in a complete circle.
MIN_CIRCLE_SEGMENTS = 72
#: Largest sweep of one chord [rad] (both methods).
MAX_CHORD_SWEEP_RAD = 0.5 * math.pi

METHODS = ("chord", "fixed")


def segment_count(
    arc: Arc, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> int:
    """Number of chords for ``arc`` (see the module docstring for the rules).

    Raises:
        ConfigError: unknown method or non-positive tolerance / length.
        PlanningError: more than :data:`MAX_SEGMENTS_PER_ARC` chords (names the arc's line).
    """
    if method not in METHODS:
        raise ConfigError(f"segmentation method {method!r} is unknown; valid: chord, fixed")
    if not (chord_tolerance_mm > 0 and segment_length_mm > 0):
        raise ConfigError("chord_tolerance_mm and segment_length_mm must be > 0")
    frame = arc_frame(arc)
    r = max(frame.r0_mm, frame.r1_mm)
    n = chords_of_sweep(arc, r, method, chord_tolerance_mm, segment_length_mm)
    if n > MAX_SEGMENTS_PER_ARC:
        raise PlanningError(
            f"arc needs {n} segments ({method} segmentation); at most {MAX_SEGMENTS_PER_ARC} "
            "per arc are planned: use fewer turns (P), a smaller arc or a coarser tolerance",
            line=arc.line,
            file=arc.file,
        )
    return n


def chords_of_sweep(
    arc: Arc, r_mm: float, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> int:
    """:func:`segment_count`'s chords of ``arc`` at radius ``r_mm`` (the larger of its end
    radii there; its start radius, ``arc.radius``, is the frame-free estimate the planner's
    windows take), unchecked."""
    theta = arc.angle
    n_sweep = math.ceil(theta / MAX_CHORD_SWEEP_RAD - 1e-12)
    if method == "chord":
        r, tol = r_mm, chord_tolerance_mm
        n = 1 if r <= tol else math.ceil(theta * r / (2.0 * math.sqrt(tol * (2.0 * r - tol))))
    else:
        n_min = math.ceil(MIN_CIRCLE_SEGMENTS * theta / (2.0 * math.pi) - 1e-9)
        n = max(math.floor(arc_length_mm(arc) / segment_length_mm), n_min)
    return max(n, n_sweep, 1)


def segment_arc(
    arc: Arc | Spline, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> np.ndarray:
    """Chord vertices of ``arc``: read-only array (n + 1, 3) [mm], first = start, last = end.

    Args:
        arc: the arc or helix (or a spline: :func:`segment_spline`).
        method: "chord" (sagitta <= ``chord_tolerance_mm``) or "fixed" (``segment_length_mm``).
        chord_tolerance_mm: maximum chord sagitta [mm] (method "chord").
        segment_length_mm: nominal chord length [mm] (method "fixed").
    """
    if isinstance(arc, Spline):
        return segment_spline(arc, method, chord_tolerance_mm, segment_length_mm)
    return segment_arcs([arc], method, chord_tolerance_mm, segment_length_mm)[0]


def segment_arcs(
    arcs: Sequence[Arc], method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> list[np.ndarray]:
    """:func:`segment_arc` of each arc: their vertices made in batches of about
    :data:`CHORD_BATCH_POINTS` (:func:`~gantry_sim.controller.planner.arc_batch.arc_points_many`,
    each number as :func:`~gantry_sim.controller.arcs.arc_points` gives it; u = 0 and 1: the
    start and the end exactly). Each arc's vertices are a read-only view of its batch's array,
    which lives as long as any of them."""
    out: list[np.ndarray] = []
    batch: list[Arc] = []
    fractions: list[np.ndarray] = []
    size = 0
    for k, arc in enumerate(arcs):
        n = segment_count(arc, method, chord_tolerance_mm, segment_length_mm)
        batch.append(arc)
        fractions.append(np.arange(n + 1) / n)
        size += n + 1
        if size >= CHORD_BATCH_POINTS or k == len(arcs) - 1:
            for verts in arc_points_many(batch, fractions):
                verts.setflags(write=False)
                out.append(verts)
            batch, fractions, size = [], [], 0
    return out


#: Chord vertices made in one batch by :func:`segment_arcs` (about 2 MB of points).
CHORD_BATCH_POINTS = 65_536


#: points per chord where a spline chord's distance from the curve is measured
CHECK_SAMPLES = 16
#: the share of the chord tolerance a spline chord may use (the rest: between the samples)
SPLINE_TOLERANCE_SHARE = 0.95


#: chords whose distance from the curve is measured at once (a G5.2 of 5,000 control points
#: near cusps asked for a million chords, 16 million points, whose arc-length inversion held
#: 24 GB at once); the numbers are the same whatever the block (each point is its own)
CHECK_CHORDS = 4096


def chord_deviation_mm(spline: Spline, n: int, enough_mm: float = math.inf) -> float:
    """Largest distance [mm] of the curve from its n equal-arc-length chords (sampled: at
    equal arc lengths, and where an end has zero speed, at equal steps of the parameter too),
    :data:`CHECK_CHORDS` chords at a time; or, once that distance passes ``enough_mm``, the
    largest found so far (a caller that only needs to know it is above that)."""
    k = CHECK_SAMPLES
    c = spline.curve
    ends = np.empty((n + 1, 3))  # the chords' vertices
    worst = 0.0
    for first in range(0, n, CHECK_CHORDS):
        stop = min(n, first + CHECK_CHORDS)
        sigma = np.arange(first * k, stop * k + 1) / (n * k)
        pts = spline_points(spline, sigma)
        ends[first : stop + 1] = pts[::k]
        inner = pts[:-1].reshape(stop - first, k, 3)
        a, b = pts[:-1:k][:, None, :], pts[k::k][:, None, :]  # chord starts, ends (m, 1, 3)
        worst = max(worst, float(_chord_distances(inner, a, b).max()))
        if worst > enough_mm * enough_mm:
            return math.sqrt(worst)
    if any(c.zero_speed_ends):
        # the curvature grows without bound there (like s^-1/2): a hook next to such an end,
        # microns long, fell between the arc-length samples, and its one chord left it out
        t_all = np.linspace(c.nurbs.t_min, c.nurbs.t_max, n * k + 1)
        a, b = ends[:-1][:, None, :], ends[1:][:, None, :]
        for first in range(0, t_all.size, CHECK_CHORDS * k):
            t = t_all[first : first + CHECK_CHORDS * k]
            chord = np.minimum((c.s_of_t(t) / c.length_mm * n).astype(np.intp), n - 1)
            q = c.nurbs.points(t)[:, None, :]
            worst = max(worst, float(_chord_distances(q, a[chord], b[chord]).max()))
    return math.sqrt(worst)


def _chord_distances(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared distances [mm^2] (m, k) of points ``q`` (m, k, 3) from the segments ``a`` ..
    ``b`` (each (m, 1, 3))."""
    d = b - a
    dd = np.einsum("ijk,ijk->ij", d, d)
    u = np.clip(np.einsum("ijk,ijk->ij", q - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    off = q - (a + u[:, :, None] * d)
    return np.einsum("ijk,ijk->ij", off, off)


def spline_segment_count(
    spline: Spline, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> int:
    """Number of equal-arc-length chords of ``spline`` (see the module docstring)."""
    if method not in METHODS:
        raise ConfigError(f"segmentation method {method!r} is unknown; valid: chord, fixed")
    if not (chord_tolerance_mm > 0 and segment_length_mm > 0):
        raise ConfigError("chord_tolerance_mm and segment_length_mm must be > 0")
    key = (method, chord_tolerance_mm, segment_length_mm)
    found = spline.curve.chord_counts.get(key)
    if found is None:
        found = spline.curve.chord_counts[key] = _chord_count(spline, *key)
    return found


def _chord_count(
    spline: Spline, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> int:
    """:func:`spline_segment_count`, searched."""
    tol = SPLINE_TOLERANCE_SHARE * chord_tolerance_mm
    length = spline.length_mm
    n_min = max(math.floor(length / segment_length_mm), 1) if method == "fixed" else 1
    n = n_min
    for _ in range(60):
        # a deviation above this sends the next count past the most allowed (below), so it is
        # measured only until it is passed (a hostile G5.2 near cusps took 142 s to measure a
        # million chords it then refused); 1e-9 more keeps rounding from deciding otherwise
        if n * 1.1 > MAX_SEGMENTS_PER_ARC:
            hopeless = tol
        else:
            hopeless = tol * (MAX_SEGMENTS_PER_ARC / (1.02 * n)) ** 2 * (1.0 + 1e-9)
        dev = chord_deviation_mm(spline, n, hopeless)
        if dev <= tol:
            return n
        # the deviation falls like 1/n^2 (like 1/n^1.5 next to a zero-speed end)
        n = max(n + 1, math.ceil(n * (dev / tol) ** 0.5 * 1.02), math.ceil(n * 1.1))
        if n > MAX_SEGMENTS_PER_ARC:
            raise PlanningError(
                f"spline needs more than {MAX_SEGMENTS_PER_ARC} segments to stay within the chord "
                "tolerance; use a coarser tolerance",
                line=spline.line,
                file=spline.file,
            )
    raise PlanningError(
        "no chord count keeps this spline within the tolerance",
        line=spline.line,
        file=spline.file,
    )


def segment_spline(
    spline: Spline, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> np.ndarray:
    """Chord vertices (n + 1, 3) [mm] of ``spline`` at equal arc-length steps (read-only)."""
    n = spline_segment_count(spline, method, chord_tolerance_mm, segment_length_mm)
    verts = spline_points(spline, np.arange(n + 1) / n)
    verts.setflags(write=False)
    return verts
