"""G64 fits: runs of short straight moves followed on one curve of continuous curvature.

A CAM polyline (a surface pass, a contour written as short G1 moves) turns a little at every end
point. Blended corner by corner (:mod:`~gantry_sim.controller.planner.blend`), each turn becomes
an arc whose curvature is its own corner's, tan(turn/2) over half the shorter move: on 0.05-0.5
mm moves turning 0.5-5 degrees, 0.02 to 1.7 /mm from one move to the next. The curvature then
jumps at every junction, and a jerk-limited reference can only pass such jumps slowly: the
generated polyline of ``benchmarks/programs.py`` ran at a third of its feed, where LinuxCNC's
planner (which has no jerk limit) runs it near the feed (docs/planning-notes.md, "Noisy
polylines").

Here such a run is followed instead on a cubic B-spline fitted to it within the path
tolerance: position, tangent and curvature are continuous along it, its curvature varies
smoothly, so nothing is left to smooth at its junctions and each part is passed at what its own
curvature allows.

Which moves (:func:`fit_runs`): consecutive straight feed moves (G1) in G64 with a tolerance, at
one feed and path control, with no stop or dwell between them (a printer's: extruding ones),
each at most :data:`MAX_MOVE_MM` long, turning by :data:`MIN_TURN_RAD` to :data:`MAX_TURN_RAD`
where they meet, all in one
principal plane (the normal coordinate the same on every end point), at least
:data:`MIN_RUN_MOVES` of them. The curve runs from the middle of the run's first move to the
middle of its last, leaving and joining them with their direction and no curvature; the halves
outside stay straight moves, which meet the moves before and after the run as any two straight
moves do (a corner blend, or a stop). Where the run starts at rest (the program's start, after
a rapid, a stop or a dwell) the curve starts at the first move's start instead, with its
direction and the moves' own turning there (:func:`_turn_rate`): the stop hides any jump of
curvature. Likewise where it ends at rest.

The fit (:func:`fit_curve`): a uniform cubic B-spline C(u), u the polyline's arc length from the
curve's start (knots every h mm, h about :data:`KNOTS_PER_MOVE` x the moves' mean length, at
least :data:`KNOT_MM`), its control points found by least
squares against points of the polyline (its end points and points :data:`SAMPLE_MM` apart) with
a penalty on the control points' third differences (the curve's third derivative, its
curvature's rate: what a jerk limit pays for) weighted by mu. mu starts at :data:`MU0`; where
the curve leaves the polyline by more than the budget, mu is lowered around those spans (by
:data:`MU_STEP`, :data:`MU_ROUNDS` times), and at last h is halved once. A run that still
does not fit keeps its moves and blends, as does a chunk whose blends would not meet
(:data:`MEETING_SHARE`). The budget is :data:`GEOMETRY_SHARE` of P less the
reference's share of the chord tolerance (as a blend's), the rest left for the planner's
smoothing.

The deviation is measured, not assumed: every span is sampled at :data:`SPAN_SAMPLES` points,
each point's distance to the nearby moves computed exactly, and the largest refined between
samples by golden-section steps; and every end point of the moves (the corners the curve cuts)
is measured from the curve (its distance to the chords between the curve's samples, plus their
sag, an upper bound). The larger of the two is the fit's deviation, reported as a blend of kind
"fit" per piece (``gantry plan``'s ``blends``).

A long run is cut into chunks of at least :data:`CHUNK_MOVES` moves, each cut in the middle of
the longest of the next :data:`CUT_MOVES` moves, where both chunks' curves take the same point,
direction and curvature (the moves' turning there, from the same three moves:
:func:`_join_curvature`), so the curve is continuous in curvature across the cut and the chunks
are fitted independently: :data:`BATCH_CHUNKS` at a time over the processes
(:func:`~gantry_sim.controller.forked.fork_map`), in bounded memory as the moves come. A chunk
that does not fit keeps its moves (the halves of the moves it shares with the chunks next to
it meet those chunks' curves in line).

Each knot span is one piece of the path: its cubic Bezier, raised to the quintic Bezier of a
:class:`~gantry_sim.controller.moves.Transition` (the curve the planner already plans for G2
transitions). Units: mm; tangents are unit vectors in the direction of motion.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from gantry_sim.controller.config import PathSettings
from gantry_sim.controller.forked import fork_map, process_count
from gantry_sim.controller.moves import Linear, PathMove, Rapid, Transition
from gantry_sim.controller.planes import PLANE_AXES, PLANES, Plane
from gantry_sim.controller.planner.blend import MEET_SHARE
from gantry_sim.controller.planner.blend_types import Blend
from gantry_sim.controller.planner.path_control import PathEntry, control
from gantry_sim.controller.quintic_curve import QuinticCurve

__all__ = ["FitCurve", "FitMemo", "fit_curve", "fit_runs"]

#: Longest move a run takes [mm], and the largest turn where two of its moves meet [rad].
MAX_MOVE_MM = 1.0
MAX_TURN_RAD = math.radians(10.0)
#: The smallest turn a run takes [rad]: moves in line (to 4 decimals' rounding, about 1e-4 rad
#: on 0.2 mm moves) stay straight moves, which run on their axes' own limits where a curve runs
#: on its plane's weaker ones (UGS's stress test, 1 mm squares of 0.01 mm moves: 9.31 s
#: blended, 10.91 s with its sides fitted).
MIN_TURN_RAD = 1e-3
#: Fewest moves a run must have to be fitted: a short run's curve spends much of itself
#: leaving and joining its straight halves (no curvature there), and its chain's ramps are its
#: sharpest piece's (pcb2gcode's isolation passes around pads, runs of 12-58 moves of 0.14 mm
#: on circles of R 1.5: 116.2 s blended, 149.4 s fitted, 120.0 s with runs of 40 or more).
MIN_RUN_MOVES = 64
#: Knot spacing aimed at [mm]: the moves' mean length times KNOTS_PER_MOVE, at least KNOT_MM
#: (a chunk's own is its length over a whole number of spans); then half that.
KNOT_MM = 0.25
KNOTS_PER_MOVE = 0.8
#: A chunk is fitted where corner blends would pass at least SLOW_SHARE of its moves below
#: SLOW_FEED of what the curvature itself allows (:func:`_blends_slow`): the jumps of
#: curvature between them, which the fit removes, cost time there; elsewhere the blends are as fast and plan faster (TinyG's
#: FordEmblem, a contour digitised in moves of about 1 mm: 721.2 s fitted against 723.2 s
#: blended, planned in 26 s against 8.7 s).
SLOW_SHARE = 0.25
SLOW_FEED = 0.9
#: Spacing of the polyline points the fit is measured against [mm] (end points too).
SAMPLE_MM = 0.1
#: Share of the budget (P less the reference's share of the chord tolerance) the curve may use.
GEOMETRY_SHARE = 0.9
#: Weight of the third-difference penalty (relative to the sum of squares over a span's points),
#: its step down around spans over the budget, and how many steps before h is halved.
MU0 = 1.0
MU_STEP = 0.05
MU_ROUNDS = 4
#: A long run is cut into chunks of at least CHUNK_MOVES moves, at the longest of the
#: CUT_MOVES moves after them (the chunks meet in its middle); chunks fitted at once.
CHUNK_MOVES = 512
CUT_MOVES = 64
BATCH_CHUNKS = 8
#: Entries held behind the chunks waiting to be fitted, at most (then they are fitted).
QUEUE_ENTRIES = 16384
#: Samples per span measuring the curve, and golden-section steps refining the largest.
SPAN_SAMPLES = 8
GOLDEN_STEPS = 8
#: Relative margin on the curve's measured distance from the moves.
DEVIATION_PAD = 1e-3
#: Moves either side of a point's own whose distance is measured (the nearest lies among them).
NEAR_MOVES = 4
#: Points in a plane closer than this to its normal coordinate count as in it [mm].
PLANE_EPS_MM = 1e-9


@dataclass(frozen=True)
class FitCurve:
    """A fitted curve: its control points ``ctrl`` (m + 3, 2) in the plane's two axes (the
    first and second of :data:`~gantry_sim.controller.planes.PLANE_AXES`) [mm], its knot
    spacing ``h`` [mm] (u runs from 0 to m h), the deviation per span [mm] and the largest
    distance of the polyline's inner end points from the curve [mm] (both as the module
    docstring measures them)."""

    ctrl: np.ndarray
    h: float
    span_deviation_mm: np.ndarray
    corner_deviation_mm: float

    @property
    def spans(self) -> int:
        return self.ctrl.shape[0] - 3


# ---- the B-spline --------------------------------------------------------------------------


def _basis(t: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline weights (k, 4) at span parameters ``t`` in [0, 1]."""
    t2, t3 = t * t, t * t * t
    return np.stack(
        [(1 - t) ** 3 / 6, (3 * t3 - 6 * t2 + 4) / 6, (-3 * t3 + 3 * t2 + 3 * t + 1) / 6, t3 / 6],
        axis=1,
    )


