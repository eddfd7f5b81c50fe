"""A fingerprint of a generated program's plan, to show a change leaves plans the same bit for bit.

    python benchmarks/plan_hash.py arcs 5000
    python benchmarks/plan_hash.py arcs 20000 --period 0.001

Plans ``benchmarks/programs.py``'s program of KIND and BLOCKS on the bundled machine and prints
one SHA-256 over the cycle time [s], every move's start time [s] and program line, every phase
of the reference (per axis: start [s], position, velocity, acceleration, jerk), and the
reference sampled every PERIOD [s] (position, velocity, acceleration, taken in ranges of a
million samples); then the cycle time, the move count and the planning time, which the hash
does not cover. Run it before and after a change: the hashes must be equal.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from programs import program

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import Plan, plan
from gantry_sim.models import DEFAULT_MACHINE

#: Samples hashed at a time.
RANGE = 1_000_000


def plan_digest(p: Plan, period_s: float) -> str:
    """SHA-256 (hex) of ``p``'s cycle time, move starts and lines, phases and samples."""
    h = hashlib.sha256()
    h.update(np.float64(p.duration_s).tobytes())
    h.update(np.ascontiguousarray(p.move_start_s, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(p.move_lines, dtype=np.int64).tobytes())
    for axis in p.curve.axes:
        for column in axis:
            h.update(np.ascontiguousarray(column, dtype=np.float64).tobytes())
    n = p.sample_count(period_s)
    for k0 in range(0, n, RANGE):
        tr = p.sample_range(period_s, k0, k0 + RANGE)
        for arr in (tr.pos, tr.vel, tr.acc):
            h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    return h.hexdigest()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind")
    ap.add_argument("blocks", type=int)
    ap.add_argument("--period", type=float, default=0.001, help="sampling period [s]")
    args = ap.parse_args()
    moves = parse_program(program(args.kind, args.blocks))
    t0 = time.perf_counter()
    p = plan(moves, load_machine_config(DEFAULT_MACHINE))
    dt = time.perf_counter() - t0
    print(
        f"{args.kind} {args.blocks} {plan_digest(p, args.period)} "
        f"cycle {p.duration_s!r} s, {len(p.move_start_s)} entries, planned in {dt:.2f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
