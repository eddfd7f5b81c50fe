"""Arc geometry for many arcs at once: each row computed exactly as
:mod:`gantry_sim.controller.arcs` computes it for one arc (the same operations, element by
element), so a batch gives the numbers bit for bit, in a few numpy calls instead of a few per
arc.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES


def arc_derivatives_many(
    arcs: Sequence[Arc], us: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`gantry_sim.controller.arcs.arc_derivatives` of each arc at its fractions ``us[i]``,
    stacked: dp/du and d2p/du2 (sum of the sizes, 3) [mm]."""
    counts = [u.size for u in us]
    frames = [arc_frame(a) for a in arcs]

    def rows(values: list[float]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=float), counts)

    u = np.concatenate(us) if us else np.zeros(0)
    a = rows([f.sigma * arc.angle for f, arc in zip(frames, arcs, strict=True)])
    r0, r1 = rows([f.r0_mm for f in frames]), rows([f.r1_mm for f in frames])
    theta = rows([f.theta0_rad for f in frames]) + a * u
    r = r0 + (r1 - r0) * u
    dr = r1 - r0
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    axes = np.repeat(np.array([PLANE_AXES[arc.plane] for arc in arcs], dtype=np.intp), counts, 0)
    at = np.arange(u.size)
    d1 = np.zeros((u.size, 3))
    d2 = np.zeros((u.size, 3))
    d1[at, axes[:, 0]] = dr * cos_t - r * a * sin_t
    d1[at, axes[:, 1]] = dr * sin_t + r * a * cos_t
    d1[at, axes[:, 2]] = rows([f.h1_mm - f.h0_mm for f in frames])
    d2[at, axes[:, 0]] = -2.0 * dr * a * sin_t - r * a * a * cos_t
    d2[at, axes[:, 1]] = 2.0 * dr * a * cos_t - r * a * a * sin_t
    return d1, d2


#: The sweep fractions of an arc's two ends.
ARC_ENDS = np.array([0.0, 1.0])


def arc_end_derivatives_many(arcs: Sequence[Arc]) -> tuple[np.ndarray, np.ndarray]:
    """dp/du and d2p/du2 [mm] at the start and end of each arc, each (len(arcs), 2, 3):
    :func:`arc_derivatives_many` at :data:`ARC_ENDS`, one batch for all of them."""
    if not arcs:
        return np.zeros((0, 2, 3)), np.zeros((0, 2, 3))
    d1, d2 = arc_derivatives_many(arcs, [ARC_ENDS] * len(arcs))
    return d1.reshape(-1, 2, 3), d2.reshape(-1, 2, 3)


def arc_points_many(arcs: Sequence[Arc], us: Sequence[np.ndarray]) -> list[np.ndarray]:
    """:meth:`~gantry_sim.controller.planner.move_geometry.ArcGeometry.points` of each arc at
    its sweep fractions ``us[i]`` (k_i,), at once (each number as
    :func:`~gantry_sim.controller.arcs.arc_points` gives it; u = 0 and 1: the start and the end
    exactly) -> one (k_i, 3) array [mm] per arc."""
    if not arcs:
        return []
    counts = [u.size for u in us]
    frames = [arc_frame(a) for a in arcs]
    u = np.concatenate(us).astype(float, copy=False)

    def rows(values: list[float]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=float), counts)

    sweep = rows([f.sigma * a.angle for a, f in zip(arcs, frames, strict=True)])
    theta = rows([f.theta0_rad for f in frames]) + sweep * u
    r0 = rows([f.r0_mm for f in frames])
    r = r0 + rows([f.r1_mm - f.r0_mm for f in frames]) * u
    h0 = rows([f.h0_mm for f in frames])
    normal = h0 + rows([f.h1_mm - f.h0_mm for f in frames]) * u
    at = np.arange(u.size)
    axes = np.repeat(np.array([(f.i1, f.i2, f.n) for f in frames], dtype=np.intp), counts, 0)
    out = np.empty((u.size, 3))
    out[at, axes[:, 0]] = rows([float(a.center[f.i1]) for a, f in zip(arcs, frames, strict=True)])
    out[at, axes[:, 0]] += r * np.cos(theta)
    out[at, axes[:, 1]] = rows([float(a.center[f.i2]) for a, f in zip(arcs, frames, strict=True)])
    out[at, axes[:, 1]] += r * np.sin(theta)
    out[at, axes[:, 2]] = normal
    ends = np.repeat(np.array([a.end for a in arcs], dtype=float), counts, 0)
    starts = np.repeat(np.array([a.start for a in arcs], dtype=float), counts, 0)
    out[u == 1.0] = ends[u == 1.0]
    out[u == 0.0] = starts[u == 0.0]
    return np.split(out, np.cumsum(counts)[:-1])


def piece_points_many(
    ps: np.ndarray, vs: np.ndarray, as_: np.ndarray, js: np.ndarray, dur: np.ndarray
) -> np.ndarray:
    """:func:`gantry_sim.controller.planner.jerk3.jerk3_points` (8 points per phase) of m
    pieces at once: ``ps``.. (m, 3 phases, 3 axes), ``dur`` (m,) [s] -> (m, 25, 3) [mm]."""
    h = dur / 3.0
    tau = (np.arange(8.0)[None, :] * (h / 8)[:, None] + 0.0)[:, None, :, None]  # linspace's
    p, v, a, j = (x[:, :, None, :] for x in (ps, vs, as_, js))
    pts = p + tau * (v + tau * (0.5 * a + tau * j / 6.0))
    hc = h[:, None]
    last = ps[:, 2] + hc * (vs[:, 2] + hc * (0.5 * as_[:, 2] + hc * js[:, 2] / 6.0))
    return np.concatenate([pts.reshape(len(dur), 24, 3), last[:, None, :]], axis=1)


