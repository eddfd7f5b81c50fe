"""Exact arc states along a move's 1-D profile: where the reference passes through the arc.

The profile ``ph`` (rows: duration [s], s [mm], v [mm/s], a_t [mm/s^2], j_t [mm/s^3]) is
inverted at the vertices' arc lengths (:func:`invert_profile`), and each vertex gets the arc's
exact state (position [mm], velocity [mm/s], acceleration [mm/s^2]; :func:`vertex_states`).
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.planner.move_geometry import MoveGeometry

#: Extra vertices at 1/2, 1/4, ... of the first (last) chord of an arc that starts (ends) at rest.
STOP_REFINEMENT = 8


def vertex_states(g: MoveGeometry, ph: np.ndarray, state_in, state_out):
    """Exact arc states where the reference passes through the arc.

    Vertices: the chord vertices, plus the points where the 1-D profile ``ph`` (rows: duration,
    s, v, a_t, j_t) switches phase (within one phase the motion is smooth), plus, next to a stop,
    points at 1/2, 1/4, ... of the end chord (there the speed grows like s^(2/3); a piece across
    the whole chord would start along a straight line).

    Returns:
        u (k,), positions (k, 3) [mm], velocities (k, 3) [mm/s], accelerations (k, 3) [mm/s^2]
        (first and last: ``state_in`` / ``state_out``), and the (k - 1,) times between them [s].
    """
    # Each knot of the 1-D profile becomes a vertex: the nearest chord vertex moves onto it when
    # within a quarter chord (a piece much shorter than a chord would let rounding dominate its
    # jerk), or it is added. The reference only passes through exact arc states, so moving a
    # vertex along the arc does not move the reference off the arc.
    m = g.u.size - 1
    u = g.u.copy()
    snapped = np.zeros(m + 1, dtype=bool)
    extra = []
    for uk in ph[1:, 1] / g.length_mm:
        if not 0.0 < uk < 1.0:
            continue
        i = round(uk * m)
        if 0 < i < m and abs(uk * m - i) < 0.25 and not snapped[i]:
            u[i], snapped[i] = uk, True
        elif abs(uk * m - i) > 1e-3:
            extra.append(uk)
    u = np.union1d(u, extra)
    halves = 0.5 ** np.arange(1, STOP_REFINEMENT + 1)
    if not np.any(state_in[0]):
        u = np.union1d(u, u[1] * halves)
    if not np.any(state_out[0]):
        u = np.union1d(u, 1.0 - (1.0 - u[-2]) * halves)
    u = u[np.concatenate(([True], np.diff(u) > 1e-12))]
    u[-1] = 1.0
    t_k, v_k, a_k = invert_profile(ph, u[1:-1] * g.length_mm)
    d1, d2 = g.derivatives(u[1:-1])
    speed_u = np.linalg.norm(d1, axis=1)
    ud = (v_k / speed_u)[:, None]
    udd = (a_k / speed_u)[:, None]
    vel = np.vstack([state_in[0], d1 * ud, state_out[0]])
    acc = np.vstack([state_in[1], d2 * ud * ud + d1 * udd, state_out[1]])
    times = np.concatenate(([0.0], t_k, [float(ph[:, 0].sum())]))
    verts = g.vertices if np.array_equal(u, g.u) else g.points(u)
    return u, verts, vel, acc, np.maximum(np.diff(times), 0.0)


def invert_profile(ph: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times [s], speeds [mm/s], tangential accelerations [mm/s^2] where the 1-D profile ``ph``
    passes the arc lengths ``s`` [mm] (ascending)."""
    keep = ph[:, 0] > 0
    dur, p, v, a, j = ph[keep].T
    t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
    k = np.clip(np.searchsorted(p, s, side="right") - 1, 0, p.size - 1)
    lo, hi = np.zeros(s.size), dur[k].copy()
    pk, vk, ak, jk = p[k], v[k], a[k], j[k]
    for _ in range(24):  # bisection: s(t) is monotone (v >= 0) ...
        mid = 0.5 * (lo + hi)
        below = pk + mid * (vk + mid * (0.5 * ak + mid * jk / 6.0)) < s
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    tau = 0.5 * (lo + hi)
    for _ in range(3):  # ... then Newton, kept inside the bracket
        f = pk + tau * (vk + tau * (0.5 * ak + tau * jk / 6.0)) - s
        df = vk + tau * (ak + 0.5 * tau * jk)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df > 0, f / df, 0.0)
        tau = np.clip(tau - step, lo, hi)
    return t0[k] + tau, vk + tau * (ak + 0.5 * tau * jk), ak + tau * jk
