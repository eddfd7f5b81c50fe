"""The marlin dialect against Marlin itself: tests/data/marlin/corpus.jsonl holds programs and
what Marlin bugfix-2.1.x's own code did with them (its line reader, GCodeParser and command
handlers built for the host; tests/data/marlin/README.md), made by
scripts/regen_marlin_expected.py. For each program, gantry-sim must move on the lines Marlin
moved on, and on each such line end where Marlin's current_position ended, at Marlin's feed
(mm/min, M220 included), extruding where Marlin's E changed; on an arc or a G5 line every
segment end Marlin planned must lie on gantry-sim's curve.

Marlin computes in float32 (24-bit mantissa): a number read from the text is within half an
ulp, about 6e-8 relative, and each G91 step or G92 shift adds as much again. So end points
agree to 1e-4 mm + 1e-6 relative (a few hundred such steps at 300 mm), feeds to 1e-5 relative
(MMS_SCALED's float product). Marlin's arc segments come from its float32 rotation (plan_arc:
a small-angle rotation corrected by sin/cos every N_ARC_CORRECTION segments) and its G5 from
float32 adaptive stepping (planner_bezier.cpp): their points lie on the curve to 2e-3 mm."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Arc, Linear, Move, Rapid, Spline

CORPUS = Path(__file__).parent / "data" / "marlin" / "corpus.jsonl"
ROWS = [json.loads(line) for line in CORPUS.read_text().splitlines()] if CORPUS.exists() else []
#: the corpus may grow, not shrink unnoticed
MIN_PROGRAMS = 373
END_ABS, END_REL = 1e-4, 1e-6
FEED_REL = 1e-5
CURVE_TOL = 2e-3


def _close(a: float, b: float, abs_tol: float = END_ABS, rel: float = END_REL) -> bool:
    return abs(a - b) <= abs_tol + rel * max(abs(a), abs(b))


def _vclose(u, v) -> bool:
    return all(_close(a, b) for a, b in zip(u, v, strict=True))


_AXES = {"XY": (0, 1, 2), "XZ": (2, 0, 1), "YZ": (1, 2, 0)}


def _off_arc(arc: Arc, points: list[list[float]]) -> str | None:
    """Why a Marlin segment end is not on ``arc`` (radius, helix and swept angle), or None."""
    a, b, h = _AXES[arc.plane]
    sign = -1.0 if arc.direction == "cw" else 1.0
    a0 = math.atan2(arc.start[b] - arc.center[b], arc.start[a] - arc.center[a])
    total = arc.angle  # the whole sweep, extra turns (P) included
    # an end off the start radius by a slicer's rounding makes the arc a spiral
    spiral = abs(math.hypot(arc.end[a] - arc.center[a], arc.end[b] - arc.center[b]) - arc.radius)
    swept_before = -1e-9
    turns_done = 0.0
    last = a0
    for p in points:
        r = math.hypot(p[a] - arc.center[a], p[b] - arc.center[b])
        if abs(r - arc.radius) > CURVE_TOL + spiral:
            return f"segment end {p} is {r - arc.radius:+.6f} mm off radius {arc.radius}"
        ang = math.atan2(p[b] - arc.center[b], p[a] - arc.center[a])
        step = (sign * (ang - last)) % (2 * math.pi)
        if step > 2 * math.pi - 1e-3:  # float noise on a point at the same angle
            step -= 2 * math.pi
        turns_done += step
        last = ang
        swept = turns_done
        if swept + CURVE_TOL / max(arc.radius, 1e-9) < swept_before:
            return f"segment end {p} goes back along the arc"
        swept_before = swept
        if total > 0 and abs(arc.end[h] - arc.start[h]) > 0:
            want_h = arc.start[h] + (arc.end[h] - arc.start[h]) * min(swept / total, 1.0)
            if abs(p[h] - want_h) > CURVE_TOL + 1e-6 * abs(want_h):
                return f"segment end {p} off the helix ({want_h} on axis {h})"
    if swept_before > total + 1e-3:
        return f"segments sweep {swept_before} rad, the arc {total}"
    return None


def _bezier(cp, t: float) -> list[float]:
    u = 1 - t
    return [
        u * u * u * cp[0][k] + 3 * u * u * t * cp[1][k] + 3 * u * t * t * cp[2][k] + t**3 * cp[3][k]
        for k in range(3)
    ]


def _off_spline(spline: Spline, points: list[list[float]]) -> str | None:
    """Why a Marlin G5 segment end is off ``spline`` (a cubic Bezier), or None."""
    cp = spline.control_points
    if spline.degree != 3 or len(cp) != 4:
        return f"spline of degree {spline.degree} with {len(cp)} control points"
    n = 512
    samples = [_bezier(cp, i / n) for i in range(n + 1)]
    lo = 0
    for p in points:
        best = min(range(lo, n + 1), key=lambda i: math.dist(samples[i], p))
        a, b = max(best - 1, 0) / n, min(best + 1, n) / n
        for _ in range(40):  # golden-section search around the nearest sample
            m1, m2 = a + (b - a) * 0.382, a + (b - a) * 0.618
            if math.dist(_bezier(cp, m1), p) < math.dist(_bezier(cp, m2), p):
                b = m2
            else:
                a = m1
        gap = math.dist(_bezier(cp, (a + b) / 2), p)
        if gap > CURVE_TOL:
            return f"G5 segment end {p} is {gap:.6f} mm off the curve"
        lo = max(best - 1, 0)
    return None


#: a move shorter than this moves nothing in Marlin (regen_marlin_expected.STILL)
STILL = 1e-5


def gantry_lines(moves: list[Move]) -> dict[int, list[Move]]:
    """The moves per line, less a straight move of no length that does not extrude (``G1
    F300``): Marlin's planner makes no block of it (no steps), and the corpus keeps none."""
    out: dict[int, list[Move]] = {}
    for m in moves:
        if (isinstance(m, Linear) and not m.extrudes
                and max(abs(a - b) for a, b in zip(m.start, m.end, strict=True)) <= STILL):  # fmt: skip
            continue
        out.setdefault(m.line, []).append(m)
    return out


