"""Speed ceilings at tangent junctions with a curvature jump, and the time they cost any planner.

    python benchmarks/junction_floor.py      the G64 P0.01 floor of every peer program


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

**A floor for any planner in G64 P** (:func:`path_floor`, run as a script for the peer
programs of benchmarks/bench_peer.py): in G64 a reference may leave the program by P anywhere,
on a line as on an arc, so every curvature jump gets the two-sided ceiling with e = P. A corner
(a turn of phi between two moves) needs no stop either: a path within P of it turns by phi
inside the band 2 P wide around the two moves, and the largest arc that does so (tangent to the
band's inner edges, its apex on the outer edge at P beyond the corner) has the radius
R = P (1 + sec(phi/2)) / (sec(phi/2) - 1), so some point of the path has a curvature of 1/R or
more, and v <= sqrt(A* R) there (a reversal: 0, a stop). The whole program is one stretch
(rapids included, at their axis speeds; our planner stops at them, another need not), from rest
to rest: floor = max(sum L/cap + the ramp losses at every ceiling (the program's start and end
count as a ceiling of 0), T_r2r(L, max cap, A*, J*)), with the bound's caps, A* and J*. Every
ceiling is generous (the largest axis acceleration and jerk, the whole of P for each effect,
each moves' ramps on at most half of it), so no planner that holds our jerk limit within P
runs a program faster than its floor; where the floor is above LinuxCNC's time (no jerk limit),
a ratio of 1.00 against it is out of reach.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from gantry_sim.controller.arcs import arc_derivatives, arc_frame, frenet
from gantry_sim.controller.moves import Arc, Linear, Rapid
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.limits import s_curve_time
from gantry_sim.controller.planner.lookahead import max_reachable_speed

HERE = Path(__file__).resolve().parent

#: Largest acceleration jump per (e J^2)^(1/3) absorbed on one side / on both sides.
C_ONE_SIDED = 1.1447
C_TWO_SIDED = 3.0 * 6.0 ** (1.0 / 3.0)


def _curvature(m, end: bool) -> np.ndarray:
    """Curvature vector [1/mm] of move ``m`` at its start (end=False) or end."""
    if not isinstance(m, Arc):
        return np.zeros(3)
    d1, d2 = arc_derivatives(m, np.array([1.0 if end else 0.0]))
    return frenet(d1[0], d2[0])[1]


def junction_ceiling(m0, m1, lim, deviation_mm: float, two_sided: bool = False) -> float:
    """Speed ceiling [mm/s] at the tangent junction m0 -> m1 (inf without a curvature jump);
    ``two_sided``: a line may leave its path too (G64), not only an arc."""
    jump = _curvature(m1, False) - _curvature(m0, True)
    dk = float(np.linalg.norm(jump))
    if dk < 1e-12:
        return math.inf
    j_n = float(np.abs(jump / dk) @ np.asarray(lim.max_jerk_mm_per_s3))
    both = two_sided or (isinstance(m0, Arc) and isinstance(m1, Arc))
    c = C_TWO_SIDED if both else C_ONE_SIDED
    return math.sqrt(c * (deviation_mm * j_n * j_n) ** (1.0 / 3.0) / dk)


def end_tangents(m) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents of move ``m`` at its start and its end."""
    if isinstance(m, Arc):
        d1, _ = arc_derivatives(m, np.array([0.0, 1.0]))
        return d1[0] / np.linalg.norm(d1[0]), d1[1] / np.linalg.norm(d1[1])
    d = np.subtract(m.end, m.start)
    d = d / np.linalg.norm(d)
    return d, d


def move_cap(m, lim) -> float:
    """The bound's speed cap [mm/s] of move ``m`` (bench_planner.py's module docstring): its
    feed, the axis speeds along a straight move, an arc's v^2 / R and v^3 / R^2 against its
    plane's smaller acceleration and jerk; a rapid, the axis speeds."""
    vmax = np.asarray(lim.max_velocity_mm_per_s)
    t_in, _ = end_tangents(m)
    if isinstance(m, Rapid):
        return float(np.min(vmax / np.maximum(np.abs(t_in), 1e-300)))
    cap = m.feed_mm_per_min / 60.0
    if isinstance(m, Linear):
        return min(cap, float(np.min(vmax / np.maximum(np.abs(t_in), 1e-300))))
    i1, i2, _ = PLANE_AXES[m.plane]
    frame = arc_frame(m)
    r = min(frame.r0_mm, frame.r1_mm)
    a_p = min(lim.max_acceleration_mm_per_s2[i1], lim.max_acceleration_mm_per_s2[i2])
    j_p = min(lim.max_jerk_mm_per_s3[i1], lim.max_jerk_mm_per_s3[i2])
    return min(cap, min(vmax[i1], vmax[i2]), math.sqrt(a_p * r), (j_p * r * r) ** (1 / 3))


def rest_to_rest_s(length: float, v: float, acc: float, jerk: float) -> float:
    """Time [s] of the fastest 1-D jerk-limited move of ``length`` [mm] from rest to rest under
    v <= ``v``, a <= ``acc``, j <= ``jerk``."""
    if v * s_curve_time(v, acc, jerk) <= length:
        return length / v + s_curve_time(v, acc, jerk)
    lo, hi = 0.0, v
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid * s_curve_time(mid, acc, jerk) <= length else (lo, mid)
    return 2 * s_curve_time(lo, acc, jerk)


