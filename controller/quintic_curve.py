"""A quintic Bezier curve: the shape of the planner's G2 transitions, in closed form.

The planner replaces a G64 tangent junction whose curvature jumps by a quintic Bezier curve
C(t) = sum B_i^5(t) P_i, t in [0, 1], that matches position, unit tangent and curvature vector
of both moves where it meets them (:mod:`~gantry_sim.controller.planner.transition`). It is
held in the power basis, C(t) = sum_k a_k t^k with a = M P (M: Bernstein to power), so the
curve and its derivatives are Horner's rule on (6, 3) coefficients.

Arc length s(t) = integral of |C'(t)| dt: 8-point Gauss-Legendre quadrature on :data:`CELLS`
equal cells of t (|C'| is the square root of a degree-8 polynomial that varies little on these
curves: exact to 1e-13 of the length on 300 random transitions, the largest |C'| 60 x the
smallest among them), inverted by Newton steps on t (s' = |C'| > 0). Derivatives with respect
to arc length (speed v = |C'|):

    p'   = C' / v                              (unit tangent T)
    p''  = (C'' - (C''.T) T) / v^2             (curvature vector k, |k| = 1/R)
    p''' = C''' t'^3 + 3 C'' t' t'' + C' t'''  (t' = 1/v, t'' = -(C'.C'')/v^4,
                                                t''' = -(|C''|^2 + C'.C''')/v^5 + 4 (C'.C'')^2/v^7)

The bounds the planner's speed caps use, the largest |p''| [1/mm] and |p'''| [1/mm^2] (and the
largest |C'| [mm], for the chords), are the largest of :data:`BOUND_SAMPLES` points evenly
spread in t, times :data:`BOUND_MARGIN` (the quintic's curvature varies on a scale of a fifth
of t: what lies between two samples was at most 0.07 % above them on 20,001 points of 300
random transitions).

Every function here works on a batch of m curves at once (control points (m, 6, 3), power
coefficients (m, 6, 3), parameters (m, k)) or on one (the same arrays without m), with
element-wise operations only: a curve's numbers do not depend on the batch it is computed in
(the planner's windows give the whole program's plan bit for bit). Units: mm.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import comb

import numpy as np

#: Bernstein (degree 5) to power basis: a_k = sum_i POWER[k, i] P_i.
POWER = np.array(
    [
        [comb(5, k) * comb(k, i) * (-1) ** (k - i) if i <= k else 0 for i in range(6)]
        for k in range(6)
    ],
    dtype=float,
)
#: Cells of t for the arc length's quadrature, and its nodes and weights on [-1, 1].
CELLS = 4
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
#: Samples (evenly in t) of the curvature bounds, and the relative margin on their maxima.
BOUND_SAMPLES = 65
BOUND_MARGIN = 1.01
#: Newton steps of the arc-length inversion (it stops earlier within S_TOLERANCE_REL of L).
INVERT_STEPS = 12
S_TOLERANCE_REL = 1e-13
#: Samples seeding the nearest-point search on the whole curve and on a window of it (a
#: piece's points near a known parameter), and the guarded Newton steps after them.
SEED_SAMPLES = 33
WINDOW_SEED_SAMPLES = 9
#: Seeds of the analysis' nearest points on a whole transition (:meth:`QuinticCurve.nearest_points`,
#: :func:`nearest_points_on`): a transition turns by about a degree, so its distance to a point
#: has one minimum; on 200,000 points within 0.001-0.5 mm of the transitions of 2,000 generated
#: arcs (parameters -0.2 to 1.2), 9 seeds found the distances of 33 to 3e-14 mm, 2-4 x faster.
POINT_SEED_SAMPLES = 9
NEAREST_STEPS = 6


def power_coefficients(ctrl: np.ndarray) -> np.ndarray:
    """Power-basis coefficients (..., 6, 3) of Bezier control points (..., 6, 3) [mm] (each a
    sum of six terms in a fixed order)."""
    out = np.zeros(ctrl.shape)
    for k in range(6):
        for i in range(k + 1):
            out[..., k, :] += POWER[k, i] * ctrl[..., i, :]
    return out


def derivative_coefficients(coef: np.ndarray, order: int) -> np.ndarray:
    """Power coefficients (..., 6 - order, 3) of the ``order``-th derivative of ``coef``
    (..., 6, 3)."""
    k = np.arange(6 - order, dtype=float)
    falling = np.ones_like(k)
    for r in range(1, order + 1):
        falling = falling * (k + r)
    return coef[..., order:, :] * falling[:, None]


def evaluate(c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The polynomials with power coefficients ``c`` (..., d, 3) at ``t`` (..., k) -> (..., k, 3)
    (Horner's rule, element-wise)."""
    x = np.asarray(t, dtype=float)[..., None, :]  # (..., 1, k)
    d = c.shape[-2]
    if d == 1:
        return np.broadcast_to(c[..., 0:1, :], (*x.shape[:-2], x.shape[-1], 3)).copy()
    # the axes' rows (..., 3, k) in place, each a run of k numbers (5-8 x faster than rows of
    # three points); the same operations in the same order
    ct = np.swapaxes(c, -1, -2)
    y = ct[..., d - 1 : d] * x
    for j in range(d - 2, 0, -1):
        y += ct[..., j : j + 1]
        y *= x
    y += ct[..., 0:1]
    return np.ascontiguousarray(np.swapaxes(y, -1, -2))