def differences(row: dict, moves: list[Move]) -> list[str]:
    """How gantry-sim's ``moves`` differ from Marlin's ``row["motions"]``; [] if they agree."""
    got = gantry_lines(moves)
    want = {m["line"]: m for m in row["motions"]}
    out = []
    if sorted(got) != sorted(want):
        extra = sorted(set(got) - set(want))
        missing = sorted(set(want) - set(got))
        return [f"lines that move: gantry-sim also {extra[:8]}, Marlin also {missing[:8]}"]
    for line in sorted(want):
        w, ms = want[line], got[line]
        end = ms[-1].end
        if not _vclose(w["end"], end):
            out.append(f"line {line}: end {list(end)} against Marlin's {w['end']}")
        if w.get("homing"):
            if not all(isinstance(m, Rapid) for m in ms):
                out.append(f"line {line}: homing, gantry-sim {[type(m).__name__ for m in ms]}")
            continue
        for m in ms:
            if isinstance(m, Rapid):
                out.append(f"line {line}: a rapid where Marlin feeds at {w['feed']}")
                continue
            if not _close(m.feed_mm_per_min, w["feed"], 0.0, FEED_REL):
                out.append(f"line {line}: feed {m.feed_mm_per_min} against Marlin's {w['feed']}")
        extrudes = any(getattr(m, "extrudes", False) for m in ms)
        if extrudes != w["extrudes"]:
            out.append(f"line {line}: extrudes {extrudes} against Marlin's {w['extrudes']}")
        points = w.get("points")
        if points:
            curves = [m for m in ms if isinstance(m, Arc | Spline)]
            if len(curves) == 1 and len(ms) == 1:
                c = curves[0]
                why = _off_arc(c, points) if isinstance(c, Arc) else _off_spline(c, points)
                if why:
                    out.append(f"line {line}: {why}")
            elif not curves:
                kinds = [type(m).__name__ for m in ms]
                if not all(isinstance(m, Linear) for m in ms):
                    out.append(f"line {line}: Marlin segments a curve, gantry-sim has {kinds}")
    return out


def test_the_corpus_is_whole() -> None:
    assert len(ROWS) >= MIN_PROGRAMS
    assert len({r["name"] for r in ROWS}) == len(ROWS)
    arcs = sum(any(len(m.get("points", ())) > 1 for m in r["motions"]) for r in ROWS)
    assert arcs >= 50


@pytest.mark.parametrize("row", ROWS, ids=[r["name"] for r in ROWS])
def test_the_marlin_dialect_moves_as_marlin_does(row: dict) -> None:
    moves = parse_program(row["program"], dialect="marlin", file="p.gcode")
    assert all(math.isfinite(x) for m in moves for x in m.end)
    problems = differences(row, moves)
    assert not problems, problems[:5]
