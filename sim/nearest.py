"""Nearest points on the COMMANDED geometry: line segments, arcs, helices, vectorised over points
that may each belong to a different move.

Used by the analysis to measure contour error against what the program asked for (true arcs from
controller/arcs.py, not the chords). All coordinates are program (work) coordinates [mm]. The
moves are first laid out as arrays (:class:`MoveTable`, one row per move); every function then
takes, per point, the index of the move to project it on, so one call covers any mix of moves.

Segment a-b: u = clip((q - a).d / d.d, 0, 1) with d = b - a, nearest point a + u d.
Arc / helix (parametrised by the sweep fraction u in [0, 1], see controller.arcs):
  1. angle projection: the point's polar angle phi about the centre gives the sweep fractions
     u_k = (sigma (phi - theta0) mod 2 pi + 2 pi k) / A, one per turn k = 0..ceil(A / 2 pi);
     with the ends u = 0 and u = 1 they are the candidates (clamped to [0, 1]); the closest
     wins (the first one on a tie). For a planar arc of constant radius this is exact: the
     distance grows with the angle off phi.
  2. helix or spiral (height or radius changing with u): a few guarded Newton steps on
     f(u) = |p(u) - q|^2 from the best candidate (f' = 2 (p - q).p', f'' = 2 (p'.p' + (p - q).p'')),
     clamped to [0, 1], each accepted only when it lowers f.

Spline (G5, G5.1, G5.2; controller/spline_curve.py): the nearest of samples spread evenly over
the spline's parameter (4 per grid cell, 128 per knot span), then guarded Newton steps on
f(t) = |C(t) - q|^2 (each kept only where it lowers f), clamped to the curve. A G2 transition
on the path the planner followed (controller/quintic_curve.py) likewise: the nearest of 33
samples of its parameter, then the same Newton steps.

Every point's result depends on that point and its move only (not on which other points share
the call), so a trace may be cut anywhere and analysed piece by piece with identical numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import cached_property

import numpy as np

from gantry_sim.controller.quintic_curve import QuinticCurve, nearest_points_on
from gantry_sim.sim.move_table import MoveTable, move_table

__all__ = [
    "MoveTable",
    "move_table",
    "nearest_on_arc",
    "nearest_on_move",
    "nearest_on_moves",
]

NEWTON_STEPS = 6
TWO_PI = 2.0 * math.pi


def _dot_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _nearest_on_segments(tab: MoveTable, idx: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Nearest points on segments ``idx`` (n,) to ``pts`` (n, 3) [mm]: u = (q - a).d / d.d,
    clipped to [0, 1] (0 on a segment of zero length). The projection is taken element by
    element, ((x0 d0 + x1 d1) + x2 d2), so every point's number depends on that point and its
    segment only, whatever else shares the call (a matrix product's kernel, and its rounding,
    depends on the shape of the call)."""
    start = np.take(tab.start, idx, axis=0)
    seg_d = np.take(tab.seg_d, idx, axis=0)
    rel = pts - start
    proj = rel[:, 0] * seg_d[:, 0] + rel[:, 1] * seg_d[:, 1] + rel[:, 2] * seg_d[:, 2]
    length2 = np.take(tab.length2, idx)
    zero = length2 == 0.0
    u = proj / np.where(zero, 1.0, length2)
    u = np.where(zero, 0.0, np.clip(u, 0.0, 1.0))
    return start + u[:, None] * seg_d