def _locate(u: np.ndarray, h: float, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Span index and span parameter of curve parameters ``u`` [mm]."""
    j = np.clip(np.floor(u / h).astype(int), 0, m - 1)
    return j, u / h - j


def points(ctrl: np.ndarray, h: float, u: np.ndarray) -> np.ndarray:
    """Curve points (k, 2) at parameters ``u`` [mm]."""
    m = ctrl.shape[0] - 3
    j, t = _locate(u, h, m)
    w = _basis(t)
    return np.einsum("ki,kid->kd", w, ctrl[j[:, None] + np.arange(4)])


def end_controls(c: np.ndarray, d1: np.ndarray, d2: np.ndarray, h: float) -> np.ndarray:
    """The three control points (3, 2) that give a span end the point ``c``, first derivative
    ``d1`` and second derivative ``d2`` with respect to u (knot spacing ``h``)."""
    mid = c - h * h * d2 / 6
    return np.stack([mid - h * d1 + h * h * d2 / 2, mid, mid + h * d1 + h * h * d2 / 2])


def bezier_pieces(ctrl: np.ndarray) -> np.ndarray:
    """Each span's quintic Bezier control points (m, 6, 2): its cubic Bezier, degree raised."""
    c0, c1, c2, c3 = ctrl[:-3], ctrl[1:-2], ctrl[2:-1], ctrl[3:]
    cubic = np.stack(
        [(c0 + 4 * c1 + c2) / 6, (2 * c1 + c2) / 3, (c1 + 2 * c2) / 3, (c1 + 4 * c2 + c3) / 6],
        axis=1,
    )
    quartic = np.empty((cubic.shape[0], 5, cubic.shape[2]))
    for i in range(5):
        lo = cubic[:, i - 1] if i > 0 else 0.0
        hi = cubic[:, i] if i < 4 else 0.0
        quartic[:, i] = (i / 4) * lo + (1 - i / 4) * hi
    quintic = np.empty((cubic.shape[0], 6, cubic.shape[2]))
    for i in range(6):
        lo = quartic[:, i - 1] if i > 0 else 0.0
        hi = quartic[:, i] if i < 5 else 0.0
        quintic[:, i] = (i / 5) * lo + (1 - i / 5) * hi
    return quintic


# ---- distances to the polyline -------------------------------------------------------------


class _Polyline:
    """The moves' end points (n + 1, 2) in the plane and their arc lengths [mm]."""

    def __init__(self, pts: np.ndarray) -> None:
        self.pts = pts
        seg = np.diff(pts, axis=0)
        self.seg = seg
        self.len = np.sqrt(np.einsum("ij,ij->i", seg, seg))
        self.s = np.concatenate([[0.0], np.cumsum(self.len)])

    def at(self, s: np.ndarray) -> np.ndarray:
        """Points (k, 2) at arc lengths ``s``."""
        return np.stack([np.interp(s, self.s, self.pts[:, a]) for a in range(2)], axis=1)

    def distance(self, q: np.ndarray, s_hint: np.ndarray) -> np.ndarray:
        """Distance of points ``q`` (k, 2) to the moves within :data:`NEAR_MOVES` of the move at
        arc length ``s_hint`` (an upper bound of the distance to the whole polyline)."""
        n = self.seg.shape[0]
        i0 = np.clip(np.searchsorted(self.s, s_hint, side="right") - 1, 0, n - 1)
        idx = np.clip(i0[:, None] + np.arange(-NEAR_MOVES, NEAR_MOVES + 1), 0, n - 1)
        a = self.pts[idx]
        d = self.seg[idx]
        l2 = np.maximum(self.len[idx] ** 2, 1e-300)
        w = q[:, None, :] - a
        t = np.clip(np.einsum("kjd,kjd->kj", w, d) / l2, 0.0, 1.0)
        r = w - t[:, :, None] * d
        return np.sqrt(np.einsum("kjd,kjd->kj", r, r).min(axis=1))


# ---- the fit --------------------------------------------------------------------------------


def fit_curve(
    poly: np.ndarray,
    budget_mm: float,
    start: tuple[np.ndarray, np.ndarray, np.ndarray],
    end: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> FitCurve | None:
    """The curve fitted to the polyline ``poly`` (n + 1, 2) [mm] from its arc length 0 (where
    it has the point, first and second derivative ``start``) to its end (``end`` likewise),
    within ``budget_mm``; None where no curve fits (module docstring)."""
    line = _Polyline(poly)
    total = float(line.s[-1])
    # a knot a move or so: finer adds pieces to plan and gains nothing on long moves
    knot_mm = max(KNOT_MM, KNOTS_PER_MOVE * total / max(1, len(poly) - 1))
    m0 = max(1, round(total / knot_mm))
    for m in dict.fromkeys((m0, 2 * m0)):
        if m < 4:
            return None
        fit = _fit(line, total / m, m, budget_mm, start, end)
        if fit is not None:
            return fit
    return None


def _fit(
    line: _Polyline,
    h: float,
    m: int,
    budget_mm: float,
    start: tuple[np.ndarray, np.ndarray, np.ndarray],
    end: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> FitCurve | None:
    """The fit with ``m`` spans of ``h`` mm (module docstring), or None."""
    total = float(line.s[-1])
    n_ctrl = m + 3
    # the points fitted: every end point and points SAMPLE_MM apart
    extra = np.linspace(0.0, total, max(2, math.ceil(total / SAMPLE_MM) + 1))
    s = np.unique(np.concatenate([line.s, extra]))
    data = line.at(s)
    j, t = _locate(s, h, m)
    w = _basis(t)
    # the normal equations, in band form: band[i, d] = N[i, i + d], d = 0..3
    band_data = np.zeros((n_ctrl, 4))
    for a in range(4):
        for d in range(4 - a):
            np.add.at(band_data[:, d], j + a, w[:, a] * w[:, a + d])
    rhs_data = np.zeros((n_ctrl, 2))
    for a in range(4):
        np.add.at(rhs_data, j + a, w[:, a, None] * data)
    fixed = np.zeros(n_ctrl, dtype=bool)
    values = np.zeros((n_ctrl, 2))
    values[:3] = end_controls(*start, h)
    fixed[:3] = True
    values[m : m + 3] = end_controls(*end, h)
    fixed[m : m + 3] = True
    # the penalty's scale: a span's share of the points' sum of squares
    mu = np.full(m, MU0 * s.size / m)
    for _ in range(MU_ROUNDS + 1):
        band = band_data.copy()
        for a in range(4):
            for d in range(4 - a):
                band[a : a + m, d] += mu * _THIRD[a] * _THIRD[a + d]
        ctrl = _solve_banded(band, rhs_data, fixed, values)
        span_dev, corner_dev = _deviation(ctrl, h, line)
        # a corner counts against the span its arc length lies in
        corner_span = np.clip((line.s[1:-1] / h).astype(int), 0, m - 1)
        over = span_dev > budget_mm
        over[corner_span[corner_dev > budget_mm]] = True
        if not over.any():
            return FitCurve(ctrl, h, span_dev, float(corner_dev.max(initial=0.0)))
        near = np.zeros(m, dtype=bool)
        for k in np.flatnonzero(over):
            near[max(0, k - 3) : k + 4] = True
        mu[near] *= MU_STEP
    return None


#: The third difference's coefficients (a row of the penalty, on 4 consecutive control points).
_THIRD = (-1.0, 3.0, -3.0, 1.0)


def _solve_banded(
    band: np.ndarray, rhs: np.ndarray, fixed: np.ndarray, values: np.ndarray
) -> np.ndarray:
    """The control points minimising the fit's quadratic form, whose symmetric matrix has the
    upper band ``band`` (n, 4) and right-hand side ``rhs`` (n, 2), with the ``fixed`` ones at
    ``values``: a banded Cholesky factorisation (half-bandwidth 3) of the free ones' block."""
    n = band.shape[0]
    free = np.flatnonzero(~fixed)
    ctrl = values.copy()
    if free.size == 0:
        return ctrl
    # move the fixed ones' terms to the right-hand side
    r = rhs.copy()
    for f in np.flatnonzero(fixed).tolist():
        for d in range(1, 4):
            if f + d < n:
                r[f + d] -= band[f, d] * values[f]
            if f - d >= 0:
                r[f - d] -= band[f - d, d] * values[f]
    # the free ones are contiguous (fixed ones only at the ends): factor that block
    lo, hi = int(free[0]), int(free[-1]) + 1
    assert hi - lo == free.size
    k = hi - lo
    diag = band[lo:hi, 0].tolist()
    off = [band[lo:hi, d].tolist() for d in range(1, 4)]
    low = [[0.0, 0.0, 0.0] for _ in range(k)]  # low[i][d - 1] = L[i, i - d]
    dl = [0.0] * k
    for i in range(k):
        for d in (3, 2, 1):
            jj = i - d
            if jj < 0:
                continue
            v = off[d - 1][jj]
            for e in range(d + 1, 4):  # sum over L[i, jj - (e - d)] L[jj, jj - (e - d)]
                q = jj - (e - d)
                if q >= 0:
                    v -= low[i][e - 1] * low[jj][e - d - 1] * dl[q]
            low[i][d - 1] = v / dl[jj]
        v = diag[i]
        for d in (1, 2, 3):
            if i - d >= 0:
                v -= low[i][d - 1] ** 2 * dl[i - d]
        dl[i] = v
    y = r[lo:hi].tolist()
    for i in range(k):  # L y = r
        for d in (1, 2, 3):
            if i - d >= 0:
                y[i] = [
                    y[i][0] - low[i][d - 1] * y[i - d][0],
                    y[i][1] - low[i][d - 1] * y[i - d][1],
                ]
    for i in range(k):  # D z = y
        y[i] = [y[i][0] / dl[i], y[i][1] / dl[i]]
    for i in range(k - 1, -1, -1):  # L^T x = z
        for d in (1, 2, 3):
            if i + d < k:
                y[i] = [
                    y[i][0] - low[i + d][d - 1] * y[i + d][0],
                    y[i][1] - low[i + d][d - 1] * y[i + d][1],
                ]
    ctrl[lo:hi] = y
    return ctrl


def _deviation(ctrl: np.ndarray, h: float, line: _Polyline) -> tuple[np.ndarray, np.ndarray]:
    """Per span, the largest distance of the curve from the polyline [mm] (samples refined by
    golden-section steps); and per inner end point of the polyline, its distance from the
    curve [mm] (an upper bound: to the chords between samples, plus their
    sag)."""
    m = ctrl.shape[0] - 3
    t = np.linspace(0.0, 1.0, SPAN_SAMPLES + 1)
    u = (np.arange(m)[:, None] + t[None, :]) * h
    flat = u.ravel()
    pts = points(ctrl, h, flat)
    dist = line.distance(pts, flat).reshape(m, SPAN_SAMPLES + 1)
    # refine each span's largest between its neighbouring samples
    k = dist.argmax(axis=1)
    lo = (np.arange(m) + t[np.maximum(k - 1, 0)]) * h
    hi = (np.arange(m) + t[np.minimum(k + 1, SPAN_SAMPLES)]) * h
    best = dist.max(axis=1)
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1 = line.distance(points(ctrl, h, x1), x1)
    f2 = line.distance(points(ctrl, h, x2), x2)
    for _ in range(GOLDEN_STEPS):
        left = f1 > f2
        best = np.maximum(best, np.maximum(f1, f2))
        lo, hi = np.where(left, lo, x1), np.where(left, x2, hi)
        x1n, x2n = hi - g * (hi - lo), lo + g * (hi - lo)
        x1, x2 = np.where(left, x1n, x2), np.where(left, x1, x2n)
        f1n = line.distance(points(ctrl, h, x1), x1)
        f2n = line.distance(points(ctrl, h, x2), x2)
        f1, f2 = np.where(left, f1n, f1), np.where(left, f1, f2n)
    # a margin for what lies between the samples away from the largest (a property test
    # found a curve 2.7e-5 of its deviation beyond the refined samples)
    best = np.maximum(best, np.maximum(f1, f2)) * (1.0 + DEVIATION_PAD)
    # the corners (end points) from the curve: distance to the sampled chords, plus their sag
    corners = line.pts[1:-1]
    if corners.size == 0:
        return best, np.zeros(0)
    chain = pts  # the curve's samples in order (each span's last equals the next one's first)
    seg = np.diff(chain, axis=0)
    d2 = np.diff(chain, 2, axis=0)
    sag = float(np.sqrt(np.einsum("ij,ij->i", d2, d2)).max(initial=0.0)) / 8.0 if d2.size else 0.0
    s_corner = line.s[1:-1]
    i0 = np.clip(np.searchsorted(flat, s_corner) - 1, 0, seg.shape[0] - 1)
    span = 2 * (SPAN_SAMPLES + 1)
    idx = np.clip(i0[:, None] + np.arange(-span, span + 1), 0, seg.shape[0] - 1)
    a = chain[idx]
    d = seg[idx]
    l2 = np.maximum(np.einsum("kjd,kjd->kj", d, d), 1e-300)
    wv = corners[:, None, :] - a
    tt = np.clip(np.einsum("kjd,kjd->kj", wv, d) / l2, 0.0, 1.0)
    r = wv - tt[:, :, None] * d
    near = np.sqrt(np.einsum("kjd,kjd->kj", r, r).min(axis=1))
    return best, near + sag


# ---- runs -----------------------------------------------------------------------------------


def _plane_of_run(pts: np.ndarray) -> Plane | None:
    """The principal plane every point of ``pts`` (k, 3) lies in (the first of XY, XZ, YZ)."""
    for plane in PLANES:
        n = PLANE_AXES[plane][2]
        if np.all(np.abs(pts[:, n] - pts[0, n]) <= PLANE_EPS_MM):
            return plane
    return None


def _turn(a: Linear, b: Linear) -> float:
    d0 = np.subtract(a.end, a.start)
    d1 = np.subtract(b.end, b.start)
    c = float(d0 @ d1) / math.sqrt(float(d0 @ d0) * float(d1 @ d1))
    return math.acos(max(-1.0, min(1.0, c)))


def _budget(move: Linear, settings: PathSettings, chord_tolerance_mm: float) -> float:
    from gantry_sim.controller.planner.blend import REFERENCE_SHARE

    c = control(move, settings)
    if c.mode != "G64":
        return 0.0
    return GEOMETRY_SHARE * (c.tolerance_mm - REFERENCE_SHARE * chord_tolerance_mm)


def _joins(run: Sequence[PathEntry], nxt: PathEntry) -> bool:
    """True when ``nxt`` may extend ``run`` (module docstring)."""
    last, m = run[-1], nxt.move
    first = run[0].move
    return (
        isinstance(m, Linear)
        and isinstance(first, Linear)
        and not last.stop_after
        and not nxt.holds
        and m.length_mm <= MAX_MOVE_MM
        and m.feed_mm_per_min == first.feed_mm_per_min
        and getattr(m, "path", None) == getattr(first, "path", None)
        and m.extrudes == first.extrudes
        and MIN_TURN_RAD <= _turn(last.move, m) <= MAX_TURN_RAD  # type: ignore[arg-type]
    )


def _starts(entry: PathEntry, settings: PathSettings, chord_tolerance_mm: float) -> bool:
    m = entry.move
    return (
        settings.short_moves == "fit"
        and isinstance(m, Linear)
        and m.extrudes is not False  # (a printer's travels may run under M204 T, pieces do not)
        and m.length_mm <= MAX_MOVE_MM
        and _budget(m, settings, chord_tolerance_mm) > 0
    )


class FitMemo:
    """The chunks fitted by an earlier call of :func:`fit_runs` for the same program, by their
    moves (program sources of the first and last, and whether the chunk holds the run's
    start and end): the path made again without its slow blends
    (:mod:`~gantry_sim.controller.planner.window_judge`) has the same moves, so its fits are
    the first path's. Dropped (emptied and no longer filled) for a path longer than a window,
    which is made again at most once: it would hold every piece of the whole program."""

    def __init__(self) -> None:
        self.known: dict[tuple[int, int, bool, bool], list[PathEntry]] | None = {}

    def drop(self) -> None:
        self.known = None


def _key(chunk: _Chunk) -> tuple[int, int, bool, bool]:
    return (chunk.run[0].source[0], chunk.run[-1].source[1], chunk.lead, chunk.tail)


def fit_runs(
    entries: Iterable[PathEntry],
    settings: PathSettings,
    chord_tolerance_mm: float,
    memo: FitMemo | None = None,
    *,
    jerk_mm_per_s3: float = math.inf,
    feed_scale: float = 1.0,
    acc_mm_per_s2: float = math.inf,
) -> Iterator[PathEntry]:
    """The entries with each run of short straight moves (module docstring) replaced by: the
    first half of its first move, the fitted curve's pieces (each an entry with a
    :class:`~gantry_sim.controller.moves.Transition` and its ``fit``), the second half of its
    last move. A run that does not fit comes as it was, and so does one that corner blends
    would pass as fast as the curvature allows (``jerk_mm_per_s3`` and ``acc_mm_per_s2``: the
    machine's lowest axis jerk [mm/s^3] and acceleration [mm/s^2], inf: none is fitted;
    ``feed_scale``: the feed override [1]). Runs are fitted :data:`BATCH_CHUNKS`
    chunks at a time over the processes (:func:`~gantry_sim.controller.forked.fork_map`)."""
    fit = functools.partial(
        _fit_chunks,
        settings=settings,
        chord_tolerance_mm=chord_tolerance_mm,
        jerk_mm_per_s3=jerk_mm_per_s3,
        feed_scale=feed_scale,
        acc_mm_per_s2=acc_mm_per_s2,
    )
    queue: list[PathEntry | _Chunk] = []  # in order: entries as they are, and chunks to fit
    chunks = 0

    def flush() -> Iterator[PathEntry]:
        nonlocal chunks
        known = None if memo is None else memo.known
        jobs = [q for q in queue if isinstance(q, _Chunk)]
        done = {id(job): known[_key(job)] for job in jobs if known and _key(job) in known}
        jobs = [job for job in jobs if id(job) not in done]
        groups = max(1, min(process_count(), len(jobs)))
        made = fork_map(fit, [jobs[g::groups] for g in range(groups)])
        for g in range(groups):
            for job, out in zip(jobs[g::groups], made[g], strict=True):
                done[id(job)] = out
                if known is not None:
                    known[_key(job)] = out
        for q in queue:
            if isinstance(q, _Chunk):
                yield from done[id(q)]
            else:
                yield q
        queue.clear()
        chunks = 0

    it = iter(entries)
    prev: PathEntry | None = None  # the entry before ``cur``
    cur = next(it, None)
    while cur is not None:
        if not _starts(cur, settings, chord_tolerance_mm):
            if queue:  # behind chunks still to fit
                queue.append(cur)
            else:  # nothing waits: the entry goes on at once (a program with no run streams)
                yield cur
            prev, cur = cur, next(it, None)
            continue
        # a run that starts or ends at rest starts or ends at its end point, not a half-move
        rest = prev is None or prev.stop_after or bool(cur.holds) or isinstance(prev.move, Rapid)
        run, lead, before = [cur], True, None
        prev, cur = cur, next(it, None)
        while cur is not None and _joins(run, cur):
            run.append(cur)
            prev, cur = cur, next(it, None)
            if len(run) >= CHUNK_MOVES + CUT_MOVES and cur is not None:
                # cut at the longest move of the last CUT_MOVES: the curve meets it in its middle
                window = range(CHUNK_MOVES, len(run) - 1)  # (the move after it in the run)
                c = max(window, key=lambda i: run[i].move.length_mm)
                queue.append(_Chunk(run[: c + 1], lead, False, before, run[c + 1].move, rest))
                chunks += 1
                run, lead, before, rest = run[c:], False, run[c - 1].move, False
        if len(run) >= MIN_RUN_MOVES or not lead:
            stops = cur is None or run[-1].stop_after or bool(cur.holds)
            stops = stops or (cur is not None and isinstance(cur.move, Rapid))
            queue.append(_Chunk(run, lead, True, before, None, rest, stops))
            chunks += 1
        else:
            queue.extend(run)
        if chunks >= BATCH_CHUNKS or (chunks == 0 and queue) or len(queue) > QUEUE_ENTRIES:
            yield from flush()
    yield from flush()


@dataclass
class _Chunk:
    """Consecutive moves of a run, fitted from the middle of the first to the middle of the
    last; ``lead``/``tail``: the first/last half of those moves is the run's own (else the
    chunk before/after has it)."""

    run: list[PathEntry]
    lead: bool
    tail: bool
    before: PathMove | None  # the move before the first (where the chunk before has it)
    after: PathMove | None  # the move after the last (where the chunk after has it)
    rest_before: bool = False  # the run starts at rest: the curve from the first's start
    rest_after: bool = False  # the run ends at rest: the curve to the last's end


def _fit_chunks(
    chunks: list[_Chunk],
    settings: PathSettings,
    chord_tolerance_mm: float,
    jerk_mm_per_s3: float,
    feed_scale: float,
    acc_mm_per_s2: float,
) -> list[list[PathEntry]]:
    limits = (jerk_mm_per_s3, feed_scale, acc_mm_per_s2)
    return [_fit_entries(c, settings, chord_tolerance_mm, *limits) for c in chunks]


def _fit_entries(
    chunk: _Chunk,
    settings: PathSettings,
    chord_tolerance_mm: float,
    jerk_mm_per_s3: float = math.inf,
    feed_scale: float = 1.0,
    acc_mm_per_s2: float = math.inf,
) -> list[PathEntry]:
    """The entries a chunk becomes: its lead half-move, the curve's pieces, its tail half-move;
    or its moves as they were where no curve fits (:func:`_unfitted`), or where corner blends
    would pass it as fast as its curvature allows anyway (:func:`_blends_slow`, under the
    machine's lowest jerk ``jerk_mm_per_s3`` [mm/s^3] and acceleration ``acc_mm_per_s2``
    [mm/s^2], and the feed override ``feed_scale``)."""
    run = chunk.run
    moves: list[Linear] = [e.move for e in run]  # type: ignore[misc]
    pts3 = np.array([moves[0].start] + [m.end for m in moves], dtype=float)
    plane = _plane_of_run(pts3)
    budget = _budget(moves[0], settings, chord_tolerance_mm)
    if plane is None or budget <= 0 or len(run) < 2:
        return _unfitted(chunk)
    ax = PLANE_AXES[plane]
    pts = pts3[:, [ax[0], ax[1]]]
    normal = float(pts3[0, ax[2]])
    d_first = (pts[1] - pts[0]) / moves[0].length_mm
    d_last = (pts[-1] - pts[-2]) / moves[-1].length_mm
    lead = 0.0 if chunk.rest_before else 0.5 * moves[0].length_mm
    tail = 0.0 if chunk.rest_after else 0.5 * moves[-1].length_mm
    line = _Polyline(pts)
    feed = moves[0].feed_mm_per_min / 60.0 * feed_scale
    if not _blends_slow(line, budget, feed, jerk_mm_per_s3, acc_mm_per_s2):
        return _unfitted(chunk)
    poly = _clip(line, lead, float(line.s[-1]) - tail)
    if chunk.rest_before:  # the polyline's own turning there (the stop hides any jump)
        k_first = _turn_rate(moves[0], moves[1], ax)
    else:
        k_first = _join_curvature(chunk.before, moves[0], moves[1], ax) if chunk.before else 0.0
    if chunk.rest_after:
        k_last = _turn_rate(moves[-2], moves[-1], ax)
    else:
        k_last = _join_curvature(moves[-2], moves[-1], chunk.after, ax) if chunk.after else 0.0
    start = (pts[0] + lead * d_first, d_first, k_first * _left(d_first))
    end = (pts[-1] - tail * d_last, d_last, k_last * _left(d_last))
    fit = fit_curve(poly, budget, start, end)
    if fit is None:
        return _unfitted(chunk)
    m = fit.spans
    quintic2 = bezier_pieces(fit.ctrl)
    quintic = np.empty((m, 6, 3))
    quintic[:, :, ax[0]] = quintic2[:, :, 0]
    quintic[:, :, ax[1]] = quintic2[:, :, 1]
    quintic[:, :, ax[2]] = normal
    rows = QuinticCurve.rows(quintic)
    # the curve's ends, as the halves (or the chunks next to this one) hold them
    a = moves[0].start if chunk.rest_before else _middle(moves[0])
    z = moves[-1].end if chunk.rest_after else _middle(moves[-1])
    out: list[PathEntry] = []
    if chunk.lead and not chunk.rest_before:
        out.append(PathEntry(replace(moves[0], end=a), False, run[0].holds, run[0].source))
    # each piece's moves: those its arc length range meets
    edges = lead + np.arange(m + 1) * fit.h
    at = len(run) - 1
    lo = np.clip(np.searchsorted(line.s, edges[:-1], side="right") - 1, 0, at)
    hi = np.clip(np.searchsorted(line.s, edges[1:], side="left") - 1, 0, at)
    mid = np.clip(np.searchsorted(line.s, 0.5 * (edges[:-1] + edges[1:]), side="right") - 1, 0, at)
    dev = np.maximum(fit.span_deviation_mm, fit.corner_deviation_mm)
    first = moves[0]
    tol = control(first, settings).tolerance_mm
    prev = a
    for k in range(m):
        end_pt = z if k == m - 1 else _v3(quintic[k, 5])
        piece = Transition(
            line=moves[int(mid[k])].line,
            start=prev,
            end=end_pt,
            feed_mm_per_min=first.feed_mm_per_min,
            plane=plane,
            row=rows[k].tobytes(),
            path=first.path,
        )
        prev = end_pt
        src = (run[int(lo[k])].source[0], run[int(hi[k])].source[1])
        holds = run[0].holds if k == 0 and chunk.rest_before else []
        stop = k == m - 1 and chunk.rest_after and run[-1].stop_after
        fit_blend = Blend(piece.line, float(dev[k]), tol, "fit", first.file)
        out.append(PathEntry(piece, stop, holds, src, fit_blend))
    if chunk.tail and not chunk.rest_after:
        out.append(PathEntry(replace(moves[-1], start=z), run[-1].stop_after, [], run[-1].source))
    return out


def _blends_slow(
    line: _Polyline, budget_mm: float, feed_mm_per_s: float, jerk: float, acc: float
) -> bool:
    """True when corner blends within ``budget_mm`` [mm] would pass at least
    :data:`SLOW_SHARE` of the inner moves of ``line`` below :data:`SLOW_FEED` of what their
    curvature itself allows, under the jerk ``jerk`` [mm/s^3] and acceleration ``acc``
    [mm/s^2]: the feed [mm/s], v^2 k <= acc and v^3 k^2 <= jerk, which a fitted curve of that
    curvature could not pass faster either. A turn phi's blend of radius R leaves the corner by
    R (sec(phi/2) - 1) and takes R tan(phi/2) of each move (at most half of it); where two
    blends meet (nothing of the move left between them) their curvatures jump by dk, and the
    jump is passed at v^2 dk <= 1.1447 (e J^2)^(1/3) at most, e the smoothing's share of the
    budget (benchmarks/junction_floor.py's ceiling); where a line stays between them, the jump
    from it to each arc (dk = 1/R) counts the same way. Blends that would use up the move
    between them within blend.MEET_SHARE of the whole budget take that, as blend.py makes them
    (a 72-gon of R 10: one chain of equal arcs, no jump). (pcb2gcode's isolation passes around
    pads, 0.13 mm moves on circles of R 1.5 at F360 in/min: curvature-bound either way, and
    29 % slower fitted, since each short run's curve leaves and meets its halves straight.)"""
    d = line.seg / np.maximum(line.len, 1e-300)[:, None]
    cross = d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0]
    phi = np.arctan2(cross, np.einsum("ij,ij->i", d[:-1], d[1:]))  # signed, at each inner end
    half = 0.5 * np.abs(phi)
    sec_less_1 = 1.0 / np.cos(half) - 1.0
    tan = np.tan(half)
    room = 0.5 * np.minimum(line.len[:-1], line.len[1:])
    inner = line.len[1:-1]
    if inner.size == 0:
        return False
    with np.errstate(divide="ignore", invalid="ignore"):

        def taken_mm(deviation_mm: float) -> np.ndarray:
            """What each corner's blend takes of its moves [mm] leaving the corner by
            ``deviation_mm``: R tan(phi/2), R from R (sec(phi/2) - 1) = deviation, at most
            half the shorter move."""
            return np.minimum(
                np.where(sec_less_1 > 0, deviation_mm / sec_less_1 * tan, np.inf), room
            )

        take = taken_mm(budget_mm)
        # blends that can use up the move between them within MEET_SHARE of the whole budget
        # do (blend.py): a regular polygon's become one chain of equal arcs, with no jump
        reach = taken_mm(MEET_SHARE * budget_mm / GEOMETRY_SHARE)
        used_up = reach[:-1] + reach[1:] >= 0.99 * inner
        grown = np.zeros(len(take), dtype=bool)
        grown[:-1] |= used_up
        grown[1:] |= used_up
        take = np.where(grown, np.maximum(take, reach), take)
        k = np.where(take > 0, np.sign(phi) * tan / take, 0.0)  # each blend's signed curvature
    meets = take[:-1] + take[1:] >= 0.99 * inner
    dk = np.where(meets, np.abs(k[1:] - k[:-1]), np.maximum(np.abs(k[1:]), np.abs(k[:-1])))
    a_jump = 1.1447 * ((1.0 - GEOMETRY_SHARE) * budget_mm * jerk * jerk) ** (1.0 / 3.0)
    k_max = np.maximum(np.abs(k[1:]), np.abs(k[:-1]))
    with np.errstate(divide="ignore"):
        v = np.sqrt(a_jump / dk)
        v_curve = np.minimum(np.sqrt(acc / k_max), np.cbrt(jerk / (k_max * k_max)))
    allowed = np.minimum(feed_mm_per_s, v_curve)
    return bool(np.mean(v < SLOW_FEED * allowed) >= SLOW_SHARE)


def _left(d: np.ndarray) -> np.ndarray:
    """``d`` (2,) turned by +90 degrees in the plane."""
    return np.array([-d[1], d[0]])


def _signed_turn(m0: PathMove, m1: PathMove, ax: tuple[int, ...]) -> float:
    """The signed turn [rad] where ``m0`` meets ``m1`` (positive: towards +90 degrees in the
    plane's two axes ``ax``)."""

    def d(m: PathMove) -> np.ndarray:
        v = np.array([m.end[ax[0]] - m.start[ax[0]], m.end[ax[1]] - m.start[ax[1]]])
        return v / math.hypot(v[0], v[1])

    d0, d1 = d(m0), d(m1)
    return math.atan2(d0[0] * d1[1] - d0[1] * d1[0], d0 @ d1)


def _join_curvature(m0: PathMove, m1: PathMove, m2: PathMove | None, ax: tuple[int, ...]) -> float:
    """The signed curvature [1/mm] (positive: turning towards +90 degrees in the plane's two
    axes ``ax``) the curve has where two chunks meet, in the middle of ``m1``: the turns where
    ``m1`` meets ``m0`` and ``m2``, over the length from ``m0``'s middle to ``m2``'s. Both
    chunks compute it from the same three moves, so their curves meet with one curvature."""
    if m2 is None:
        return 0.0
    turn = _signed_turn(m0, m1, ax) + _signed_turn(m1, m2, ax)
    return turn / (0.5 * m0.length_mm + m1.length_mm + 0.5 * m2.length_mm)


def _turn_rate(m0: PathMove, m1: PathMove, ax: tuple[int, ...]) -> float:
    """The signed turn where ``m0`` meets ``m1`` over half their lengths [1/mm]: the polyline's
    curvature there (a polygon's turn over its side: its circle's, to first order)."""
    return _signed_turn(m0, m1, ax) / (0.5 * m0.length_mm + 0.5 * m1.length_mm)


def _middle(m: Linear) -> tuple[float, float, float]:
    """The middle of a straight move [mm] (where chunks of a run meet)."""
    return (
        0.5 * (m.start[0] + m.end[0]),
        0.5 * (m.start[1] + m.end[1]),
        0.5 * (m.start[2] + m.end[2]),
    )


def _v3(p: np.ndarray) -> tuple[float, float, float]:
    return (float(p[0]), float(p[1]), float(p[2]))


def _clip(line: _Polyline, s0: float, s1: float) -> np.ndarray:
    """The polyline between arc lengths ``s0`` and ``s1`` (its end points inside, and the two
    cut points)."""
    inner = line.pts[(line.s > s0) & (line.s < s1)]
    ends = line.at(np.array([s0, s1]))
    return np.vstack([ends[:1], inner, ends[1:]])


def _unfitted(chunk: _Chunk) -> list[PathEntry]:
    """A chunk that does not fit: its moves as they were, the first from its middle where the
    chunk before has its first half, the last to its middle where the chunk after has the
    rest (straight halves: they meet in line)."""
    out = list(chunk.run)
    if not chunk.lead:
        e, m = out[0], out[0].move
        assert isinstance(m, Linear)  # (a run's moves are)
        out[0] = PathEntry(replace(m, start=_middle(m)), e.stop_after, [], e.source)
    if not chunk.tail:
        e, m = out[-1], out[-1].move
        assert isinstance(m, Linear)
        out[-1] = PathEntry(replace(m, end=_middle(m)), False, e.holds, e.source)
    return out
