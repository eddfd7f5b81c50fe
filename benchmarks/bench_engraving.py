"""Engraving: cycle time with the G64 stops' jerk shared (controller/planner/shared_jerk.py)
against the plain stops they replaced (the baseline, planned in the same run with no share
counted on), per feed.

    python benchmarks/bench_engraving.py [--strokes N] [--feeds 300,900,2400]

The program is generated as a V-bit engraving of text is written: strokes of 2-12 straight
moves of 0.2-3 mm turning 20-120 degrees either way (letters' corners, most of which share an
axis with the move before), the tool lifted by rapids between strokes, G64 P0.01. Prints, per
feed, both plans' cycle times, their ratio, how many stops overlapped, and the planning
seconds; then checks every overlap's samples against the axis limits (ratios printed).
"""

from __future__ import annotations

import argparse
import math
import random
import time
from pathlib import Path

import numpy as np

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner import plan, shared_jerk
from gantry_sim.controller.planner.result import Plan

MACHINE = load_machine_config(Path(__file__).resolve().parents[1] / "models" / "gantry.toml")


def engraving(strokes: int, feed: float, seed: int = 1) -> str:
    """``strokes`` strokes at ``feed`` [mm/min], 4 decimals as CAM writes."""
    rng = random.Random(seed)
    out = ["G21 G90 G17 G64 P0.01", "G0 Z1", f"F{feed:g}"]
    for s in range(strokes):
        x, y = 4.0 * (s % 25), 6.0 * (s // 25)
        out += [f"G0 X{x:.4f} Y{y:.4f}", "G1 Z-0.2"]
        heading = rng.uniform(0.0, 2.0 * math.pi)
        for _ in range(rng.randint(2, 12)):
            length = rng.uniform(0.2, 3.0)
            x, y = x + length * math.cos(heading), y + length * math.sin(heading)
            out.append(f"G1 X{x:.4f} Y{y:.4f}")
            heading += math.radians(rng.uniform(20.0, 120.0)) * rng.choice((-1.0, 1.0))
        out.append("G0 Z1")
    return "\n".join([*out, "M2"]) + "\n"


def _plan(text: str, taken: float) -> tuple[Plan, float]:
    shared_jerk.OVERLAP_TAKEN = taken
    items = list(interpret_events(text))
    t0 = time.perf_counter()
    p = plan(items, MACHINE)
    return p, time.perf_counter() - t0


def _limit_ratios(p: Plan) -> tuple[float, float, float]:
    """The largest |velocity|, |acceleration| and |jerk| over each axis' limit, sampled every
    0.1 ms (jerk by differences of the acceleration)."""
    tr = p.sample(1e-4)
    vmax, amax, jmax = (np.asarray(x) for x in MACHINE.limits.per_axis())
    jerk = np.diff(tr.acc, axis=0) / 1e-4
    return (
        float((np.abs(tr.vel) / vmax).max()),
        float((np.abs(tr.acc) / amax).max()),
        float((np.abs(jerk) / jmax).max()),
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strokes", type=int, default=100)
    ap.add_argument("--feeds", default="300,900,2400", help="mm/min, comma-separated")
    args = ap.parse_args()
    taken = shared_jerk.OVERLAP_TAKEN
    print(f"engraving, {args.strokes} strokes, G64 P0.01, bundled machine")
    print("  feed   stops [s]  shared [s]   ratio  overlaps  plan stops/shared [s]  v/a/j ratios")
    for feed in (float(f) for f in args.feeds.split(",")):
        text = engraving(args.strokes, feed)
        base, t_base = _plan(text, 0.0)
        new, t_new = _plan(text, taken)
        v, a, j = _limit_ratios(new)
        print(
            f"  F{feed:<5g} {base.duration_s:9.3f}  {new.duration_s:9.3f}  "
            f"{new.duration_s / base.duration_s:6.4f}  {len(base.overlaps_s):4d}->{len(new.overlaps_s):<4d}"
            f"  {t_base:6.2f} / {t_new:6.2f}            {v:.6f} {a:.6f} {j:.6f}"
        )
    shared_jerk.OVERLAP_TAKEN = taken
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