@dataclass(frozen=True)
class _Arcs:
    """The arc fields of a MoveTable gathered for a set of points (one arc per point; see
    MoveTable for each field)."""

    axes: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    theta0: np.ndarray
    s_angle: np.ndarray
    angle: np.ndarray
    r0: np.ndarray
    dr: np.ndarray
    h0: np.ndarray
    dh: np.ndarray
    k2: np.ndarray
    end: np.ndarray

    @classmethod
    def gather(cls, source: MoveTable | _Arcs, idx: np.ndarray) -> _Arcs:
        return cls(**{f.name: getattr(source, f.name)[idx] for f in fields(cls)})

    def subset(self, keep: np.ndarray) -> _Arcs:
        return _Arcs.gather(self, keep)

    @cached_property
    def rows(self) -> np.ndarray:
        return np.arange(len(self.c1))

    @cached_property
    def cols(self) -> tuple[int, ...] | None:
        """The (first, second, normal) columns when every row shares one plane, else None."""
        axes = self.axes
        return tuple(axes[0].tolist()) if len(axes) and (axes == axes[0]).all() else None

    def _place(self, out: np.ndarray, first, second, normal) -> None:
        if self.cols is not None:
            i1, i2, n = self.cols
            out[:, i1], out[:, i2], out[:, n] = first, second, normal
        else:
            axes = self.axes
            out[self.rows, axes[:, 0]] = first
            out[self.rows, axes[:, 1]] = second
            out[self.rows, axes[:, 2]] = normal

    def points(self, u: np.ndarray) -> np.ndarray:
        """Points (n, 3) at sweep fractions u (n,), as controller.arcs.arc_points."""
        theta = self.theta0 + self.s_angle * u
        r = self.r0 + self.dr * u
        out = np.empty((u.size, 3))
        self._place(
            out, self.c1 + r * np.cos(theta), self.c2 + r * np.sin(theta), self.h0 + self.dh * u
        )
        at_end = u == 1.0
        if at_end.any():
            out[at_end] = self.end[at_end]
        return out

    def derivatives(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dp/du and d2p/du2 (n, 3) [mm], as controller.arcs.arc_derivatives."""
        a = self.s_angle
        theta = self.theta0 + a * u
        r = self.r0 + self.dr * u
        cos_t, sin_t = np.cos(theta), np.sin(theta)
        d1 = np.empty((u.size, 3))
        d2 = np.empty((u.size, 3))
        self._place(d1, self.dr * cos_t - r * a * sin_t, self.dr * sin_t + r * a * cos_t, self.dh)
        ra2 = r * a * a
        self._place(d2, -self.k2 * sin_t - ra2 * cos_t, self.k2 * cos_t - ra2 * sin_t, 0.0)
        return d1, d2


def _nearest_on_arcs(tab: MoveTable, idx: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Nearest points on arcs ``idx`` (see the module docstring). A candidate clamped to u = 0
    or 1 is the start or end point again (never strictly nearer), so it is not evaluated; the
    best candidate's point is kept rather than evaluated again."""
    arcs = _Arcs.gather(tab, idx)
    rows, n = arcs.rows, len(idx)
    p1 = pts[rows, arcs.axes[:, 0]] - arcs.c1
    p2 = pts[rows, arcs.axes[:, 1]] - arcs.c2
    base = np.mod(tab.sigma[idx] * (np.arctan2(p2, p1) - arcs.theta0), TWO_PI)
    best_u = np.zeros(n)
    best_p = tab.arc_start[idx]
    best_f = _dot_rows(best_p - pts, best_p - pts)
    f = _dot_rows(arcs.end - pts, arcs.end - pts)
    better = f < best_f
    best_u[better], best_p[better], best_f[better] = 1.0, arcs.end[better], f[better]
    turns = tab.turns[idx]
    for k in range(int(turns.max(initial=0)) + 1):
        u = np.clip((base + TWO_PI * k) / arcs.angle, 0.0, 1.0)
        on = np.flatnonzero((turns >= k) & (u > 0.0) & (u < 1.0))
        sub = arcs if on.size == n else arcs.subset(on)
        pt = sub.points(u[on])
        f = _dot_rows(pt - pts[on], pt - pts[on])
        better = f < best_f[on]
        on = on[better]
        best_u[on], best_p[on], best_f[on] = u[on], pt[better], f[better]
    # Newton on helices and spirals; a rejected step leaves u as it was, so every later step
    # would repeat it: a row leaves the iteration at its first rejected step
    live = np.flatnonzero(tab.newton[idx])
    for _ in range(NEWTON_STEPS):
        if not live.size:
            break
        sub = arcs if live.size == n else arcs.subset(live)
        q, u0 = pts[live], best_u[live]
        p = best_p[live] - q
        d1, d2 = sub.derivatives(u0)
        g = _dot_rows(p, d1)
        h = _dot_rows(d1, d1) + _dot_rows(p, d2)
        step = np.where(h > 0, g / np.where(h > 0, h, 1.0), 0.0)
        u = np.clip(u0 - step, 0.0, 1.0)
        pt = sub.points(u)
        f = _dot_rows(pt - q, pt - q)
        better = f < best_f[live]
        live = live[better]
        best_u[live], best_p[live], best_f[live] = u[better], pt[better], f[better]
    return best_p


def nearest_on_moves(tab: MoveTable, idx: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) [mm] to ``pts`` (n, 3) [mm], point i on move ``idx[i]`` of ``tab``."""
    idx = np.asarray(idx, dtype=np.intp)
    pts = np.asarray(pts, dtype=float).reshape(-1, 3)
    out = np.empty_like(pts)
    is_arc, is_spline = tab.arc[idx], tab.spline[idx]
    seg = np.flatnonzero(~is_arc & ~is_spline)
    arc = np.flatnonzero(is_arc)
    if seg.size:
        out[seg] = _nearest_on_segments(tab, idx[seg], pts[seg])
    if arc.size:
        out[arc] = _nearest_on_arcs(tab, idx[arc], pts[arc])
    spl = np.flatnonzero(is_spline)
    if spl.size:
        _nearest_on_curves(tab, idx[spl], pts[spl], out, spl)
    return out


def _nearest_on_curves(
    tab: MoveTable, idx: np.ndarray, pts: np.ndarray, out: np.ndarray, at: np.ndarray
) -> None:
    """``out[at]``: the nearest points on the curve rows ``idx`` of ``tab`` to ``pts``: the G2
    transitions' all at once (:func:`~gantry_sim.controller.quintic_curve.nearest_points_on`),
    each spline's points in one call (grouped by one sort, not one scan per spline)."""
    rows, inverse = np.unique(idx, return_inverse=True)
    quintic = np.array([isinstance(tab.curves[j], QuinticCurve) for j in rows.tolist()])
    if quintic.any():
        packed = np.stack([tab.curves[j].row for j in rows[quintic].tolist()])
        slot = np.cumsum(quintic) - 1  # row k's place in ``packed`` (where quintic)
        mine = np.flatnonzero(quintic[inverse])
        out[at[mine]] = nearest_points_on(packed[slot[inverse[mine]]], pts[mine])
    if quintic.all():
        return
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(rows) + 1))
    for k in np.flatnonzero(~quintic).tolist():
        mine = order[bounds[k] : bounds[k + 1]]
        out[at[mine]] = tab.curves[rows[k]].nearest_points(pts[mine])


def nearest_on_move(move, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) on one commanded move (line or arc) [mm]."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 3)
    return nearest_on_moves(move_table((move,)), np.zeros(len(pts), dtype=np.intp), pts)


def nearest_on_arc(arc, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) on the arc or helix ``arc`` [mm] to ``pts`` (n, 3) [mm]."""
    return nearest_on_move(arc, pts)
