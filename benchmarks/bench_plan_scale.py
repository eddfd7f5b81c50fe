"""Planning time and peak memory against program length: the planner's growth law.

    python benchmarks/bench_plan_scale.py                       1k and 10k blocks of each kind
    python benchmarks/bench_plan_scale.py --sizes 1000,10000,100000 --kinds mixed
    python benchmarks/bench_plan_scale.py --sizes 1905,19050 --kinds finish

Programs: benchmarks/programs.py (tangent arcs with S-bends, 0.05-0.5 mm G1 polylines, mixed
G0/G1/G2/G3 contours with corners; ``--kinds finish``: a G18 finishing raster in G64 P0.001;
``--kinds adaptive``: FreeCAD-like adaptive clearing, loops of 0.05-0.12 mm chords joined by
short rapids), seeded, on the bundled machine (G64 P0.01, 1 um chords).
Each size runs in a fresh subprocess, so its peak resident set (getrusage ru_maxrss) is the
planner's own: parse, then plan(). Printed per kind and size: parse and plan time [s], blocks
per second, chords, cycle time of the plan [s], peak RSS [MB] of the planning process, the
private memory its forked children added at most [MB] (large rounds are planned over the cores,
controller/forked.py; benchmarks/memory_probe.py) and the tree's peak [MB]: the largest of the
process' own peak and its RSS plus its children's private memory at one poll; the CPU time of
planning [s] in the process and in its forked children (steadier than the wall time on a shared
machine, whose moment moved 100,000 polyline blocks' plan from 63 to 86 s on 2026-11-29; on 2
cores the wall time is at least half their sum); then the growth exponent b of plan time ~
blocks^b between the smallest and largest size (1: linear).
``GANTRY_PLAN_WORKERS=1`` plans in one process.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def child(kind: str, blocks: int) -> dict:
    sys.path.insert(0, str(HERE))
    from memory_probe import TreeMemory
    from programs import program

    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.controller.planner import plan
    from gantry_sim.models import DEFAULT_MACHINE

    machine = load_machine_config(DEFAULT_MACHINE)
    text = program(kind, blocks)
    t0 = time.perf_counter()
    moves = parse_program(text)
    t1 = time.perf_counter()
    tree = TreeMemory()
    cpu0, forks0 = time.process_time(), _children_cpu_s()
    p = plan(moves, machine)
    t2 = time.perf_counter()
    cpu, forks_cpu = time.process_time() - cpu0, _children_cpu_s() - forks0
    forks, total = tree.stop()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {
        "parse_s": t1 - t0,
        "plan_s": t2 - t1,
        "chords": p.segment_count,
        "cycle_s": p.duration_s,
        "peak_mb": peak / 2**20,
        "forks_mb": forks / 2**20,
        "tree_mb": max(peak, total) / 2**20,
        "cpu_s": cpu,
        "forks_cpu_s": forks_cpu,
    }


def _children_cpu_s() -> float:
    """CPU time [s] (user + system) of this process' children that have ended."""
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ch.ru_utime + ch.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000")
    ap.add_argument("--kinds", default="arcs,poly,mixed")
    ap.add_argument("--child", nargs=2, metavar=("KIND", "BLOCKS"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child[0], int(args.child[1]))))
        return 0
    sizes = [int(x) for x in args.sizes.split(",")]
    print(
        f"{'kind':6s} {'blocks':>7s} {'parse s':>8s} {'plan s':>8s} {'blocks/s':>9s} "
        f"{'chords':>9s} {'cycle s':>9s} {'peak MB':>8s} {'forks MB':>9s} {'tree MB':>8s} "
        f"{'cpu s':>7s} {'forks cpu s':>11s}"
    )
    for kind in args.kinds.split(","):
        rows = []
        for n in sizes:
            out = subprocess.run(
                [sys.executable, __file__, "--child", kind, str(n)],
                capture_output=True,
                text=True,
                check=True,
            )
            r = json.loads(out.stdout.strip().splitlines()[-1])
            rows.append((n, r))
            print(
                f"{kind:6s} {n:7d} {r['parse_s']:8.2f} {r['plan_s']:8.2f} "
                f"{n / r['plan_s']:9.0f} {r['chords']:9d} {r['cycle_s']:9.1f} "
                f"{r['peak_mb']:8.0f} {r['forks_mb']:9.0f} {r['tree_mb']:8.0f} "
                f"{r['cpu_s']:7.2f} {r['forks_cpu_s']:11.2f}",
                flush=True,
            )
        if len(rows) > 1:
            (n0, a), (n1, b) = rows[0], rows[-1]
            law = math.log(b["plan_s"] / a["plan_s"]) / math.log(n1 / n0)
            print(f"{kind:6s} growth: plan time ~ blocks^{law:.2f} ({n0} -> {n1})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
