"""Planner benchmark: limits, reference accuracy, cycle time against a lower bound, speed.

Run:  python benchmarks/bench_planner.py [--quick]        (from the repository root)

Prints, in one run, ratios measured against the machine's own limits and a lower bound:

(a) limits: max |v|/vmax, |a|/amax, |j|/jmax per axis, taken both from the samples (jerk by
    finite differences at the servo period) and exactly from the planned constant-jerk phases
    (jerk of every phase, acceleration at every phase boundary, velocity at every phase boundary
    and stationary point); and the path speed over F on every feed move. All must be <= 1.
(b) reference accuracy: largest distance of the reference (evaluated every 0.1 ms) from the true
    arc/helix of the path it follows (the program's moves, and in G64, the bundled default, the
    blend arcs and G2 transitions put in: their own distance from the program is within P and
    reported as blends), over the chord tolerance (<= 0.25), for the default arc pieces ("jerk3") and for
    every arc piece made by Ruckig ("ruckig", as in DESIGN.md) -- the comparison behind the
    default.
(c) cycle time / lower bound. The bound, per program: the moves are split into stop-to-stop
    stretches at the stops every jerk-limited planner must make (program start and end, rapids,
    corners: tangent turn > 1 degree, or any turn between two straight moves). For a stretch,
        bound = max( sum_i L_i / cap_i ,  T_r2r(L, max_i cap_i, A*, J*) )
    with L_i the move's length, cap_i = min(F_i, the per-axis velocity limits along its
    direction, sqrt(A_p R), (J_p R^2)^(1/3)) (A_p, J_p: the smallest limits of the arc's plane
    axes, R its radius), L = sum L_i, A* = max axis acceleration, J* = max axis jerk, and T_r2r
    the time-optimal rest-to-rest time of a 1-D jerk-limited move of length L under v <= cap,
    a <= A*, j <= J* (closed form). The program's bound is the sum over its stretches. The
    floor adds the ramps to the junction speed ceilings of benchmarks/junction_floor.py, for
    the deviation the machine's path control allows there: in G64 P (the bundled default) P,
    on a line as on an arc (two-sided); in G61 0.25 x chord tolerance, on the arc only.
(d) planning speed: chords per second planning a 10,000-arc program (--quick: 2,000).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.junction_floor import end_tangents, junction_floor, move_cap, rest_to_rest_s
from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import PlannerFailure, PlanningError
from gantry_sim.controller.moves import Arc, Linear, Rapid, Transition
from gantry_sim.controller.planes import PLANE_AXES
from gantry_sim.controller.planner.plan import plan
from gantry_sim.models import DEFAULT_MACHINE


# ---------------------------------------------------------------- programs (moves built here)
def _arc(line, start, center, angle, direction="ccw", feed=6000.0, dz=0.0, plane="XY"):
    i1, i2, n = PLANE_AXES[plane]
    r = math.hypot(start[i1] - center[i1], start[i2] - center[i2])
    th = math.atan2(start[i2] - center[i2], start[i1] - center[i1])
    th += angle if direction == "ccw" else -angle
    end = list(start)
    end[i1], end[i2] = center[i1] + r * math.cos(th), center[i2] + r * math.sin(th)
    end[n] += dz
    if abs(angle % (2 * math.pi)) < 1e-12:
        end[i1], end[i2] = start[i1], start[i2]
    turns = max(1, math.ceil(angle / (2 * math.pi) - 1e-9))
    return Arc(
        line, tuple(start), tuple(end), feed, plane, direction, tuple(center), r, turns, angle
    )


def circle(radius, feed):
    return [_arc(1, (radius, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=feed)]


def helix(radius, turns, dz, feed):
    return [_arc(1, (radius, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi * turns, feed=feed, dz=dz)]


def s_chain(count, radius, feed):
    """Alternating tangent semicircles (a serpentine): a curvature jump at every junction."""
    moves, x = [], 0.0
    for k in range(count):
        d = "ccw" if k % 2 else "cw"
        moves.append(_arc(k + 1, (x, 0.0, 0.0), (x + radius, 0.0, 0.0), math.pi, d, feed))
        x += 2 * radius
    return moves


def spiral_chain(count, r0, dr, feed):
    """Tangent quarter arcs with growing radius (an Archimedean-like spiral): small jumps."""
    moves, p, r, th = [], (r0, 0.0, 0.0), r0, 0.0
    c = (0.0, 0.0, 0.0)
    for k in range(count):
        a = _arc(k + 1, p, c, math.pi / 2, feed=feed)
        moves.append(a)
        th += math.pi / 2
        r_new = r + dr  # next centre moves back along the radius so the tangent is kept
        c = (a.end[0] - r_new * math.cos(th), a.end[1] - r_new * math.sin(th), 0.0)
        p, r = a.end, r_new
    return moves


def pocket(loops, corner_r, step, feed):
    """CAM-like pocket: nested rounded rectangles (line, corner arc, ...), a step between loops."""
    moves, line = [], 1
    for k in range(loops):
        w, h = 10.0 + k * step, 6.0 + k * step
        x0, y0 = -w / 2, -h / 2
        pts = [
            ((x0 + corner_r, y0), (x0 + w - corner_r, y0), (x0 + w - corner_r, y0 + corner_r)),
            (
                (x0 + w, y0 + corner_r),
                (x0 + w, y0 + h - corner_r),
                (x0 + w - corner_r, y0 + h - corner_r),
            ),
            (
                (x0 + w - corner_r, y0 + h),
                (x0 + corner_r, y0 + h),
                (x0 + corner_r, y0 + h - corner_r),
            ),
            ((x0, y0 + h - corner_r), (x0, y0 + corner_r), (x0 + corner_r, y0 + corner_r)),
        ]
        if moves:
            moves.append(Linear(line, moves[-1].end, (*pts[0][0], 0.0), feed))
            line += 1
        for a, b, c in pts:
            moves.append(Linear(line, (*a, 0.0), (*b, 0.0), feed))
            moves.append(_arc(line + 1, (*b, 0.0), (*c, 0.0), math.pi / 2, feed=feed))
            line += 2
    return moves


# ---------------------------------------------------------------- lower bound
_ends = end_tangents
_cap = move_cap
_r2r = rest_to_rest_s


def stretches(moves):
    """The stop-to-stop stretches (lists of moves) of the bound."""
    moves = [m for m in moves if m.length_mm > 1e-9]
    out = []
    for k, m in enumerate(moves):
        stop = k == 0 or isinstance(m, Rapid) or isinstance(moves[k - 1], Rapid)
        if not stop:
            kink = math.acos(float(np.clip(_ends(moves[k - 1])[1] @ _ends(m)[0], -1, 1)))
            both_straight = not isinstance(m, Arc) and not isinstance(moves[k - 1], Arc)
            stop = kink > (1e-6 if both_straight else math.radians(1.0))
        if stop:
            out.append([])
        out[-1].append(m)
    return out


def lower_bound(moves, lim, deviation_mm, two_sided=False):
    """(bound, floor, junctions): the bound (module docstring); the floor, the bound with the
    ramps every planner needs at the junction speed ceilings of benchmarks/junction_floor.py
    (deviation ``deviation_mm`` [mm]; ``two_sided``: a line may leave its path too) added to
    each stretch's cruise term; and those junctions (line, ceiling [mm/s])."""
    a_s, j_s = max(lim.max_acceleration_mm_per_s2), max(lim.max_jerk_mm_per_s3)
    total, floor, found = 0.0, 0.0, []
    for stretch in stretches(moves):
        caps = [_cap(m, lim) for m in stretch]
        length = sum(m.length_mm for m in stretch)
        cruise = sum(m.length_mm / c for m, c in zip(stretch, caps, strict=True))
        r2r = _r2r(length, max(caps), a_s, j_s)
        total += max(cruise, r2r)
        extra, junc = junction_floor(stretch, caps, lim, deviation_mm, two_sided)
        floor += max(cruise + extra, r2r)
        found += junc
    return total, floor, found


