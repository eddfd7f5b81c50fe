"""report.json, trace.npz and the PNG plots of a run (drawn by sim.plots, imported lazily).

report.json keys (contract, see README "Running a simulation"): program, dialect, cycle_time_s,
contour_error_um {max, rms, p95}, parts_um {chord_max, reference_max, tracking_max}, blocks
[{line, kind, max_error_um, rms_error_um}], limits, sim {physics_timestep_s, servo_period_s, steps,
realtime_factor}, timing_s {parse, plan, simulate, analyse, total}; plus a few extra keys.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

#: files a run writes into its output folder (removed first by `gantry run`: no stale report)
OUTPUT_FILES = ("report.json", "trace.npz", "path.png", "error.png")


def build_report(
    *, program, dialect, machine, plant, feed_override_pct, planned, traj, sim, analysis, timing
) -> dict[str, Any]:
    """The report.json dictionary (units in the key names; errors [um], times [s])."""
    force = np.abs(sim.force)
    limit = np.array([[-p.force_min_N, p.force_max_N] for p in plant]).min(axis=1)
    saturated = (force >= limit * (1 - 1e-12)).mean(axis=0) if force.size else np.zeros(3)
    return {
        "program": program,
        "dialect": dialect,
        "machine": machine.source,
        "feed_override_pct": float(feed_override_pct),
        "cycle_time_s": float(planned.duration_s),
        "contour_error_um": analysis.contour_um,
        "parts_um": analysis.parts_um,
        "blocks": analysis.blocks,
        "limits": machine.limits.to_json(),
        "moves": len(planned.moves),
        "segments": int(planned.segment_count),
        "chord_tolerance_mm": float(planned.chord_tolerance_mm),
        "sim": {
            "physics_timestep_s": machine.sim.physics_timestep_s,
            "servo_period_s": machine.servo.period_s,
            "steps": int(sim.steps),
            "realtime_factor": float(traj.duration_s / sim.wall_s) if sim.wall_s > 0 else 0.0,
            "model": machine.sim.model,
            "max_force_N": [float(v) for v in (force.max(axis=0) if force.size else np.zeros(3))],
            "saturated_fraction": [float(v) for v in saturated],
        },
        "timing_s": {k: float(v) for k, v in timing.items()},
    }


def write_outputs(result, out_dir: Path) -> None:
    """Write the run's files into a temporary folder, then move them in, report.json last."""
    from gantry_sim.sim.outdir import atomic_output_dir
    from gantry_sim.sim.plots import save_error_plot, save_path_plot

    with atomic_output_dir(out_dir, last="report.json") as tmp:
        (tmp / "report.json").write_text(json.dumps(result.report, indent=2) + "\n")
        tr = result.trace
        np.savez_compressed(
            tmp / "trace.npz",
            t=tr.t,
            ref=tr.ref,
            pos=tr.pos,
            line=tr.line,
            err_um=tr.err_um,
            force_N=tr.force_N,
        )
        rep = result.report
        save_path_plot(tmp / "path.png", result.moves, tr, rep["program"], rep["contour_error_um"])
        save_error_plot(tmp / "error.png", tr, rep["contour_error_um"])
