"""Nearest points on the COMMANDED geometry: line segments, arcs, helices (vectorised).

Used by the analysis to measure contour error against what the program asked for (true arcs from
controller/arcs.py, not the chords). All coordinates are program (work) coordinates [mm].

Arc / helix (parametrised by the sweep fraction u in [0, 1], see controller.arcs):
  1. angle projection: the point's polar angle phi about the centre gives the sweep fractions
     u_k = (sigma (phi - theta0) mod 2 pi + 2 pi k) / A, one per turn k = 0..ceil(A / 2 pi);
     with the ends u = 0 and u = 1 they are the candidates (clamped to [0, 1]); the closest
     wins. For a planar arc of constant radius this is exact: the distance grows with the angle
     off phi.
  2. helix or spiral (height or radius changing with u): a few guarded Newton steps on
     f(u) = |p(u) - q|^2 from the best candidate (f' = 2 (p - q).p', f'' = 2 (p'.p' + (p - q).p'')),
     clamped to [0, 1], each accepted only when it lowers f.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from gantry_sim.controller.arcs import arc_derivatives, arc_frame, arc_points
from gantry_sim.controller.moves import Arc, Move

NEWTON_STEPS = 6


def nearest_on_segment(a: ArrayLike, b: ArrayLike, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) on the segment a-b [mm] to ``pts`` (n, 3) [mm]."""
    a = np.asarray(a, dtype=float)
    d = np.asarray(b, dtype=float) - a
    length2 = float(d @ d)
    if length2 == 0.0:
        return np.broadcast_to(a, pts.shape).copy()
    u = np.clip(((pts - a) @ d) / length2, 0.0, 1.0)
    return a + u[:, None] * d


def _arc_eval(arc: Arc, u: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Squared distance [mm^2] from pts (n, 3) to the arc points at u (n,)."""
    diff = arc_points(arc, u) - pts
    return np.einsum("ij,ij->i", diff, diff)


def nearest_on_arc(arc: Arc, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) on the arc or helix ``arc`` [mm] to ``pts`` (n, 3) [mm]."""
    i1, i2, _, theta0, sigma, r0, r1, h0, h1 = arc_frame(arc)
    c = arc.center
    phi = np.arctan2(pts[:, i2] - c[i2], pts[:, i1] - c[i1])
    base = np.mod(sigma * (phi - theta0), 2.0 * math.pi)
    turns = math.ceil(arc.angle / (2.0 * math.pi))
    cands = [np.zeros(len(pts)), np.ones(len(pts))]
    cands += [np.clip((base + 2.0 * math.pi * k) / arc.angle, 0.0, 1.0) for k in range(turns + 1)]
    best_u = cands[0]
    best_f = _arc_eval(arc, best_u, pts)
    for u in cands[1:]:
        f = _arc_eval(arc, u, pts)
        better = f < best_f
        best_u = np.where(better, u, best_u)
        best_f = np.where(better, f, best_f)
    if h1 != h0 or r1 != r0:
        for _ in range(NEWTON_STEPS):
            p = arc_points(arc, best_u) - pts
            d1, d2 = arc_derivatives(arc, best_u)
            g = np.einsum("ij,ij->i", p, d1)
            h = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", p, d2)
            step = np.where(h > 0, g / np.where(h > 0, h, 1.0), 0.0)
            u = np.clip(best_u - step, 0.0, 1.0)
            f = _arc_eval(arc, u, pts)
            better = f < best_f
            best_u = np.where(better, u, best_u)
            best_f = np.where(better, f, best_f)
    return arc_points(arc, best_u)


def nearest_on_move(move: Move, pts: np.ndarray) -> np.ndarray:
    """Nearest points (n, 3) on one commanded move (line or arc) [mm]."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 3)
    if isinstance(move, Arc):
        return nearest_on_arc(move, pts)
    return nearest_on_segment(move.start, move.end, pts)


def distance_to_polyline_near(path: np.ndarray, pts: np.ndarray, window: int) -> np.ndarray:
    """Distance [mm] from pts[k] to the polyline ``path`` near its k-th vertex.

    Both are (n, 3) sampled at the same instants (the reference and the trace); the segments
    path[s] - path[s + 1] for s = k - window .. k + window - 1 (clipped to the path) are searched,
    one vectorised pass per offset, on contiguous slices of edge-padded component arrays.
    """
    n = len(pts)
    if n < 2:
        return np.linalg.norm(pts - path, axis=1)
    w = int(window)
    seg_a, seg_d = path[:-1], np.diff(path, axis=0)  # segment s: seg_a[s] + u seg_d[s]
    a = np.concatenate([np.repeat(seg_a[:1], w, 0), seg_a, np.repeat(seg_a[-1:], w + 1, 0)])
    d = np.concatenate([np.repeat(seg_d[:1], w, 0), seg_d, np.repeat(seg_d[-1:], w + 1, 0)])
    length2 = np.einsum("ij,ij->i", d, d)
    inv = np.divide(1.0, length2, out=np.zeros_like(length2), where=length2 > 0)
    ax, ay, az = (np.ascontiguousarray(a[:, i]) for i in range(3))
    dx, dy, dz = (np.ascontiguousarray(d[:, i]) for i in range(3))
    px, py, pz = (np.ascontiguousarray(pts[:, i]) for i in range(3))
    best = np.full(n, np.inf)
    for j in range(-w, w):
        sl = slice(w + j, w + j + n)
        sx, sy, sz, ex, ey, ez = ax[sl], ay[sl], az[sl], dx[sl], dy[sl], dz[sl]
        u = ((px - sx) * ex + (py - sy) * ey + (pz - sz) * ez) * inv[sl]
        np.clip(u, 0.0, 1.0, out=u)
        dist2 = (sx + u * ex - px) ** 2 + (sy + u * ey - py) ** 2 + (sz + u * ez - pz) ** 2
        np.minimum(best, dist2, out=best)
    return np.sqrt(best)
