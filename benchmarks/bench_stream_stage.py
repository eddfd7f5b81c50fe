"""The streamed stage of ``gantry run`` alone, repeated on one plan: simulate and analyse against
MuJoCo alone stepping the same motion.

``bench_run.py`` times a whole run once per process, so a change to the streamed stage is lost
in the machine's moment and in planning's. Here the program is parsed and planned once; each
repeat then runs the streamed stage (sim.api's ``_streamed``: the servo loop, the range helper,
the analysis worker, trace.npz's deflating and, with ``--plots``, the plot worker's outline) in
a child forked from the planned process, with its analysis worker (and plot worker) started
and given time to import first, as a run's are during planning. The first repeat's trace.npz
gives the held forces, which MuJoCo alone replays open loop (bench_run.py's ``_replay_s``)
right after each repeat: on a shared machine whose speed drifts by 1.5 x within minutes, each
repeat is held to its own moment's physics.

Prints, per repeat, the stage's seconds (``simulate`` holds the model's load and the set-up, as
in report.json's timing_s), its CPU in the run's process and MuJoCo alone after it, then the
median ratios. To compare with an earlier revision, put its tree first on PYTHONPATH as
``gantry_sim`` (a folder holding a link named gantry_sim to a worktree of it).

    python benchmarks/bench_stream_stage.py poly 30000 --repeat 4 [--plots]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from bench_run import _replay_s

#: seconds a child waits for its workers' imports before the stage starts
WORKER_START_S = 2.5


def _stage(moves, planned, machine, plots: bool, trace_to: Path | None) -> dict:
    """In a forked child: the streamed stage once; its timing and CPU."""
    from gantry_sim.sim import api
    from gantry_sim.sim.analysis_worker import ProcessAnalyser
    from gantry_sim.sim.plot_worker import PlotWorker

    worker = ProcessAnalyser()
    plotter = None
    if plots:
        plotter = PlotWorker()
        plotter.start()
    time.sleep(WORKER_START_S)
    timing: dict[str, float] = {}
    cpu = time.process_time()
    result = api._streamed(
        moves, planned, machine, "p", "linuxcnc", 100.0, False, timing, True, worker, plotter, plots
    )
    out = {k: timing[k] for k in ("simulate", "analyse", "trace")}
    out["cpu"] = time.process_time() - cpu
    if trace_to is not None and result.full_trace is not None:
        result.full_trace.save(trace_to)
    if plotter is not None:
        plotter.close()
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=["arcs", "poly", "mixed"])
    ap.add_argument("blocks", type=int)
    ap.add_argument("--repeat", type=int, default=4)
    ap.add_argument("--plots", action="store_true", help="the plot worker computes the outline")
    args = ap.parse_args()
    os.environ.setdefault("GANTRY_PLOT_WORKER", "1")

    import numpy as np

    from benchmarks.programs import program
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.controller.gcode.dialects import with_segmentation_default
    from gantry_sim.controller.moves import Arc, Linear, Rapid, Spline
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.controller.spill import SpilledList
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim.machine import load_gantry
    from gantry_sim.sim.program import interpret_program

    machine = with_segmentation_default(load_machine_config(DEFAULT_MACHINE), "linuxcnc")
    items = interpret_program(
        program(args.kind, args.blocks),
        dialect="linuxcnc",
        file="p",
        machine=machine,
        search_path=[],
        max_iterations=10**6,
        events=True,
    )
    moves = SpilledList(m for m in items if isinstance(m, Rapid | Linear | Arc | Spline))
    planned = plan(items, machine)
    del items
    ticks = planned.sample_count(machine.servo.period_s)
    print(f"{args.kind} {args.blocks}: {ticks} ticks, plots {'on' if args.plots else 'off'}")
    import mujoco  # noqa: F401  (imported by the planned process, as a run's is by then)

    runs = []
    gantry = load_gantry(machine)
    with tempfile.TemporaryDirectory() as tmp:
        trace = Path(tmp) / "trace.npz"
        for k in range(args.repeat):
            r, w = os.pipe()
            pid = os.fork()
            if pid == 0:  # the child: one stage, its figures on the pipe
                os.close(r)
                got = _stage(moves, planned, machine, args.plots, trace if k == 0 else None)
                os.write(w, json.dumps(got).encode())
                os._exit(0)
            os.close(w)
            with os.fdopen(r) as f:
                text = f.read()
            os.waitpid(pid, 0)
            got = json.loads(text)
            if k == 0:
                with np.load(trace) as npz:
                    start, force = npz["ref"][0], npz["force_N"]
            got["alone"] = _replay_s(gantry, start, force)
            runs.append(got)
            print(
                f"  repeat {k + 1}: simulate {got['simulate']:.3f} s, analyse {got['analyse']:.3f}"
                f" s, trace {got['trace']:.3f} s, CPU of the run's process {got['cpu']:.3f} s;"
                f" MuJoCo alone {got['alone']:.3f} s"
            )
    sim = statistics.median(r["simulate"] / r["alone"] for r in runs)
    stage = statistics.median(
        (r["simulate"] + r["analyse"] + r["trace"]) / r["alone"] for r in runs
    )
    print(f"median simulate / MuJoCo alone: {sim:.2f}; stage / MuJoCo alone: {stage:.2f}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    sys.exit(main())