# ---------------------------------------------------------------- measures
def phase_ratios(p, lim):
    """Exact limit ratios from the planned constant-jerk phases (per axis, max over the plan)."""
    out = np.zeros((3, 3))
    for i, (t0, _, v, a, j) in enumerate(p.curve.axes):
        dur = np.diff(np.append(t0, p.duration_s))
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.clip(np.where(j != 0, -a / j, 0.0), 0.0, dur)
        v_stat = v + tau * (a + 0.5 * tau * j)
        a_end = a + dur * j
        out[0, i] = max(np.abs(v).max(), np.abs(v_stat).max()) / lim.max_velocity_mm_per_s[i]
        out[1, i] = max(np.abs(a).max(), np.abs(a_end).max()) / lim.max_acceleration_mm_per_s2[i]
        out[2, i] = np.abs(j).max() / lim.max_jerk_mm_per_s3[i]
    return out


def sample_ratios(tr, lim, moves):
    jerk = np.diff(tr.acc, axis=0) / tr.period_s
    out = np.array(
        [
            np.abs(tr.vel).max(0) / lim.max_velocity_mm_per_s,
            np.abs(tr.acc).max(0) / lim.max_acceleration_mm_per_s2,
            np.abs(jerk).max(0) / lim.max_jerk_mm_per_s3,
        ]
    )
    speed = np.linalg.norm(tr.vel, axis=1)
    feed_ratio = 0.0
    for m in moves:
        sel = tr.line == m.line
        if not isinstance(m, Rapid) and sel.any():
            feed_ratio = max(feed_ratio, speed[sel].max() / (m.feed_mm_per_min / 60.0))
    return out, feed_ratio