def derivatives(coef: np.ndarray, t: np.ndarray, order: int) -> list[np.ndarray]:
    """[C, C', ..., C^(order)] (each (..., k, 3)) of the curves ``coef`` (..., 6, 3) at ``t``
    (..., k)."""
    return [evaluate(derivative_coefficients(coef, r), t) for r in range(order + 1)]


def dot_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (..., 3) arrays, element-wise (a fixed order of three terms)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def arc_length_derivatives(
    d1: np.ndarray, d2: np.ndarray, d3: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(p', p'', p''') with respect to arc length from C', C'', C''' (..., 3) (the module
    docstring's formulas)."""
    v2 = dot_rows(d1, d1)
    v = np.sqrt(v2)
    c12 = dot_rows(d1, d2)
    t1 = 1.0 / v
    t2 = -c12 / (v2 * v2)
    t3 = -(dot_rows(d2, d2) + dot_rows(d1, d3)) / (v2 * v2 * v) + 4.0 * c12 * c12 / (
        v2 * v2 * v2 * v
    )
    p1 = d1 * t1[..., None]
    p2 = d2 * (t1 * t1)[..., None] + d1 * t2[..., None]
    p3 = d3 * (t1**3)[..., None] + 3.0 * d2 * (t1 * t2)[..., None] + d1 * t3[..., None]
    return p1, p2, p3


def curvature_bounds(
    coef: np.ndarray, samples: int = BOUND_SAMPLES
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(largest |p''| [1/mm], largest |p'''| [1/mm^2], largest |C'| [mm]) (...,) of the curves
    ``coef`` (..., 6, 3): ``samples`` points evenly spread in t, times :data:`BOUND_MARGIN`."""
    t = np.broadcast_to(np.linspace(0.0, 1.0, samples), (*coef.shape[:-2], samples))
    _, d1, d2, d3 = derivatives(coef, t, 3)
    _, p2, p3 = arc_length_derivatives(d1, d2, d3)
    k = np.sqrt(dot_rows(p2, p2)).max(axis=-1)
    dk = np.sqrt(dot_rows(p3, p3)).max(axis=-1)
    speed = np.sqrt(dot_rows(d1, d1)).max(axis=-1)
    return BOUND_MARGIN * k, BOUND_MARGIN * dk, BOUND_MARGIN * speed


def _speed(coef1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """|C'| (..., k) at ``t`` (..., k) from the first derivative's coefficients (..., 5, 3)."""
    d1 = evaluate(coef1, t)
    return np.sqrt(dot_rows(d1, d1))


def arc_length(coef1: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Arc length [mm] (..., k) from ``a`` to ``b`` (..., k) (Gauss-Legendre, one interval
    each; ``coef1``: the first derivative's coefficients (..., 5, 3))."""
    half = 0.5 * (b - a)
    nodes = (0.5 * (a + b))[..., None] + half[..., None] * _GL_X
    shape = nodes.shape
    speed = _speed(coef1, nodes.reshape(*shape[:-2], shape[-2] * 8)).reshape(shape)
    return half * (speed * _GL_W).sum(axis=-1)


def lengths_at(coef1: np.ndarray, cum: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Arc length [mm] (N,) from the start of each point's curve to its parameter ``t`` (N,)
    (clamped to [0, 1]); per point: its curve's first-derivative coefficients ``coef1``
    (N, 5, 3) and cell lengths ``cum`` (N, CELLS + 1)."""
    t = np.clip(np.asarray(t, dtype=float), 0.0, 1.0)
    cell = np.minimum((t * CELLS).astype(np.intp), CELLS - 1)
    piece = arc_length(coef1, (cell / CELLS)[:, None], t[:, None])[:, 0]
    return cum[np.arange(t.size), cell] + piece


def parameters_at(coef1: np.ndarray, cum: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The parameters (N,) where each point's curve (as :func:`lengths_at`) has run ``s``
    [mm] (N,) (clamped to the curve): Newton steps from the linear guess within the
    quadrature cell, each point until within :data:`S_TOLERANCE_REL` of its curve's
    length."""
    length = cum[:, -1]
    s = np.clip(np.asarray(s, dtype=float), 0.0, length)
    cell = np.minimum((cum[:, 1:-1] <= s[:, None]).sum(axis=1), CELLS - 1)
    rows = np.arange(s.size)
    c0, c1 = cum[rows, cell], cum[rows, cell + 1]
    frac = np.where(c1 > c0, (s - c0) / np.where(c1 > c0, c1 - c0, 1.0), 0.0)
    t = (cell + frac) / CELLS
    tol = S_TOLERANCE_REL * np.maximum(length, 1e-6)
    active = np.arange(s.size)
    for _ in range(INVERT_STEPS):
        ta = t[active]
        f = lengths_at(coef1[active], cum[active], ta) - s[active]
        moving = np.abs(f) > tol[active]
        active, ta, f = active[moving], ta[moving], f[moving]
        if not active.size:
            break
        t[active] = np.clip(ta - f / _speed(coef1[active], ta[:, None])[:, 0], 0.0, 1.0)
    return t


def nearest_parameters(
    coef: np.ndarray,
    q: np.ndarray,
    t_lo: np.ndarray,
    t_hi: np.ndarray,
    seeds: int = SEED_SAMPLES,
    t_start: np.ndarray | None = None,
) -> np.ndarray:
    """Parameters t (m, k) of the points of each curve ``coef`` (m, 6, 3) nearest to its
    points ``q`` (m, k, 3) [mm], searched on [t_lo, t_hi] (m,): from ``t_start`` (m, k) when
    given, else from the nearest of ``seeds`` samples, guarded Newton steps on
    f(t) = |C(t) - q|^2 (a step is kept only where it lowers f, so a point's search does not
    depend on the others')."""
    c0, c1, c2 = (derivative_coefficients(coef, r) for r in range(3))
    lo, hi = t_lo[:, None], t_hi[:, None]
    if t_start is None:
        frac = np.linspace(0.0, 1.0, seeds)
        ts = lo + (hi - lo) * frac[None, :]  # (m, S)
        rel = q[:, :, None, :] - evaluate(c0, ts)[:, None, :, :]
        f_all = dot_rows(rel, rel)
        best = np.argmin(f_all, axis=2)
        t = np.take_along_axis(ts, best, axis=1)
        f = np.take_along_axis(f_all, best[:, :, None], axis=2)[:, :, 0]
    else:
        t = np.minimum(np.maximum(t_start, lo), hi)
        r0 = evaluate(c0, t) - q
        f = dot_rows(r0, r0)
    # each point steps until a step no longer lowers f or moves t by more than rounding
    # (1e-13): what a point does depends on it alone
    rows, cols = np.nonzero(np.ones(t.shape, dtype=bool))
    for _ in range(NEAREST_STEPS):
        if not rows.size:
            break
        ta, qa = t[rows, cols], q[rows, cols]
        c0a, c1a, c2a = c0[rows], c1[rows], c2[rows]
        x = ta[:, None]
        r = evaluate(c0a, x)[:, 0] - qa
        d1, d2 = evaluate(c1a, x)[:, 0], evaluate(c2a, x)[:, 0]
        g = dot_rows(r, d1)
        h = dot_rows(d1, d1) + dot_rows(r, d2)
        step = np.where(h > 0, -g / np.where(h > 0, h, 1.0), 0.0)
        nt = np.minimum(np.maximum(ta + step, lo[rows, 0]), hi[rows, 0])
        nr = evaluate(c0a, nt[:, None])[:, 0] - qa
        nf = dot_rows(nr, nr)
        better = nf < f[rows, cols]
        t[rows[better], cols[better]] = nt[better]
        f[rows[better], cols[better]] = nf[better]
        moving = better & (np.abs(nt - ta) > 1e-13)
        rows, cols = rows[moving], cols[moving]
    return t


#: Points searched at once by :func:`nearest_points_on` (its seeds take about 0.8 KB a point).
NEAREST_BATCH = 8192


def nearest_points_on(rows: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) [mm] to ``q`` (n, 3) [mm], point i on the whole curve of packed
    row ``rows[i]`` ((n, :data:`ROW`), :meth:`QuinticCurve.rows`), from
    :data:`POINT_SEED_SAMPLES` seeds: the points of many curves in a few numpy calls, each
    point's numbers its own (element-wise operations only), whatever the batch."""
    rows = np.asarray(rows, dtype=float).reshape(-1, ROW)
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    out = np.empty_like(q)
    for lo in range(0, len(q), NEAREST_BATCH):
        r, qq = rows[lo : lo + NEAREST_BATCH], q[lo : lo + NEAREST_BATCH]
        n = len(qq)
        coef = row_coefficients(r)
        t = nearest_parameters(coef, qq[:, None, :], np.zeros(n), np.ones(n), POINT_SEED_SAMPLES)
        out[lo : lo + n] = points_on_rows(r, t)[:, 0]
    return out


#: The layout of a curve's numbers in its packed row (:class:`QuinticCurve`): its power
#: coefficients (6, 3), end points (2, 3), quadrature cells' arc lengths (CELLS + 1) and the
#: bounds (|p''|, |p'''|, |C'|).
_COEF, _ENDS, _CUM = slice(0, 18), slice(18, 24), slice(24, 25 + CELLS)
_BOUNDS = slice(25 + CELLS, 28 + CELLS)
ROW = 28 + CELLS
#: Power to Bernstein basis (POWER's inverse): the control points of power coefficients.
BERNSTEIN = np.linalg.inv(POWER)


def packed_rows(packed: Sequence[bytes]) -> np.ndarray:
    """The rows (m, :data:`ROW`) of curves kept as their rows' bytes (``Transition.row``), in
    one array (the same numbers :meth:`QuinticCurve.from_row` reads)."""
    return np.frombuffer(b"".join(packed), dtype=float).reshape(len(packed), ROW)


def row_cells(rows: np.ndarray) -> np.ndarray:
    """The quadrature cells' arc lengths (m, CELLS + 1) [mm] of packed rows (a view)."""
    return rows[:, _CUM]


def row_ends(rows: np.ndarray) -> np.ndarray:
    """The end points (m, 2, 3) [mm] of the curves of packed rows ``rows`` (a view)."""
    return rows[:, _ENDS].reshape(rows.shape[0], 2, 3)


def row_coefficients(rows: np.ndarray) -> np.ndarray:
    """The power coefficients (m, 6, 3) of the curves of packed rows ``rows`` (m, :data:`ROW`)
    (a view)."""
    return rows[:, _COEF].reshape(rows.shape[0], 6, 3)


def points_on_rows(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """C(t) (m, k, 3) [mm] of the curves of packed rows ``rows`` (m, :data:`ROW`) at their
    parameters ``t`` (m, k): :meth:`QuinticCurve.points` of each, at once (element-wise: the
    same numbers; t = 0 and 1 give the end points exactly)."""
    t = np.asarray(t, dtype=float)
    pts = evaluate(row_coefficients(rows), t)
    ends = rows[:, _ENDS].reshape(rows.shape[0], 2, 1, 3)
    for end, at in ((0, t <= 0.0), (1, t >= 1.0)):
        if at.any():
            pts[at] = np.broadcast_to(ends[:, end], pts.shape)[at]
    return pts


def end_frames(coef: np.ndarray) -> np.ndarray:
    """(T_start, k_start, T_end, k_end) (m, 4, 3) of the curves ``coef`` (m, 6, 3): unit
    tangents and curvature vectors [1/mm] at their ends."""
    ends = np.broadcast_to(np.array([0.0, 1.0]), (coef.shape[0], 2))
    d1, d2 = (evaluate(derivative_coefficients(coef, r), ends) for r in (1, 2))
    v2 = dot_rows(d1, d1)
    tangent = d1 / np.sqrt(v2)[..., None]
    normal = (d2 - dot_rows(d2, tangent)[..., None] * tangent) / v2[..., None]
    return np.stack([tangent[:, 0], normal[:, 0], tangent[:, 1], normal[:, 1]], axis=1)


class QuinticCurve:
    """One quintic Bezier curve (see the module docstring); :meth:`batch` makes many at once,
    with the same numbers. Its numbers are one packed row of floats (:data:`ROW`; a batch's
    rows are one array): a transition keeps its curve as that row's bytes (``from_row``), so
    the planner holds no other object per transition of the whole program.

    Attributes (read from the row):
        control_points: (6, 3) [mm] (the ends exactly; the inner four from the coefficients,
            to rounding).
        coef: (6, 3) its power-basis coefficients.
        cum: (CELLS + 1,) arc length [mm] from the start to each quadrature cell's bound.
        bounds: (largest |p''| [1/mm], largest |p'''| [1/mm^2]) along the curve.
        speed_max: largest |C'| [mm per unit t].
        end_frames: (T_start, k_start, T_end, k_end): unit tangents and curvature vectors
            [1/mm] at its ends (:func:`end_frames`, computed when asked for).
    """

    __slots__ = ("row",)

    def __init__(self, control_points: np.ndarray) -> None:
        self.row = QuinticCurve.rows(np.asarray(control_points, dtype=float).reshape(1, 6, 3))[0]

    @classmethod
    def from_row(cls, row: np.ndarray | bytes) -> QuinticCurve:
        """The curve of a packed row (:meth:`rows`; bytes: its float64 buffer, not copied)."""
        c = object.__new__(cls)
        c.row = np.frombuffer(row, dtype=float) if isinstance(row, bytes) else row
        return c

    @classmethod
    def batch(cls, ctrl: np.ndarray) -> list[QuinticCurve]:
        """The curves of control points ``ctrl`` (m, 6, 3) [mm], their arc lengths and
        bounds computed for all at once."""
        out = []
        for row in cls.rows(ctrl):
            c = object.__new__(cls)
            c.row = row
            out.append(c)
        return out

    @staticmethod
    def rows(ctrl: np.ndarray) -> np.ndarray:
        """The packed rows (m, :data:`ROW`) of the curves of control points ``ctrl`` (m, 6, 3)."""
        ctrl = np.asarray(ctrl, dtype=float)
        m = ctrl.shape[0]
        coef = power_coefficients(ctrl)
        coef1 = derivative_coefficients(coef, 1)
        grid = np.linspace(0.0, 1.0, CELLS + 1)
        a = np.broadcast_to(grid[:-1], (m, CELLS))
        b = np.broadcast_to(grid[1:], (m, CELLS))
        cum = np.concatenate([np.zeros((m, 1)), np.cumsum(arc_length(coef1, a, b), axis=1)], 1)
        k, dk, speed = curvature_bounds(coef)
        out = np.empty((m, ROW))
        out[:, _COEF] = coef.reshape(m, 18)
        out[:, _ENDS] = ctrl[:, [0, 5]].reshape(m, 6)
        out[:, _CUM] = cum
        out[:, _BOUNDS] = np.stack([k, dk, speed], axis=1)
        return out

    @property
    def control_points(self) -> np.ndarray:
        ctrl = BERNSTEIN @ self.coef
        ctrl[[0, 5]] = self.row[_ENDS].reshape(2, 3)
        return ctrl

    @property
    def coef(self) -> np.ndarray:
        return self.row[_COEF].reshape(6, 3)

    @property
    def cum(self) -> np.ndarray:
        return self.row[_CUM]

    @property
    def bounds(self) -> tuple[float, float]:
        return float(self.row[_BOUNDS][0]), float(self.row[_BOUNDS][1])

    @property
    def speed_max(self) -> float:
        return float(self.row[_BOUNDS][2])

    @property
    def end_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        f = end_frames(self.coef[None])[0]
        return f[0], f[1], f[2], f[3]

    def _order(self, r: int) -> np.ndarray:
        """The power coefficients of the r-th derivative."""
        return derivative_coefficients(self.coef, r)

    @property
    def length_mm(self) -> float:
        return float(self.cum[-1])

    def derivatives(self, t: np.ndarray, order: int = 2) -> list[np.ndarray]:
        """[C, C', ..., C^(order)] (each (k, 3) [mm]) at parameters ``t`` (k,), order <= 3."""
        return [evaluate(self._order(r), t) for r in range(order + 1)]

    def points(self, t: np.ndarray) -> np.ndarray:
        """C(t) (k, 3) [mm]; t = 0 and 1 give the end control points exactly."""
        return points_on_rows(self.row[None], np.asarray(t, dtype=float)[None])[0]

    def speed(self, t: np.ndarray) -> np.ndarray:
        """|C'(t)| [mm per unit t] (k,)."""
        return _speed(self._order(1), t)

    def speed_rate(self, t: np.ndarray) -> np.ndarray:
        """d|C'|/dt = C'.C'' / |C'| [mm] (k,) at parameters ``t``: what the planner needs where
        its parameter (here t) is not the arc-length fraction."""
        d1, d2 = evaluate(self._order(1), t), evaluate(self._order(2), t)
        return dot_rows(d1, d2) / np.sqrt(dot_rows(d1, d1))

    def _rows(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The first derivative's coefficients and the cell lengths, once per point (views)."""
        return np.broadcast_to(self._order(1), (k, 5, 3)), np.broadcast_to(self.cum, (k, CELLS + 1))

    def s_of_t(self, t: np.ndarray) -> np.ndarray:
        """Arc length [mm] from the start to parameters ``t`` (k,) (:func:`lengths_at`)."""
        t = np.asarray(t, dtype=float).ravel()
        return lengths_at(*self._rows(t.size), t)

    def t_of_s(self, s: np.ndarray) -> np.ndarray:
        """The parameters (k,) at arc lengths ``s`` [mm] (:func:`parameters_at`)."""
        s = np.asarray(s, dtype=float).ravel()
        return parameters_at(*self._rows(s.size), s)

    def nearest(
        self, q: np.ndarray, t_lo: float = 0.0, t_hi: float = 1.0, seeds: int = SEED_SAMPLES
    ) -> np.ndarray:
        """Parameters t (k,) of the points of the curve nearest to ``q`` (k, 3) [mm], searched
        on [t_lo, t_hi] (:func:`nearest_parameters`)."""
        q = np.asarray(q, dtype=float).reshape(1, -1, 3)
        lo, hi = np.array([t_lo]), np.array([t_hi])
        return nearest_parameters(self.coef[None], q, lo, hi, seeds)[0]

    def nearest_points(self, q: np.ndarray) -> np.ndarray:
        """Nearest points (k, 3) [mm] on the whole curve to ``q`` (k, 3) [mm]
        (:func:`nearest_points_on`)."""
        q = np.asarray(q, dtype=float).reshape(-1, 3)
        return nearest_points_on(np.broadcast_to(self.row, (len(q), ROW)), q)
