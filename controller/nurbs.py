"""Exact NURBS evaluation: points and derivatives, vectorised over the parameter.

A NURBS curve of degree p with control points P_i, weights w_i > 0 and knots t_0..t_{n+p+1}
(clamped: the first and last p + 1 knots equal) is C(t) = A(t) / W(t), where
A(t) = sum N_{i,p}(t) w_i P_i and W(t) = sum N_{i,p}(t) w_i are one B-spline in homogeneous
coordinates (w x, w y, w z, w). De Boor's algorithm and the derivative B-splines (control
points p (Q_{i+1} - Q_i) / (t_{i+p+1} - t_{i+1}), degree p - 1) give, once per curve, each knot
span's polynomial (its Taylor coefficients at the span's start); points and derivatives are then
Horner's rule on those, and the curve's derivatives follow from the quotient rule:

    C'   = (A'   - W' C) / W
    C''  = (A''  - 2 W' C'  - W'' C) / W
    C''' = (A''' - 3 W' C'' - 3 W'' C' - W''' C) / W

LinuxCNC's G5 (cubic Bezier), G5.1 (quadratic Bezier) and G5.2/G5.3 (NURBS) are all of this form
(see :func:`linuxcnc_knots`). Units: whatever the control points are in (mm here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def linuxcnc_knots(n_points: int, order: int) -> tuple[float, ...]:
    """LinuxCNC's knot vector for ``n_points`` control points and ``order`` (= degree + 1):
    knot i (0 <= i <= n + k, n = n_points - 1, k = order) is 0 for i < k, i - k + 1 for
    k <= i <= n, and n - k + 2 beyond (rs274ngc nurbs_additional_functions.cc,
    knot_vector_creator): uniform, clamped, unit spacing, parameter range [0, n - k + 2]."""
    n, k = n_points - 1, order
    return tuple(
        float(0 if i < k else (i - k + 1 if i <= n else n - k + 2)) for i in range(n + k + 1)
    )


@dataclass(frozen=True, eq=False)
class BSpline:
    """A (non-rational) B-spline: ``ctrl`` (n + 1, d), ``knots`` (n + p + 2,), degree ``p``."""

    ctrl: np.ndarray
    knots: np.ndarray
    degree: int

    def derivative(self) -> BSpline:
        """The derivative B-spline (degree p - 1; a zero constant for degree 0)."""
        p, t, q = self.degree, self.knots, self.ctrl
        if p == 0:
            return BSpline(np.zeros_like(q[:1]), t[:2].copy(), 0)
        span = t[p + 1 : p + len(q)] - t[1 : len(q)]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where(span[:, None] > 0, p * np.diff(q, axis=0) / span[:, None], 0.0)
        return BSpline(d, t[1:-1].copy(), p - 1)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Values (m, d) at parameters ``u`` (m,) (de Boor; clamped to the knot range)."""
        p, t, q = self.degree, self.knots, self.ctrl
        n = len(q) - 1
        u = np.clip(np.asarray(u, dtype=float), t[p], t[n + 1])
        if p == 0 and n == 0:
            return np.repeat(q[:1], len(u), axis=0)
        # span j with t[j] <= u < t[j+1], p <= j <= n (u at the end: the last non-empty span)
        j = np.clip(np.searchsorted(t, u, side="right") - 1, p, n)
        idx = j[:, None] - p + np.arange(p + 1)[None, :]
        d = q[idx]  # (m, p + 1, dim)
        for r in range(1, p + 1):
            for i in range(p, r - 1, -1):
                lo = t[j - p + i]
                hi = t[j + 1 + i - r]
                den = hi - lo
                alpha = np.where(den > 0, (u - lo) / np.where(den > 0, den, 1.0), 0.0)[:, None]
                d[:, i] = (1.0 - alpha) * d[:, i - 1] + alpha * d[:, i]
        return d[:, p]


#: points :meth:`PiecewisePoly.orders` evaluates at once: it gathers (orders, points, p + 1, d)
#: coefficients, about 34 MB for a cubic's four orders at 65,536 points (a hostile G5.2 of
#: 5,000 control points asked for 135 million points at once: 24 GB)
ORDERS_CHUNK = 65_536


