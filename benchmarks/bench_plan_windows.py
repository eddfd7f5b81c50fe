"""Windowed planning against whole-program planning: the same plan, and what the windows cost.

    python benchmarks/bench_plan_windows.py                      5,000 blocks of each kind, windows of 1,000
    python benchmarks/bench_plan_windows.py --blocks 20000 --window 5000 --kinds arcs

Each program (benchmarks/programs.py, bundled machine) is planned twice in this process: whole
(the window larger than the program) and in windows (controller/planner/windows.py). Printed per
kind: both planning times and their ratio, both cycle times, and whether the reference (every
phase of every axis), the move start times and the cycle time are identical, with the largest
difference of the sampled reference [mm] when they are not.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from programs import program

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.models import DEFAULT_MACHINE

plan_module = importlib.import_module("gantry_sim.controller.planner.plan")
window_cut = importlib.import_module("gantry_sim.controller.planner.window_cut")


def _plan(moves, machine, window: int):
    window_cut.WINDOW_MOVES = window
    t0 = time.perf_counter()
    p = plan_module.plan(moves, machine)
    return p, time.perf_counter() - t0


def _same(a, b) -> tuple[bool, float]:
    same = a.duration_s == b.duration_s and np.array_equal(a.move_start_s, b.move_start_s)
    for axis_a, axis_b in zip(a.curve.axes, b.curve.axes, strict=True):
        same = same and all(np.array_equal(x, y) for x, y in zip(axis_a, axis_b, strict=True))
    t = np.linspace(0.0, min(a.duration_s, b.duration_s), 100_001)
    return same, float(np.abs(a.curve.evaluate(t)[0] - b.curve.evaluate(t)[0]).max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=5000)
    ap.add_argument("--window", type=int, default=1000)
    ap.add_argument("--kinds", default="arcs,poly,mixed")
    args = ap.parse_args()
    machine = load_machine_config(DEFAULT_MACHINE)
    print(
        f"{'kind':6s} {'blocks':>7s} {'whole s':>8s} {'windows s':>9s} {'ratio':>6s} "
        f"{'cycle whole s':>14s} {'cycle windows s':>15s}  identical  max |ref diff| mm"
    )
    for kind in args.kinds.split(","):
        moves = parse_program(program(kind, args.blocks))
        whole, t_whole = _plan(moves, machine, 10**12)
        part, t_part = _plan(moves, machine, args.window)
        same, diff = _same(whole, part)
        print(
            f"{kind:6s} {args.blocks:7d} {t_whole:8.2f} {t_part:9.2f} {t_part / t_whole:6.2f} "
            f"{whole.duration_s:14.6f} {part.duration_s:15.6f}  {same!s:9s}  {diff:.3g}"
        )


if __name__ == "__main__":
    main()
