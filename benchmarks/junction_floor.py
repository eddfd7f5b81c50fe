"""Speed ceilings at tangent junctions with a curvature jump, and the time they cost any planner.

The cycle-time bound of bench_planner.py (the issue's definition) lets a tangent junction keep
the speed caps of its two blocks. Where the curvature jumps (line -> arc, an S-bend), the
required acceleration jumps by da = v^2 |k1 - k0| [mm/s^2] while the reference's acceleration
must stay continuous (finite jerk), so the reference leaves the geometry near the junction. With
the deviation held to e = 0.25 x chord tolerance (measure (b)) and jerk J_n along the jump's
direction n (per-axis limits: J_n = sum_i |n_i| J_i), da cannot exceed

    one side (a straight move is followed exactly, so only the arc side may deviate):
        da <= C1 (e J_n^2)^(1/3),  C1 = 1.1447
    both sides (arc -> arc):
        da <= C2 (e J_n^2)^(1/3),  C2 = 3 * 6^(1/3) = 5.451

C1 is the optimum of a linear programme over piecewise-constant jerk (600 intervals, window
wide enough that widening it changes nothing): the largest jump that a correction starting at
the jump with zero offset and slope, and returning to the geometry at rest, absorbs with
|jerk| <= J and |offset| <= e. The planner's closed-form piece (controller/jerk3.py) reaches the
same constant. C2 follows from third divided differences: the required normal position
q(u) = k u^2 / 2 with a curvature jump dk at u = 0 has third divided difference dk / (12 h) on
the nodes u = -2h, -h, h, 2h; a reference within +-e of it whose normal jerk is <= J_n, passing
at speed v, must satisfy dk v^2 / (12 tau) <= J_n / 6 + e / (2 tau^3) at every node spacing
tau = h / v [s], and the tightest tau gives dk v^2 <= 3 (6 e J_n^2)^(1/3).

Both ceilings idealise the motion over the junction's few milliseconds as constant speed and
ignore the geometry's own jerk (which only lowers them). They are not part of the issue's bound;
:func:`junction_floor` adds, to that bound, the time any planner loses ramping between the
ceilings and the block caps, with the bound's own A* and J*: a floor for the cycle-time ratio.
"""

from __future__ import annotations

import math

import numpy as np

from gantry_sim.controller.arcs import arc_derivatives, frenet
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planner.limits import s_curve_time
from gantry_sim.controller.planner.lookahead import max_reachable_speed

#: Largest acceleration jump per (e J^2)^(1/3) absorbed on one side / on both sides.
C_ONE_SIDED = 1.1447
C_TWO_SIDED = 3.0 * 6.0 ** (1.0 / 3.0)


def _curvature(m, end: bool) -> np.ndarray:
    """Curvature vector [1/mm] of move ``m`` at its start (end=False) or end."""
    if not isinstance(m, Arc):
        return np.zeros(3)
    d1, d2 = arc_derivatives(m, np.array([1.0 if end else 0.0]))
    return frenet(d1[0], d2[0])[1]


def junction_ceiling(m0, m1, lim, deviation_mm: float) -> float:
    """Speed ceiling [mm/s] at the tangent junction m0 -> m1 (inf without a curvature jump)."""
    jump = _curvature(m1, False) - _curvature(m0, True)
    dk = float(np.linalg.norm(jump))
    if dk < 1e-12:
        return math.inf
    j_n = float(np.abs(jump / dk) @ np.asarray(lim.max_jerk_mm_per_s3))
    c = C_TWO_SIDED if isinstance(m0, Arc) and isinstance(m1, Arc) else C_ONE_SIDED
    return math.sqrt(c * (deviation_mm * j_n * j_n) ** (1.0 / 3.0) / dk)


def _ramp_loss(c: float, cap: float, length_mm: float, acc: float, jerk: float) -> float:
    """Time [s] lost against cruising at ``cap`` by an S-curve from ``c`` up to the cap (or as
    high as ``length_mm`` allows)."""
    if c >= cap:
        return 0.0
    top = min(cap, max_reachable_speed(c, length_mm, acc, jerk))
    t_r = s_curve_time(top - c, acc, jerk)
    return t_r - 0.5 * (c + top) * t_r / cap


def junction_floor(moves, caps, lim, deviation_mm: float) -> tuple[float, list[tuple]]:
    """Extra time [s] over the issue's bound at the junction ceilings of one stop-to-stop
    stretch, and its junctions.

    Args:
        moves: the stretch's moves, as the bound splits them; ``caps``: their speed caps [mm/s].
        lim: machine limits; ``deviation_mm``: the deviation allowed by measure (b) [mm].

    Returns:
        (extra time, [(line of the move after the junction, ceiling [mm/s]), ...]). Each
        junction's ramps use at most half of each neighbouring block, so they never overlap.
    """
    a_s, j_s = max(lim.max_acceleration_mm_per_s2), max(lim.max_jerk_mm_per_s3)
    extra, found = 0.0, []
    for k in range(1, len(moves)):
        c = junction_ceiling(moves[k - 1], moves[k], lim, deviation_mm)
        if not math.isfinite(c):
            continue
        found.append((moves[k].line, c))
        for b in (k - 1, k):
            extra += _ramp_loss(c, caps[b], 0.5 * moves[b].length_mm, a_s, j_s)
    return extra, found