def arc_deviation_many(arcs: Sequence[Arc], q: np.ndarray, u_hint: Sequence[float]) -> np.ndarray:
    """:meth:`gantry_sim.controller.planner.move_geometry.ArcGeometry.deviation` of the points
    ``q[i]`` (k, 3) near ``u_hint[i]`` from each arc, at once -> (m,) [mm]. Where every row
    is of one arc (a Ruckig piece's samples, checked one arc at a time):
    :func:`arc_deviation_one`."""
    m, k = q.shape[0], q.shape[1]
    if m and all(a is arcs[0] for a in arcs):
        return arc_deviation_one(arcs[0], q, u_hint)
    frames = [arc_frame(a) for a in arcs]
    pts = q.reshape(m * k, 3)
    axes = np.repeat(np.array([PLANE_AXES[a.plane] for a in arcs], dtype=np.intp), k, 0)
    at = np.arange(m * k)
    q1, q2, qn = pts[at, axes[:, 0]], pts[at, axes[:, 1]], pts[at, axes[:, 2]]

    def per_arc(values: list[float]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=float), k)

    c1 = per_arc([float(a.center[f.i1]) for a, f in zip(arcs, frames, strict=True)])
    c2 = per_arc([float(a.center[f.i2]) for a, f in zip(arcs, frames, strict=True)])
    theta0 = per_arc([f.theta0_rad for f in frames])
    sigma = per_arc([f.sigma for f in frames])
    angle = per_arc([a.angle for a in arcs])
    hint = per_arc(
        [
            f.theta0_rad + f.sigma * a.angle * uh
            for a, f, uh in zip(arcs, frames, u_hint, strict=True)
        ]
    )
    r0, r1 = per_arc([f.r0_mm for f in frames]), per_arc([f.r1_mm for f in frames])
    h0, h1 = per_arc([f.h0_mm for f in frames]), per_arc([f.h1_mm for f in frames])
    th = np.arctan2(q2 - c2, q1 - c1)
    th = th - 2.0 * np.pi * np.round((th - hint) / (2.0 * np.pi))
    u = sigma * (th - theta0) / angle
    d_r = np.hypot(q1 - c1, q2 - c2) - (r0 + (r1 - r0) * u)
    d_n = qn - (h0 + (h1 - h0) * u)
    d_t = arc_overrun_mm(u, angle, r0, r1, h1 - h0)
    return np.hypot(np.hypot(d_r, d_n), d_t).reshape(m, k).max(axis=1)


def arc_deviation_one(arc: Arc, q: np.ndarray, u_hint: Sequence[float]) -> np.ndarray:
    """:func:`arc_deviation_many` of rows ``q`` (m, k, 3) all of one ``arc``, the same numbers:
    the arc's numbers are scalars and the rows (m, k) arrays, so each step is one NumPy call
    on the same elements (not the dozen calls and lists that repeat scalars per row), and the
    overrun term is skipped where every point lies within the sweep (it is 0 there, and
    hypot(x, 0) is |x| exactly)."""
    f = arc_frame(arc)
    c1, c2 = float(arc.center[f.i1]), float(arc.center[f.i2])
    q1, q2, qn = q[:, :, f.i1], q[:, :, f.i2], q[:, :, f.n]
    turn = f.sigma * arc.angle
    hint = np.array([f.theta0_rad + turn * uh for uh in u_hint], dtype=float)[:, None]
    th = np.arctan2(q2 - c2, q1 - c1)
    th = th - 2.0 * np.pi * np.rint((th - hint) / (2.0 * np.pi))
    u = f.sigma * (th - f.theta0_rad) / arc.angle
    d = np.hypot(
        np.hypot(q1 - c1, q2 - c2) - (f.r0_mm + (f.r1_mm - f.r0_mm) * u),
        qn - (f.h0_mm + (f.h1_mm - f.h0_mm) * u),
    )
    if not (u.min() >= 0.0 and u.max() <= 1.0):  # (NaN too)
        d = np.hypot(d, arc_overrun_mm(u, arc.angle, f.r0_mm, f.r1_mm, f.h1_mm - f.h0_mm))
    return d.max(axis=1)


def arc_overrun_mm(
    u: np.ndarray,
    angle_rad: float | np.ndarray,
    r0: float | np.ndarray,
    r1: float | np.ndarray,
    rise_mm: float | np.ndarray,
) -> np.ndarray:
    """How far [mm] along the arc (or helix) points at sweep fractions ``u`` lie beyond its
    ends (0 inside [0, 1]): a point on the arc's circle but past its end is off the arc. Without
    it a piece that runs on along the tangent and back (a time-optimal Ruckig piece between the
    states of a nearly straight blend arc, 0.1 mm past a 0.03 mm line) read as on the arc."""
    over = np.maximum(np.maximum(u - 1.0, -u), 0.0)
    r = r0 + (r1 - r0) * np.clip(u, 0.0, 1.0)
    return over * np.hypot(r * angle_rad, rise_mm)