def reference_error(p, moves, dt=1e-4):
    """Largest distance of the reference from the true geometry of the path it follows [mm]
    (``Plan.path_moves``: the program's moves, with the G64 blend arcs and G2 transitions the
    planner put in), evaluated every dt; the distance of those from the program is their own
    (``Plan.blends``)."""
    t = np.arange(0.0, p.duration_s, dt)
    pos, _, _ = p.curve.evaluate(t)
    k = np.clip(np.searchsorted(p.move_start_s, t, side="right") - 1, 0, None)
    # a stop overlapped is an entry of its own (planner/stop_overlap.py): its samples cut the
    # corner by design (its distance is a blend's, in Plan.blends), and the moves after it
    # are one entry further on
    overlap = p.overlap_entries()
    k = np.where(np.isin(k, overlap), -1, k - np.searchsorted(overlap, k))
    active = [m for m in (p.path_moves or moves) if m.length_mm > 1e-9]
    worst = 0.0
    for b, m in enumerate(active):
        q = pos[k == b]
        if not q.size:
            continue
        if isinstance(m, Transition):
            worst = max(worst, float(np.max(np.linalg.norm(m.curve.nearest_points(q) - q, axis=1))))
        elif isinstance(m, Arc):
            i1, i2, n, th0, sg, r0, r1, h0, h1 = arc_frame(m)
            c = m.center
            th = np.unwrap(np.arctan2(q[:, i2] - c[i2], q[:, i1] - c[i1]))
            th -= 2 * math.pi * np.round((th[0] - th0) / (2 * math.pi))
            u = sg * (th - th0) / m.angle
            dr = np.hypot(q[:, i1] - c[i1], q[:, i2] - c[i2]) - (r0 + (r1 - r0) * u)
            dn = q[:, n] - (h0 + (h1 - h0) * u)
            worst = max(worst, float(np.max(np.hypot(dr, dn))))
        else:
            s, d = np.asarray(m.start), np.subtract(m.end, m.start) / m.length_mm
            off = q - s
            worst = max(worst, float(np.max(np.linalg.norm(off - np.outer(off @ d, d), axis=1))))
    return worst


