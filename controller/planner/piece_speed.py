"""The exact peak path speed over constant-jerk phases.

Between two consecutive phase switches (of any axis) every axis' velocity is a quadratic in
time, so the squared path speed |v|^2 is a quartic whose stationary points are the real roots of
the cubic sum_i v_i a_i = 0; :func:`max_speed_squared` finds them as the eigenvalues of the
cubic's companion matrix, for many intervals at once. Two users:

* a 3-DoF Ruckig piece (:func:`peak_speed`) synchronises its axes in time but not in shape:
  each axis switches jerk at its own times, and |v| can bulge where they do. Sampling misses a
  bulge short against the piece (found on a PrusaSlicer file: 1 ms, 0.21 % above the feed, at
  the start of an 83 ms piece sampled every 3.4 ms);
* the closed-form pieces (:func:`~gantry_sim.controller.planner.jerk3.piece_limits_ok`) sample
  five points a phase and refine the phases where what lies between could pass the cap.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["axis_speed_bound", "max_speed_squared", "peak_speed", "speed_exceeds"]

#: :func:`speed_exceeds` trusts the per-axis bound only this far below the cap (relative), so
#: that its answer is :func:`peak_speed`'s to the last bit (their roundings are ~1e-16).
BOUND_MARGIN = 1e-9


def max_speed_squared(v: np.ndarray, a: np.ndarray, j: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Largest |v(tau)|^2 [mm^2/s^2] for tau in [0, h] of m intervals of constant jerk.

    Args:
        v, a, j: (m, 3) velocity [mm/s], acceleration [mm/s^2] at the interval's start and its
            jerk [mm/s^3], per axis.
        h: (m,) the intervals' durations [s].
    """
    # d/dtau |v|^2 / 2 = c3 tau^3 + c2 tau^2 + c1 tau + c0
    c3 = 0.5 * (j * j).sum(axis=1)
    c2 = 1.5 * (a * j).sum(axis=1)
    c1 = (a * a + v * j).sum(axis=1)
    c0 = (v * a).sum(axis=1)
    cands = [np.zeros_like(h), h]
    cubic = c3 > 0.0  # else |v|^2 is convex (j = 0): its ends hold the maximum
    if cubic.any():
        comp = np.zeros((int(cubic.sum()), 3, 3))
        comp[:, 0, 0] = -c2[cubic] / c3[cubic]
        comp[:, 0, 1] = -c1[cubic] / c3[cubic]
        comp[:, 0, 2] = -c0[cubic] / c3[cubic]
        comp[:, 1, 0] = comp[:, 2, 1] = 1.0
        roots = np.zeros((h.size, 3))
        roots[cubic] = np.linalg.eigvals(comp).real  # complex pairs: a harmless extra point
        cands += [roots[:, 0], roots[:, 1], roots[:, 2]]
    tau = np.clip(np.stack(cands), 0.0, h)[:, :, None]  # (candidates, m, 1)
    vel = v + tau * (a + 0.5 * tau * j)
    return np.einsum("cmd,cmd->cm", vel, vel).max(axis=0)


def peak_speed(phases: Sequence[Sequence[Sequence[float]]]) -> float:
    """Largest path speed [mm/s] over a piece: ``phases[i]`` is axis i's (durations [s],
    p [mm], v [mm/s], a [mm/s^2], j [mm/s^3]), the start state of each phase and its jerk;
    every axis starts at time 0 (an axis whose phases end early holds its last velocity)."""
    rows = [np.asarray(ph, dtype=float).reshape(5, -1) for ph in phases]
    v_start = np.array([r[2, 0] if r.shape[1] else 0.0 for r in rows])
    axes = [r[:, r[0] > 0] for r in rows]
    ends = [np.cumsum(ax[0]) for ax in axes]
    cuts = np.unique(np.concatenate([[0.0], *ends]))
    t0, h = cuts[:-1], np.diff(cuts)
    if t0.size == 0:  # no phase of any length: the start states' speed
        return float(np.linalg.norm(v_start))
    v = np.empty((t0.size, 3))
    a = np.zeros((t0.size, 3))
    j = np.zeros((t0.size, 3))
    for i, ax in enumerate(axes):
        if ax.shape[1] == 0:  # no phase: the axis holds its start velocity
            v[:, i] = v_start[i]
            continue
        starts = np.concatenate(([0.0], ends[i][:-1]))  # the cuts' own numbers
        k = np.clip(np.searchsorted(starts, t0, side="right") - 1, 0, ax.shape[1] - 1)
        tau = t0 - starts[k]
        past = t0 >= ends[i][k]  # after the axis' last phase: its end velocity, held
        tau = np.minimum(tau, ax[0, k])
        v[:, i] = ax[2, k] + tau * (ax[3, k] + 0.5 * tau * ax[4, k])
        a[:, i] = np.where(past, 0.0, ax[3, k] + tau * ax[4, k])
        j[:, i] = np.where(past, 0.0, ax[4, k])
    return float(np.sqrt(max_speed_squared(v, a, j, h).max()))


def axis_speed_bound(phases: Sequence[Sequence[Sequence[float]]]) -> float:
    """An upper bound on :func:`peak_speed` [mm/s]: each axis' largest |velocity| over its own
    phases (a phase's ends and its stationary point), combined as if they coincided. Pure
    Python on the few phases of a Ruckig piece: about 10 x faster than the exact peak."""
    total = 0.0
    for dur, _p, v, a, j in phases:
        top = abs(v[0]) if len(v) else 0.0  # an axis with no phase holds its start velocity
        for d, v0, a0, j0 in zip(dur, v, a, j, strict=False):
            if not d > 0.0:
                continue
            v1 = v0 + d * (a0 + 0.5 * d * j0)
            top = max(top, abs(v0), abs(v1))
            if j0 != 0.0:
                tau = -a0 / j0
                if 0.0 < tau < d:
                    top = max(top, abs(v0 + tau * (a0 + 0.5 * tau * j0)))
        total += top * top
    return total**0.5


def speed_exceeds(phases: Sequence[Sequence[Sequence[float]]], cap_mm_per_s: float) -> bool:
    """Whether :func:`peak_speed` of ``phases`` exceeds ``cap_mm_per_s``, the same answer:
    the cheap :func:`axis_speed_bound` settles it where it lies clearly below the cap (most
    pieces), the exact peak elsewhere."""
    if axis_speed_bound(phases) < cap_mm_per_s * (1.0 - BOUND_MARGIN):
        return False
    return peak_speed(phases) > cap_mm_per_s
