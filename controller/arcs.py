"""Pure arc and helix geometry, shared by the segmenter, the planner and the analysis.

An arc is parametrised by the fraction u in [0, 1] of its sweep. With (e1, e2, en) the plane's
first, second and normal axes (a right-handed triple, so counter-clockwise seen from +en turns
e1 towards e2):

    theta(u) = theta0 + sigma * A * u          sigma = +1 ccw (G3), -1 cw (G2); A = arc.angle [rad]
    r(u)     = r0 + (r1 - r0) * u              r0 = arc.radius, r1 = |end - center| in the plane [mm]
    h(u)     = h0 + (h1 - h0) * u              normal-axis coordinate [mm]
    p(u)     = center + r(u) * (cos theta e1 + sin theta e2) + h(u) en

so p(0) is the start and p(1) the programmed end exactly (up to rounding). For an exact arc
r1 == r0; LinuxCNC accepts a small mismatch, which makes the path a gentle spiral.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.vector import norm


class ArcFrame(NamedTuple):
    """An arc's parametrisation (the module docstring's symbols)."""

    i1: int  #: index of the plane's first axis (e1)
    i2: int  #: index of the plane's second axis (e2)
    n: int  #: index of the plane's normal axis (en)
    theta0_rad: float  #: polar angle of the start about the centre [rad]
    sigma: float  #: +1 counter-clockwise seen from +en (G3), -1 clockwise (G2)
    r0_mm: float  #: in-plane radius at the start [mm] (the programmed radius)
    r1_mm: float  #: in-plane radius at the end [mm]
    h0_mm: float  #: normal-axis coordinate at the start [mm]
    h1_mm: float  #: normal-axis coordinate at the end [mm]


#: Frames kept by :func:`arc_frame` (the planner asks for the same arc's frame tens of times
#: while it plans it), each with its arc, so an id is never mistaken; emptied when full.
FRAME_CACHE_SIZE = 4096
_frames: dict[int, tuple[Arc, ArcFrame]] = {}


def arc_frame(arc: Arc) -> ArcFrame:
    """The :class:`ArcFrame` of ``arc`` (kept for the :data:`FRAME_CACHE_SIZE` arcs asked for
    last)."""
    hit = _frames.get(id(arc))
    if hit is not None and hit[0] is arc:
        return hit[1]
    frame = _arc_frame(arc)
    if len(_frames) >= FRAME_CACHE_SIZE:
        _frames.clear()  # one step, safe beside other threads
    _frames[id(arc)] = (arc, frame)
    return frame


def _arc_frame(arc: Arc) -> ArcFrame:
    i1, i2, n = PLANE_AXES[arc.plane]
    c, s, e = arc.center, arc.start, arc.end
    theta0 = math.atan2(s[i2] - c[i2], s[i1] - c[i1])
    sigma = 1.0 if arc.direction == "ccw" else -1.0
    r1 = math.hypot(e[i1] - c[i1], e[i2] - c[i2])
    return ArcFrame(i1, i2, n, theta0, sigma, arc.radius, r1, s[n], e[n])


def arc_points(arc: Arc, u: np.ndarray | float) -> np.ndarray:
    """Points on the arc at sweep fractions ``u`` (array (k,) or scalar) -> array (k, 3) [mm].

    u = 1 returns the programmed end point exactly.
    """
    u_arr = np.atleast_1d(np.asarray(u, dtype=float))
    i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(arc)
    theta = theta0 + sigma * arc.angle * u_arr
    r = r0 + (r1 - r0) * u_arr
    out = np.empty((u_arr.size, 3))
    out[:, i1] = arc.center[i1] + r * np.cos(theta)
    out[:, i2] = arc.center[i2] + r * np.sin(theta)
    out[:, n] = h0 + (h1 - h0) * u_arr
    out[u_arr == 1.0] = arc.end
    return out


def arc_derivatives(arc: Arc, u: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives dp/du [mm] and d2p/du2 [mm] at fractions ``u`` -> two (k, 3)."""
    u_arr = np.atleast_1d(np.asarray(u, dtype=float))
    i1, i2, n, theta0, sigma, r0, r1, h0, h1 = arc_frame(arc)
    a = sigma * arc.angle
    theta = theta0 + a * u_arr
    r = r0 + (r1 - r0) * u_arr
    dr = r1 - r0
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    d1 = np.zeros((u_arr.size, 3))
    d2 = np.zeros((u_arr.size, 3))
    d1[:, i1] = dr * cos_t - r * a * sin_t
    d1[:, i2] = dr * sin_t + r * a * cos_t
    d1[:, n] = h1 - h0
    d2[:, i1] = -2.0 * dr * a * sin_t - r * a * a * cos_t
    d2[:, i2] = 2.0 * dr * a * cos_t - r * a * a * sin_t
    return d1, d2