@dataclass(frozen=True, eq=False)
class PiecewisePoly:
    """A B-spline as one polynomial per knot span, in powers of (u - start of its span): the
    coefficients are the Taylor coefficients D^k(start) / k! from the derivative B-splines (exact,
    no fitting), so evaluating is a span look-up and Horner's rule.

    Attributes:
        breaks: (s + 1,) the distinct knots bounding the s non-empty spans.
        coeffs: (4, s, p + 1, d): for derivative order 0..3, the coefficients of that derivative.
    """

    breaks: np.ndarray
    coeffs: np.ndarray

    @classmethod
    def of(cls, spline: BSpline) -> PiecewisePoly:
        p, t = spline.degree, spline.knots
        lo, hi = t[spline.degree], t[len(spline.ctrl)]
        breaks = np.unique(t[(t >= lo) & (t <= hi)])
        starts = breaks[:-1]
        taylor = np.zeros((len(starts), p + 1, spline.ctrl.shape[1]))
        d, fact = spline, 1.0
        for k in range(p + 1):
            taylor[:, k] = d(starts) / fact
            d, fact = d.derivative(), fact * (k + 1)
        coeffs = np.zeros((4, *taylor.shape))
        for order in range(
            4
        ):  # d^order/du^order of sum c_k x^k = sum c_k k!/(k-order)! x^(k-order)
            for k in range(order, p + 1):
                falling = float(np.prod(np.arange(k - order + 1, k + 1)))
                coeffs[order, :, k - order] = taylor[:, k] * falling
        return cls(breaks, coeffs)

    def __call__(self, u: np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (m, d) at ``u`` (m,) (clamped to the breaks)."""
        return self.orders(u, order)[0]

    def orders(self, u: np.ndarray, top: int) -> list[np.ndarray]:
        """Derivatives 0..``top`` (each (m, d)) at ``u`` (m,) (clamped to the breaks), the
        span looked up once, :data:`ORDERS_CHUNK` points at a time (each point is its own:
        the same numbers). (np.minimum/np.maximum rather than np.clip: the same numbers,
        NaN included, without np.clip's overhead of ~9 us a call, which dominated planning
        programs of many small splines.)"""
        u = np.asarray(u, dtype=float)
        if u.ndim == 1 and u.size > ORDERS_CHUNK:
            parts = [
                self.orders(u[i : i + ORDERS_CHUNK], top) for i in range(0, u.size, ORDERS_CHUNK)
            ]
            return [np.concatenate([p[order] for p in parts]) for order in range(top + 1)]
        b = self.breaks
        u = np.minimum(np.maximum(u, b[0]), b[-1])
        j = np.minimum(np.maximum(np.searchsorted(b, u, side="right") - 1, 0), len(b) - 2)
        x = (u - b[j])[:, None]
        c = self.coeffs[: top + 1, j]  # (top + 1, m, p + 1, d): every order's Horner at once
        y = c[:, :, -1]
        for k in range(c.shape[2] - 2, -1, -1):
            y = y * x + c[:, :, k]
        return list(y)


@dataclass(frozen=True, eq=False)
class Nurbs:
    """A rational curve in 3-D built from control points (n + 1, 3), weights and knots.

    Attributes:
        homogeneous: the B-spline of (w x, w y, w z, w).
        poly: the same, per span (:class:`PiecewisePoly`), which evaluates it and its derivatives.
        t_min, t_max: the parameter range.
    """

    homogeneous: BSpline
    poly: PiecewisePoly
    t_min: float
    t_max: float

    @classmethod
    def build(cls, ctrl: np.ndarray, weights: np.ndarray, knots: np.ndarray, degree: int) -> Nurbs:
        ctrl = np.asarray(ctrl, dtype=float)
        w = np.asarray(weights, dtype=float)
        t = np.asarray(knots, dtype=float)
        h = BSpline(np.column_stack([ctrl * w[:, None], w]), t, degree)
        return cls(h, PiecewisePoly.of(h), float(t[degree]), float(t[len(ctrl)]))

    def derivatives(self, u: np.ndarray, order: int = 2) -> list[np.ndarray]:
        """[C, C', ..., C^(order)] at ``u`` (m,), each (m, 3), order <= 3."""
        h = self.poly.orders(np.asarray(u, dtype=float), order)
        w = [hi[:, 3:4] for hi in h]
        a = [hi[:, :3] for hi in h]
        c = [a[0] / w[0]]
        if order >= 1:
            c.append((a[1] - w[1] * c[0]) / w[0])
        if order >= 2:
            c.append((a[2] - 2.0 * w[1] * c[1] - w[2] * c[0]) / w[0])
        if order >= 3:
            c.append((a[3] - 3.0 * w[1] * c[2] - 3.0 * w[2] * c[1] - w[3] * c[0]) / w[0])
        return c

    def points(self, u: np.ndarray) -> np.ndarray:
        """C(u) (m, 3)."""
        h = self.poly(np.asarray(u, dtype=float))
        return h[:, :3] / h[:, 3:4]


def split_bspline(
    ctrl: np.ndarray, knots: np.ndarray, degree: int, u: float
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The B-spline (``ctrl`` (n + 1, d), clamped ``knots``, ``degree`` p) cut at parameter
    ``u`` (strictly inside its range) into two clamped B-splines, ((ctrl, knots) before u,
    (ctrl, knots) after u), together the same curve: u is inserted (Boehm's algorithm, The NURBS
    Book's A5.1 one knot at a time) until its multiplicity is p, so that the curve passes through
    one control point there, which the two parts share (the last of the first, the first of the
    second). Each part keeps the parameter range it had (the first [t_p, u], the second [u,
    t_{n+1}]). For a NURBS, pass its homogeneous control points (w x, w y, w z, w)."""
    q = np.asarray(ctrl, dtype=float)
    t = np.asarray(knots, dtype=float)
    p = degree
    if not t[p] < u < t[len(q)]:
        raise ValueError(f"cut at {u} outside the open range ({t[p]}, {t[len(q)]})")
    for _ in range(p - int(np.count_nonzero(t == u))):
        k = int(np.searchsorted(t, u, side="right")) - 1  # t[k] <= u < t[k + 1]
        s = int(np.count_nonzero(t == u))
        new = np.empty((len(q) + 1, q.shape[1]))
        new[: k - p + 1] = q[: k - p + 1]
        for i in range(k - p + 1, k - s + 1):
            alpha = (u - t[i]) / (t[i + p] - t[i])
            new[i] = alpha * q[i] + (1.0 - alpha) * q[i - 1]
        new[k - s + 1 :] = q[k - s :]
        q, t = new, np.insert(t, k + 1, u)
    j = int(np.searchsorted(t, u, side="left"))  # the first knot u
    first = (q[:j].copy(), np.concatenate([t[: j + p], [u]]))
    second = (q[j - 1 :].copy(), np.concatenate([[u], t[j:]]))
    return first, second
