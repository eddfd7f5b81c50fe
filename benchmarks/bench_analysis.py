"""CPU time of a streamed run's analysis (what sim.analysis_worker's worker does per range), by
part, on a generated program: it must keep pace with the servo loop on the second core.

    python benchmarks/bench_analysis.py                      10,000 polyline blocks
    python benchmarks/bench_analysis.py --kind arcs --blocks 1000 --repeat 9

Runs the program once through ``run_program`` with the analysis in the run's process
(``GANTRY_ANALYSIS_WORKER=0``), keeping every range's arguments to
``sim.analysis_worker.analyse_range``; then analyses those ranges again ``--repeat`` times and
prints the CPU time [s] (minimum and median) of the whole analysis and of each part: the
program's and the path's move tables, the feed flags, the traced points' and the reference's
distances from the program, the tracking part and the reference's distance from the path.
Also printed: the run's simulate stage [s], and the analysis' minimum over it (above 1, the
loop waits for the worker). CPU time, not wall time: the machine these figures come from is
shared and noisy. To compare revisions, run this file from each checkout (or with its package
first on PYTHONPATH), alternating.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from programs import program


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", default="poly", choices=["poly", "arcs", "mixed"])
    ap.add_argument("--blocks", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    os.environ["GANTRY_ANALYSIS_WORKER"] = "0"  # the ranges analysed here, in this process

    import gantry_sim.sim.analysis_worker as worker
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim import contour
    from gantry_sim.sim.api import run_program
    from gantry_sim.sim.blend_parts import planning_distance_mm
    from gantry_sim.sim.budget import Budget
    from gantry_sim.sim.move_table import move_table
    from gantry_sim.sim.program_distance import distance_to_moves
    from gantry_sim.sim.tracking import max_distance_to_polyline_near

    jobs: list[tuple] = []
    analyse_range = worker.analyse_range

    def keep(*job: object) -> object:
        jobs.append(job)
        return analyse_range(*job)

    worker.analyse_range = keep  # type: ignore[assignment]
    big = Budget(max_sim_s=1e9, max_physics_steps=1e15)
    result = run_program(
        program(args.kind, args.blocks),
        file=f"{args.kind}_{args.blocks}.ngc",
        machine=load_machine_config(DEFAULT_MACHINE),
        budget=big,
    )
    worker.analyse_range = analyse_range  # type: ignore[assignment]
    simulate_s = result.run_report.to_json()["timing_s"]["simulate"]
    ticks = sum(len(job[3]) for job in jobs)
    if not jobs:
        print("the run was not streamed: no ranges to analyse")
        return 1

    parts: dict[str, list[float]] = {}

    def timed(name: str, fn: Callable[..., Any], *args: object, **kwargs: object) -> Any:
        t0 = time.process_time()
        out = fn(*args, **kwargs)
        parts[name][-1] += time.process_time() - t0
        return out

    names = ("program table", "feed", "traced", "reference", "tracking", "path table", "path")
    for name in ("whole", *names):
        parts[name] = []
    for _ in range(args.repeat):
        for name in names:
            parts[name].append(0.0)
        t0 = time.process_time()
        for tables, line, source, pos, ctx, offset, overlap in jobs:
            tab = timed("program table", move_table, tables.moves, tables.cum_len)
            src = None if source is None else np.where(source >= 0, source - tables.r0, source)
            ref = ctx[offset : offset + len(pos)]
            feed = timed("feed", contour.feed_samples, tab, line, src, tables.found)
            lag = contour.LAG_REACH * np.linalg.norm(pos - ref, axis=1)
            timed("traced", distance_to_moves, tab, line, pos, lag, src)
            own = None if src is None else src[feed]
            timed("reference", distance_to_moves, tab, line[feed], ref[feed], window=own)
            window = contour.TRACKING_WINDOW
            timed("tracking", max_distance_to_polyline_near, ctx, pos, window, feed, shift=offset)
            path = timed("path table", move_table, tables.path_moves)
            kept = feed if overlap is None else feed & ~overlap
            timed("path", planning_distance_mm, path, line, ref, kept, tables.path_window)
        parts["whole"].append(time.process_time() - t0)
    print(f"{args.kind} {args.blocks}: {len(jobs)} ranges, {ticks} ticks")
    print(f"the run's simulate stage: {simulate_s:.2f} s")
    print(f"{'part':<14} {'min [s]':>8} {'median':>8} {'us/tick':>8}")
    for name, values in parts.items():
        low = min(values)
        print(f"{name:<14} {low:8.3f} {statistics.median(values):8.3f} {1e6 * low / ticks:8.2f}")
    print(f"analysis (min) / simulate: {min(parts['whole']) / simulate_s:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