def corner_ceiling(turn_rad: float, lim, deviation_mm: float) -> float:
    """Speed ceiling [mm/s] at a corner turning by ``turn_rad`` for any path within
    ``deviation_mm`` of it: sqrt(A* R), R = e (1 + sec(phi/2)) / (sec(phi/2) - 1) (the module
    docstring); 0 for a reversal, inf for no turn."""
    sec = 1.0 / math.cos(0.5 * turn_rad) if turn_rad < math.pi else math.inf
    if not sec > 1.0:  # no turn (to rounding)
        return math.inf
    if not math.isfinite(sec):
        return 0.0
    radius = deviation_mm * (1.0 + sec) / (sec - 1.0)
    return math.sqrt(max(lim.max_acceleration_mm_per_s2) * radius)


def path_floor(moves, lim, tolerance_mm: float) -> tuple[float, float]:
    """(floor, its cruise part) [s] of ``moves`` for any planner holding the jerk limit within
    ``tolerance_mm`` (G64 P; the module docstring)."""
    moves = [m for m in moves if m.length_mm > 1e-9]
    if not moves:
        return 0.0, 0.0
    a_s, j_s = max(lim.max_acceleration_mm_per_s2), max(lim.max_jerk_mm_per_s3)
    caps = [move_cap(m, lim) for m in moves]
    cruise = sum(m.length_mm / c for m, c in zip(moves, caps, strict=True))
    extra = _ramp_loss(0.0, caps[0], 0.5 * moves[0].length_mm, a_s, j_s)
    extra += _ramp_loss(0.0, caps[-1], 0.5 * moves[-1].length_mm, a_s, j_s)
    for k in range(1, len(moves)):
        m0, m1 = moves[k - 1], moves[k]
        cos = float(np.clip(end_tangents(m0)[1] @ end_tangents(m1)[0], -1.0, 1.0))
        c = min(
            corner_ceiling(math.acos(cos), lim, tolerance_mm),
            junction_ceiling(m0, m1, lim, tolerance_mm, two_sided=True),
        )
        for b in (k - 1, k):
            extra += _ramp_loss(c, caps[b], 0.5 * moves[b].length_mm, a_s, j_s)
    length = sum(m.length_mm for m in moves)
    return max(cruise + extra, rest_to_rest_s(length, max(caps), a_s, j_s)), cruise


def _ramp_loss(c: float, cap: float, length_mm: float, acc: float, jerk: float) -> float:
    """Time [s] lost against cruising at ``cap`` by an S-curve from ``c`` up to the cap (or as
    high as ``length_mm`` allows)."""
    if c >= cap:
        return 0.0
    top = min(cap, max_reachable_speed(c, length_mm, acc, jerk))
    t_r = s_curve_time(top - c, acc, jerk)
    return t_r - 0.5 * (c + top) * t_r / cap


def junction_floor(
    moves, caps, lim, deviation_mm: float, two_sided: bool = False
) -> tuple[float, list[tuple]]:
    """Extra time [s] over the issue's bound at the junction ceilings of one stop-to-stop
    stretch, and its junctions.

    Args:
        moves: the stretch's moves, as the bound splits them; ``caps``: their speed caps [mm/s].
        lim: machine limits; ``deviation_mm``: the deviation allowed [mm]; ``two_sided``: a
            line may leave its path too (G64 P), not only an arc.

    Returns:
        (extra time, [(line of the move after the junction, ceiling [mm/s]), ...]). Each
        junction's ramps use at most half of each neighbouring block, so they never overlap.
    """
    a_s, j_s = max(lim.max_acceleration_mm_per_s2), max(lim.max_jerk_mm_per_s3)
    extra, found = 0.0, []
    for k in range(1, len(moves)):
        c = junction_ceiling(moves[k - 1], moves[k], lim, deviation_mm, two_sided)
        if not math.isfinite(c):
            continue
        found.append((moves[k].line, c))
        for b in (k - 1, k):
            extra += _ramp_loss(c, caps[b], 0.5 * moves[b].length_mm, a_s, j_s)
    return extra, found


def main() -> None:
    """Print, per peer program in G64 P0.01 (benchmarks/peer/), LinuxCNC's cycle time, the
    floor of any planner that holds our jerk limit within P, and ours."""
    sys.path.insert(0, str(HERE.parent))
    from benchmarks.peer_programs import OUT, programs
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
    from gantry_sim.controller.planner import plan

    machine = load_machine_config(HERE.parent / "models" / "gantry.toml")
    peer = json.loads((HERE / "data" / "linuxcnc_peer.json").read_text())["programs"]
    p_mm = 0.01
    print(f"G64 P{p_mm:g}: a floor for any planner holding the jerk limit within P")
    head = f"{'program':12s} {'LinuxCNC [s]':>12s} {'floor [s]':>10s} {'floor/LC':>9s}"
    print(f"{head} {'ours [s]':>9s} {'ours/LC':>8s} {'ours/floor':>10s}")
    for name in programs():
        path = OUT / f"{name}.g64.ngc"
        moves = parse_program(path.read_text(), file=path.name)
        floor, _ = path_floor(moves, machine.limits, p_mm)
        theirs = peer.get(name, {}).get("g64", {}).get("cycle_s", math.nan)
        # ours with the events, as gantry plan has them (the floor leaves their stops out)
        ours = plan(list(interpret_events(path.read_text(), file=path.name)), machine).duration_s
        note = "  <- 1.00 x LinuxCNC out of reach" if floor > theirs else ""
        print(
            f"{name:12s} {theirs:12.3f} {floor:10.3f} {floor / theirs:9.3f} "
            f"{ours:9.3f} {ours / theirs:8.3f} {ours / floor:10.3f}{note}"
        )


if __name__ == "__main__":
    main()
