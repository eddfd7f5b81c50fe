"""A plain circular arc's 1-D profile under constant limits taken along its own tangent.

An axis limit bounds the tangential acceleration along a direction T only by
``limit_i / |T_i|``: along a short arc whose tangent stays near one axis, the path may take far
more than the weaker axis' limit (the orientation-free bound). :func:`tangent_profile` takes,
over the arc's sweep, the smallest of these per-axis tangential limits (acceleration and jerk),
solves the time-optimal 1-D profile under them (Ruckig), and checks it point by point against
every plane axis' own limits, with the curvature's share (acceleration a T + v^2/R N, jerk
(j - v^3/R^2) T + 3 v a / R N; T tangent, N inward normal). Where the check fails the limits
are lowered and the profile solved again.

On a short arc passed from rest to rest (the U-turns of arc-fitted 3D-printer infill: a few
degrees of a few mm of radius) it is within a few per cent of the saturated ramps
(:mod:`~gantry_sim.controller.planner.saturated_ramp`) for a thousandth of their cost: measured
on four such arcs of a Bambu Studio print, 0.064, 0.054, 0.066, 0.056 s against 0.065, 0.052,
0.063, 0.053 s (the block's boosted profiles: 0.076, 0.064, 0.072, 0.064 s).
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.arcs import ArcFrame
from gantry_sim.controller.planner.profile import Profile1D
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver, SolverFailure

#: Points of the sweep where the tangent's per-axis limits are taken (the check that follows
#: is exact at 9 points of every phase).
SWEEP_SAMPLES = 65
#: Share of the tangent's limits the profile is solved with, then the shares tried after a
#: failed check (each times the one before).
START_SHARE = 0.94
LOWER_SHARE = 0.85
TRIES = 6
#: Share of each axis' limits the point-by-point check allows (the planner checks the pieces
#: built on the profile again, exactly).
CHECK_MARGIN = 0.97


def _tangent_limit(th: np.ndarray, sigma: float, lims: tuple[float, float]) -> float:
    """Smallest over angles ``th`` [rad] of the tangential limit the two plane axes allow:
    min_i lims[i] / |T_i| with T = sigma (-sin th, cos th)."""
    t1, t2 = np.abs(np.sin(th)), np.abs(np.cos(th))
    with np.errstate(divide="ignore"):
        per = np.minimum(lims[0] / t1, lims[1] / t2)
    return float(per.min())


def follows_per_axis(
    profile: Profile1D,
    frame: ArcFrame,
    acc: tuple[float, float],
    jerk: tuple[float, float],
    margin: float = CHECK_MARGIN,
) -> bool:
    """Whether following the plain circle of ``frame`` with ``profile`` (path length from the
    arc's start [mm]) keeps each plane axis within ``margin`` of its acceleration [mm/s^2] and
    jerk [mm/s^3] limits (``acc``, ``jerk``: the plane's two axes), at 9 points of every phase."""
    s, v, a, j = profile.states_at()
    r, sg = frame.r0_mm, frame.sigma
    th = frame.theta0_rad + sg * s / r
    tang = (-sg * np.sin(th), sg * np.cos(th))
    norm = (-np.cos(th), -np.sin(th))
    for t_i, n_i, al, jl in zip(tang, norm, acc, jerk, strict=True):
        if np.abs(a * t_i + v * v / r * n_i).max() > margin * al:
            return False
        if np.abs((j - v**3 / r**2) * t_i + 3.0 * v * a / r * n_i).max() > margin * jl:
            return False
    return True


def tangent_profile(
    frame: ArcFrame,
    length_mm: float,
    v_in: float,
    v_out: float,
    cap: float,
    acc: tuple[float, float],
    jerk: tuple[float, float],
    solver: RuckigSolver,
) -> Profile1D | None:
    """The time-optimal profile over ``length_mm`` of the plain circle ``frame`` from ``v_in``
    to ``v_out`` [mm/s] under ``cap`` [mm/s] and the tangent's per-axis limits (``acc``,
    ``jerk``: the plane's two axes [mm/s^2], [mm/s^3]) that passes :func:`follows_per_axis`,
    or None (the solver fails, or no share in :data:`TRIES` passes)."""
    th = frame.theta0_rad + frame.sigma * np.linspace(0.0, length_mm, SWEEP_SAMPLES) / frame.r0_mm
    a_t = START_SHARE * _tangent_limit(th, frame.sigma, acc)
    j_t = START_SHARE * _tangent_limit(th, frame.sigma, jerk)
    for _ in range(TRIES):
        try:
            prof = solver.profile(length_mm, v_in, v_out, cap, a_t, j_t)
        except SolverFailure:
            return None
        if follows_per_axis(prof, frame, acc, jerk):
            return prof
        a_t, j_t = LOWER_SHARE * a_t, LOWER_SHARE * j_t
    return None