def junction_speeds(p, junctions):
    """Planner's speed [mm/s] at each junction (start of the move on its line), min and max,
    and the ceilings' min and max."""
    t = np.array([p.move_start_s[np.flatnonzero(p.move_lines == line)[0]] for line, _ in junctions])
    _, vel, _ = p.curve.evaluate(t)
    speed = np.linalg.norm(vel, axis=1)
    ceil = np.array([c for _, c in junctions])
    return speed.min(), speed.max(), ceil.min(), ceil.max()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer programs, a 2,000-arc speed test")
    args = ap.parse_args(argv)
    machine = load_machine_config(DEFAULT_MACHINE)
    lim, tol = machine.limits, machine.segmentation.chord_tolerance_mm
    # what the reference may leave the program by at a junction: G64 P (the bundled default)
    # anywhere, lines too; G61 0.25 x chord tolerance, on the arcs
    g64 = machine.path.mode == "G64"
    deviation = (machine.path.tolerance_mm, True) if g64 else (0.25 * tol, False)
    radii = [1, 5, 20, 200] if args.quick else [1, 2, 5, 10, 20, 50, 100, 200]
    progs = {f"circle R{r} F6000": circle(float(r), 6000.0) for r in radii}
    progs.update({f"circle R{r} F1500": circle(float(r), 1500.0) for r in radii[:2]})
    progs["helix R5 P5 F3000"] = helix(5.0, 5, -5.0, 3000.0)
    progs["helix R20 P3 F6000"] = helix(20.0, 3, -3.0, 6000.0)
    progs["S-chain 20 x R5 F6000"] = s_chain(20, 5.0, 6000.0)
    progs["spiral 200 quarter arcs"] = spiral_chain(200, 1.0, 0.05, 6000.0)
    n_loops = 100 if args.quick else 500
    progs[f"pocket {n_loops * 4} corner arcs"] = pocket(n_loops, 1.0, 0.2, 6000.0)

    print(
        f"machine: {DEFAULT_MACHINE.name}, chord tolerance {tol} mm, "
        f"servo {machine.servo.period_s} s"
    )
    print(
        f"{'program':28s} {'chords':>7s} {'T [s]':>8s} {'bound':>8s} {'T/bound':>7s} "
        f"{'ref/tol':>8s} {'ruckig ref/tol':>14s} {'samples v a j /max':>20s} {'F':>7s} "
        f"{'phases v a j /max':>18s} {'rk':>4s}"
    )
    worst = {"cycle": 0.0, "ref": 0.0, "ref_rk": 0.0, "lim": 0.0, "feed": 0.0, "plim": 0.0}
    worst["floor"] = 0.0
    ratios_c, notes = [], []
    for name, moves in progs.items():
        p = plan(moves, machine)
        tr = p.sample(machine.servo.period_s)
        s_rat, f_rat = sample_ratios(tr, lim, moves)
        p_rat = phase_ratios(p, lim)
        ref = reference_error(p, moves) / tol
        small = sum(len(v) for v in p.vertices) < 5000
        ref_rk = float("nan")
        if small:
            try:
                ref_rk = reference_error(plan(moves, machine, arc_pieces="ruckig"), moves) / tol
            except (PlanningError, PlannerFailure):  # Ruckig failed on a piece
                ref_rk = float("inf")
        bound, floor, junc = lower_bound(moves, lim, *deviation)
        ratios_c.append(p.duration_s / bound)
        worst["floor"] = max(worst["floor"], floor / bound)
        if junc:
            notes.append((name, floor / bound, *junction_speeds(p, junc)))
        worst["cycle"] = max(worst["cycle"], p.duration_s / bound)
        worst["ref"] = max(worst["ref"], ref)
        worst["ref_rk"] = max(worst["ref_rk"], ref_rk) if small else worst["ref_rk"]
        worst["lim"] = max(worst["lim"], s_rat.max())
        worst["plim"] = max(worst["plim"], p_rat.max())
        worst["feed"] = max(worst["feed"], f_rat)
        print(
            f"{name:28s} {p.segment_count:7d} {p.duration_s:8.3f} {bound:8.3f} "
            f"{p.duration_s / bound:7.4f} {ref:8.4f} {ref_rk:14.4f} "
            f"{s_rat[0].max():6.3f} {s_rat[1].max():6.3f} {s_rat[2].max():6.3f} {f_rat:7.5f} "
            f"{p_rat[0].max():5.3f} {p_rat[1].max():5.3f} {p_rat[2].max():5.3f} "
            f"{p.ruckig_piece_count:4d}"
        )

    for name, ratio, v_lo, v_hi, c_lo, c_hi in notes:
        print(
            f"  {name}: curvature-jump junctions at {v_lo:.1f}..{v_hi:.1f} mm/s, ceilings "
            f"{c_lo:.1f}..{c_hi:.1f} mm/s; floor / bound {ratio:.4f}"
        )
    n_arcs = 2000 if args.quick else 10000
    big = spiral_chain(n_arcs, 0.5, 0.002, 6000.0)
    t0 = time.perf_counter()
    p = plan(big, machine)
    t_plan = time.perf_counter() - t0
    t0 = time.perf_counter()
    tr = p.sample(machine.servo.period_s)
    t_sample = time.perf_counter() - t0
    print()
    print(
        f"(a) limits, samples:  max ratio {worst['lim']:.6f} (<= 1); "
        f"path speed / F {worst['feed']:.12f} (<= 1)"
    )
    print(f"    limits, phases:   max ratio {worst['plim']:.6f} (<= 1)")
    print(
        f"(b) reference / chord tolerance: {worst['ref']:.5f} (<= 0.25); "
        f"all pieces by Ruckig: {worst['ref_rk']:.4f}"
    )
    print(
        f"(c) cycle time / lower bound: max {worst['cycle']:.4f}, "
        f"mean {np.mean(ratios_c):.4f} (<= 1.10, aim 1.02)"
    )
    print(
        f"    floor / bound (the bound plus the ramps to the junction speed ceilings the path "
        f"tolerance imposes, {deviation[0]} mm, idealised: benchmarks/junction_floor.py): "
        f"max {worst['floor']:.4f}"
    )
    print(
        f"(d) planning: {n_arcs} arcs, {p.segment_count} chords in {t_plan:.2f} s = "
        f"{p.segment_count / t_plan:,.0f} chords/s; sampling {tr.t.size} samples "
        f"({p.duration_s:.1f} s of motion) in {t_sample * 1000:.0f} ms"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
