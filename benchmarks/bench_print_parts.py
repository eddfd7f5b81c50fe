"""Planning a printer's file cut into parts by Marlin's limit changes: one process against the
parts' batches over the cores, and the planner's memory against the reference laid out.

    python benchmarks/bench_print_parts.py                  3 layers and 30 layers
    python benchmarks/bench_print_parts.py --layers 100     (1,202 parts, 73,953 moves)

Program (seeded, ``--dialect marlin``): layers 0.2 mm apart as a slicer writes them, each with
the same six islands. On each island two perimeters of a wavy closed outline (R 3-8 mm, 0.3-1.2
mm segments), the outer one under M201 X800 Y800 at F1500 and the inner one under M201 X1000
Y1000 at F2700, then a zigzag infill at F4800, with G0 travels between (Marlin runs G0 as G1 at
F9000 here). Every M201 changes the machine and cuts the plan into a part planned from rest to
rest (controller/planner/limit_events.py): parts of 20-120 moves. (PrusaSlicer writes M204
P800 / P1000 around its external perimeters in this pattern; M204 is a path acceleration that
cuts nothing, so M201 stands in for it here: the worst case of parts, 2,088 of 31 moves on
average in a PrusaSlicer Benchy when M204 still cut them.)

Each row plans the same program twice, each in a fresh subprocess: with
``GANTRY_PLAN_WORKERS=1`` (every part in one process, as before the parts were batched) and with
the default (batches of parts over the cores, controller/planner/plan.py ``PART_BATCH_MOVES``).
Printed: parts and moves, plan wall time [s] and CPU time [s] (the process and its forked
children) of each, their ratio, the peak resident set [MB] of the planning process, the bytes
the reference would take laid out as one PiecewiseCubic (120 bytes a phase: what joining the
parts held in memory, twice, before they were joined on disk), and whether the two plans are
the same (duration, move start times and a digest of 20,000 reference samples, bit for bit).

One run on 2026-11-29 (2 cores, other jobs running), ``--layers 3,30,100``:

| layers | parts | moves | one process: wall / CPU [s] | batched: wall / CPU [s] | wall ratio | peak | laid out |
|---|---|---|---|---|---|---|---|
| 3 | 38 | 2,214 | 4.16 / 4.15 | 1.95 / 3.70 | 0.47 | 60 MB | 11 MB |
| 30 | 362 | 22,190 | 32.66 / 32.62 | 20.16 / 38.62 | 0.62 | 127 MB | 113 MB |
| 100 | 1,202 | 73,953 | 101.71 / 100.69 | 64.21 / 123.11 | 0.63 | 140 MB | 376 MB |

(The same prints with M204 P800 / P1000, as they were cut before M204 became a path
acceleration, gave 0.62, 0.49 and 0.55 the same day.)
The same plans bit for bit in every row.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import random
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def print_program(layers: int, seed: int = 1) -> str:
    """The G-code of ``layers`` layers (see the module docstring)."""
    rng = random.Random(seed)
    islands = [(rng.uniform(-60, 60), rng.uniform(-40, 40), rng.uniform(3, 8)) for _ in range(6)]
    out = ["G21", "G90", "M201 X1000 Y1000", "G0 X0 Y0 Z0.2 F9000"]
    for layer in range(layers):
        out.append(f"G0 Z{0.2 * (layer + 1):.2f} F9000")
        for cx, cy, radius in islands:
            lobes, wobble = rng.randint(3, 7), rng.uniform(0.05, 0.2)
            for ring, inset in enumerate((0.0, 0.45)):
                pts = [(cx + x, cy + y) for x, y in _outline(radius - inset, lobes, wobble, rng)]
                outer = ring == 0
                out.append(f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} F9000")
                if outer:  # an axis acceleration change around each external perimeter
                    out.append("M201 X800 Y800")
                out.append(f"G1 X{pts[1][0]:.3f} Y{pts[1][1]:.3f} F{1500 if outer else 2700}")
                out += [f"G1 X{x:.3f} Y{y:.3f}" for x, y in pts[2:] + pts[:1]]
                if outer:
                    out.append("M201 X1000 Y1000")
            half = 0.6 * radius  # a zigzag infill inside
            out.append(f"G0 X{cx - half:.3f} Y{cy - half:.3f} F9000")
            for r in range(int(2 * half / 0.45)):
                y = cy - half + 0.45 * r
                out.append(f"G1 X{cx + (half if r % 2 == 0 else -half):.3f} Y{y:.3f} F4800")
                out.append(f"G1 Y{y + 0.45:.3f}")
    out.append("M2")
    return "\n".join(out) + "\n"


def _outline(
    radius: float, lobes: int, wobble: float, rng: random.Random
) -> list[tuple[float, float]]:
    """A closed wavy outline around the origin, as 0.3-1.2 mm segments (the last point is the
    one before the first)."""
    pts = []
    angle = 0.0
    while angle < 2 * math.pi - 1e-9:
        r = radius * (1 + wobble * math.sin(lobes * angle))
        pts.append((r * math.cos(angle), r * math.sin(angle)))
        angle += rng.uniform(0.3, 1.2) / radius
    return pts


def child(path: str) -> dict:
    """Plan the program at ``path`` in this process (and the forks it makes)."""
    import numpy as np

    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.dialects import with_segmentation_default
    from gantry_sim.controller.moves import Limits
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.program import interpret_program

    machine = with_segmentation_default(load_machine_config(DEFAULT_MACHINE), "marlin")
    text = Path(path).read_text()
    items = interpret_program(text, dialect="marlin", file=path, machine=machine, events=True)
    t0, c0 = time.perf_counter(), time.process_time()
    planned = plan(items, machine)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    digest = hashlib.sha256(np.asarray(planned.move_start_s).tobytes())
    t = np.linspace(0.0, planned.duration_s, 20_000)
    for arr in planned.curve.evaluate(t):
        digest.update(arr.tobytes())
    return {
        "parts": 1 + sum(isinstance(i, Limits) for i in items),
        "moves": len(planned.moves),
        "wall": wall,
        "cpu": cpu + kids.ru_utime + kids.ru_stime,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "laid_out_mb": 120 * max(planned.curve.phase_counts) * 3 / 1e6,
        "duration": planned.duration_s,
        "digest": digest.hexdigest()[:16],
    }


def _run(path: str, workers: str | None) -> dict:
    env = dict(os.environ)
    env.pop("GANTRY_PLAN_WORKERS", None)
    if workers is not None:
        env["GANTRY_PLAN_WORKERS"] = workers
    cmd = [sys.executable, __file__, "--child", path]
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env)
    if res.returncode != 0:
        raise SystemExit(f"{path}: failed\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--layers", default="3,30", help="comma-separated layer counts")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child)))
        return 0
    print(f"cores: {len(os.sched_getaffinity(0))}; each row: one process, then batches of parts")
    print(
        f"{'layers':>6} {'parts':>6} {'moves':>7} | {'one: wall':>9} {'cpu':>7} | "
        f"{'batched: wall':>13} {'cpu':>7} | {'wall ratio':>10} | {'peak MB':>7} "
        f"{'laid out MB':>11} | same"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for layers in (int(x) for x in args.layers.split(",")):
            path = str(Path(tmp) / f"print_{layers}.gcode")
            Path(path).write_text(print_program(layers))
            one, many = _run(path, "1"), _run(path, None)
            same = one["digest"] == many["digest"] and one["duration"] == many["duration"]
            print(
                f"{layers:>6} {many['parts']:>6} {many['moves']:>7} | {one['wall']:>9.2f} "
                f"{one['cpu']:>7.2f} | {many['wall']:>13.2f} {many['cpu']:>7.2f} | "
                f"{many['wall'] / one['wall']:>10.2f} | {many['peak_mb']:>7.0f} "
                f"{many['laid_out_mb']:>11.0f} | {'yes' if same else 'NO'}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
