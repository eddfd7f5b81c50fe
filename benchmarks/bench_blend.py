"""Path blending (G64 P) against exact stops (G61) on polyline programs, and planning rate.

    python benchmarks/bench_blend.py [--quick]

Per program: cycle time in G61 and G64 P0.01, their ratio, blends made, the largest distance
of the reference (sampled every 0.1 ms) from the programmed polyline, the largest path speed /
F and the largest |v|/vmax, |a|/amax, |j|/jmax over the axes (1 ms samples, jerk by finite
differences). Then the time and peak memory (ru_maxrss) to plan polylines of growing length.
"""

from __future__ import annotations

import argparse
import math
import resource
import time
from pathlib import Path

import numpy as np

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.moves import Linear
from gantry_sim.controller.planner import plan

MACHINE = load_machine_config(Path(__file__).resolve().parents[1] / "models" / "gantry.toml")


def polygon(n: int, r: float = 10.0, feed: float = 3000.0) -> str:
    pts = [
        (r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n + 1)
    ]
    body = "".join(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in pts[1:])
    return f"G21 G90 G17 {{mode}}\nG0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nF{feed:g}\n{body}M2\n"


def surface(n: int, step: float = 0.2, feed: float = 2000.0, row: int = 500) -> str:
    """A polyline surface raster in XZ (G18 finishing): z = 2 sin(x / 5), rows of ``row`` moves
    of ``step`` mm along X, alternating direction, 0.5 mm apart in Y; ``n`` moves in all."""
    out = []
    for k in range(1, n + 1):
        r, i = divmod(k, row)
        x = (i if r % 2 == 0 else row - i) * step
        out.append(f"G1 X{x:.4f} Y{0.5 * r:.4f} Z{2 * math.sin(x / 5):.4f}\n")
    return f"G21 G90 G18 {{mode}}\nG0 X0 Y0 Z0\nF{feed:g}\n{''.join(out)}M2\n"


def zigzag(n: int, feed: float = 3000.0) -> str:
    """Corners: a zigzag of 5 mm moves turning 30 degrees, then a square."""
    out, x, y = [], 0.0, 0.0
    for k in range(n):
        x += 5 * math.cos(math.radians(15))
        y += 5 * math.sin(math.radians(15)) * (1 if k % 2 == 0 else -1)
        out.append(f"G1 X{x:.4f} Y{y:.4f}\n")
    out += ["G1 Y-20\n", "G1 X0\n", "G1 Y0\n"]
    return f"G21 G90 G17 {{mode}}\nF{feed:g}\n{''.join(out)}M2\n"


def polyline_distance(points: np.ndarray, moves) -> float:
    segs = [m for m in moves if isinstance(m, Linear)]
    a = np.array([m.start for m in segs], float)
    d = np.array([m.end for m in segs], float) - a
    best = np.full(len(points), np.inf)
    for i in range(len(a)):
        t = np.clip((points - a[i]) @ d[i] / (d[i] @ d[i]), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a[i] + t[:, None] * d[i]), axis=1))
    return float(best.max())


#: G64 P0.01 is what LinuxCNC runs by default: its P is also the naive-CAM Q (moves within
#: 0.01 mm of a line merged first); Q0 blends every programmed corner instead.
MODES = ("G61", "G64 P0.01", "G64 P0.01 Q0")


def measure(name: str, template: str) -> None:
    row = {}
    for mode in MODES:
        moves = parse_program(template.format(mode=mode))
        t0 = time.perf_counter()
        p = plan(moves, MACHINE)
        t_plan = time.perf_counter() - t0
        fine = p.sample(1e-4)
        feed_sel = np.isin(fine.line, [m.line for m in moves if isinstance(m, Linear)])
        dev = polyline_distance(fine.pos[feed_sel], moves)
        tr = p.sample(MACHINE.servo.period_s)
        lim = MACHINE.limits
        jerk = np.diff(tr.acc, axis=0) / tr.period_s
        speed = np.linalg.norm(tr.vel, axis=1)
        feeds = {m.line: m.feed_mm_per_min / 60 for m in moves if isinstance(m, Linear)}
        over = max(
            (speed[tr.line == ln].max() / f for ln, f in feeds.items() if (tr.line == ln).any()),
            default=0,
        )
        row[mode] = p.duration_s
        print(
            f"  {name:24s} {mode:9s} {p.duration_s:8.3f} s  blends {len(p.blends):5d}  "
            f"dev {dev * 1000:7.3f} um  speed/F {over:.6f}  "
            f"v {np.max(np.abs(tr.vel) / lim.max_velocity_mm_per_s):.4f} "
            f"a {np.max(np.abs(tr.acc) / lim.max_acceleration_mm_per_s2):.4f} "
            f"j {np.max(np.abs(jerk) / lim.max_jerk_mm_per_s3):.4f}  plan {t_plan:.2f} s"
        )
    print(
        f"  {name:24s} G64/G61 {row['G64 P0.01'] / row['G61']:.3f}  "
        f"(Q0: {row['G64 P0.01 Q0'] / row['G61']:.3f})"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    g3 = plan(parse_program("G21 G90 G17\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F3000\nM2"), MACHINE)
    print(f"circle R10 as one G3 at F3000: {g3.duration_s:.3f} s")
    for n in (72, 360):
        measure(f"{n}-gon R10 F3000", polygon(n))
    for mode in ("G64 P0.01", "G64 P0.01 Q0"):
        p360 = plan(parse_program(polygon(360).format(mode=mode)), MACHINE)
        print(f"  360-gon {mode} / G3: {p360.duration_s / g3.duration_s:.3f} (target <= 1.05)")
    measure("zigzag 30 deg + square", zigzag(20))
    measure("surface 0.2 mm G18", surface(200 if args.quick else 1000))
    print("planning rate (surface polylines, G64 P0.01):")
    for n in (1000,) if args.quick else (1000, 10000):
        moves = parse_program(surface(n).format(mode="G64 P0.01"))
        t0 = time.perf_counter()
        p = plan(moves, MACHINE)
        dt = time.perf_counter() - t0
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(
            f"  {n:6d} moves: {dt:7.2f} s ({n / dt:8.0f} moves/s), peak RSS {rss:.0f} MB, cycle {p.duration_s:.2f} s"
        )


if __name__ == "__main__":
    main()