def arc_length_mm(arc: Arc) -> float:
    """Path length of the arc, helix or slight spiral [mm] (mean in-plane radius)."""
    return arc.length_mm


def frenet(d1: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangent and curvature vector [1/mm] from a curve's first and second derivatives
    (3,) with respect to any parameter (e.g. :func:`arc_derivatives`)."""
    speed = norm(d1)
    t = d1 / speed
    return t, (d2 - np.dot(d2, t) * t) / speed**2


def frenet_many(d1: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`frenet` of each row of ``d1``, ``d2`` (m, 3) at once -> (m, 3) twice: the same
    numbers (``np.vecdot`` sums as ``np.dot`` does, and the squared speed is a Python float's
    power, as there)."""
    speed = np.sqrt(np.vecdot(d1, d1))
    t = d1 / speed[:, None]
    square = np.array([s**2 for s in speed.tolist()], dtype=float)
    return t, (d2 - np.vecdot(d2, t)[:, None] * t) / square[:, None]


#: Gauss-Legendre nodes on [0, 1] and weights for a spiral's arc length (|dp/du| is the square
#: root of a quadratic in u: 16 nodes integrate it to rounding on any spiral LinuxCNC accepts).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


#: An arc whose end radius differs from its start radius by more than this share is planned as
#: the spiral it is (:func:`is_spiral`); below it, |dp/du| varies by less than the planner's
#: margins on the limits can absorb, and u is taken as the arc-length fraction.
SPIRAL_REL = 1e-7


def is_spiral(arc: Arc) -> bool:
    """Whether the in-plane radius changes along ``arc`` by more than :data:`SPIRAL_REL` of it
    (LinuxCNC accepts up to 0.1 % in a program, and more where a tool offset changed under
    the arc): then |dp/du| is not constant and the sweep fraction u is not the arc-length
    fraction."""
    f = arc_frame(arc)
    return abs(f.r1_mm - f.r0_mm) > SPIRAL_REL * max(f.r0_mm, f.r1_mm)


def spiral_speed_rate(arc: Arc, u: np.ndarray) -> np.ndarray:
    """d|dp/du|/du [mm] at sweep fractions ``u`` (0 on a circle or helix): with
    |dp/du|^2 = (r1 - r0)^2 + (r(u) A)^2 + (h1 - h0)^2, it is r(u) A^2 (r1 - r0) / |dp/du|."""
    f = arc_frame(arc)
    u = np.asarray(u, dtype=float)
    r = f.r0_mm + (f.r1_mm - f.r0_mm) * u
    return r * arc.angle**2 * (f.r1_mm - f.r0_mm) / _speed_u(f, arc.angle, u)


def _speed_u(f: ArcFrame, angle: float, u: np.ndarray) -> np.ndarray:
    """|dp/du| [mm] of a spiral at sweep fractions ``u`` (any shape):
    sqrt((r1 - r0)^2 + (r(u) A)^2 + (h1 - h0)^2)."""
    dr = f.r1_mm - f.r0_mm
    c2 = dr**2 + (f.h1_mm - f.h0_mm) ** 2
    return np.sqrt(c2 + ((f.r0_mm + dr * u) * angle) ** 2)


def spiral_length_at(arc: Arc, u: np.ndarray) -> np.ndarray:
    """Path length [mm] from the start to sweep fractions ``u`` (k,) of a spiral:
    the integral of |dp/du| on [0, u], by Gauss-Legendre."""
    return _spiral_length(arc_frame(arc), arc.angle, np.asarray(u, dtype=float))


def _spiral_length(f: ArcFrame, angle: float, u: np.ndarray) -> np.ndarray:
    return u * (_speed_u(f, angle, u[:, None] * _GL_X[None, :]) @ _GL_W)


def spiral_fraction_at(arc: Arc, s_mm: np.ndarray, length_mm: float) -> np.ndarray:
    """The sweep fractions where a spiral of length ``length_mm`` (:func:`spiral_length_at` of
    1) has run ``s_mm`` [mm]: Newton's method from s / length (|dp/du| > 0 varies slowly, so
    a step or two reach rounding on the spirals LinuxCNC accepts; at most 8)."""
    s = np.asarray(s_mm, dtype=float)
    u = s / length_mm
    f = arc_frame(arc)
    for _ in range(8):
        step = (_spiral_length(f, arc.angle, u) - s) / _speed_u(f, arc.angle, u)
        u = u - step
        if not np.any(np.abs(step) > 4e-16):
            break
    return u
