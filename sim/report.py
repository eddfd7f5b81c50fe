"""report.json, trace.npz and the PNG plots of a run (matplotlib Agg, imported lazily).

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
        plot_path(result, tmp / "path.png")
        plot_error(result, tmp / "error.png")


def _geometry_polyline(move) -> np.ndarray:
    from gantry_sim.controller.arcs import arc_points
    from gantry_sim.controller.moves import Arc

    if isinstance(move, Arc):
        n = max(16, int(np.ceil(move.angle / (2 * np.pi) * 360)))
        return arc_points(move, np.linspace(0.0, 1.0, n + 1))
    return np.array([move.start, move.end], dtype=float)


def _nice(x: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above x (>= 1)."""
    if x <= 1:
        return 1.0
    e = 10 ** np.floor(np.log10(x))
    return float(max(m * e for m in (1, 2, 5) if m * e <= x))


def plot_path(result, path: Path) -> None:
    """The commanded geometry, and the traced path with its error magnified, in the plane of
    largest extent."""
    from matplotlib.figure import Figure

    tr = result.trace
    polys = [(_geometry_polyline(mv), mv.kind) for mv in result.moves]
    cut = [p for p, kind in polys if kind != "rapid"] or [p for p, _ in polys] or [tr.ref]
    allpts = np.vstack(cut)
    span = allpts.max(axis=0) - allpts.min(axis=0)
    # the two axes of largest extent of the feed moves; XY unless Z clearly matters more
    i, j = sorted(np.argsort(span - np.array([0.0, 0.0, 1e-9]), kind="stable")[-2:])
    extent = float(max(span[i], span[j], 1e-6))
    feed = tr.feed
    emax = float(tr.err_um[feed].max()) / 1000.0 if feed.any() else 0.0
    gain = _nice(0.03 * extent / emax) if emax > 0 else 1.0
    traced = tr.nearest + gain * (tr.pos - tr.nearest)
    traced = np.where(feed[:, None], traced, np.nan)

    fig = Figure(figsize=(7, 7), dpi=110)
    ax = fig.add_subplot()
    labelled: set[str] = set()
    for p, kind in polys:
        rapid = kind == "rapid"
        style = dict(color="0.6", ls="--", lw=0.8) if rapid else dict(color="k", lw=1.0)
        label = "commanded rapid (G0)" if rapid else "commanded feed move"
        ax.plot(p[:, i], p[:, j], **style, label=None if label in labelled else label)
        labelled.add(label)
    ax.plot(traced[:, i], traced[:, j], color="tab:red", lw=0.9, label=f"traced, error x {gain:g}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{'XYZ'[i]} [mm]")
    ax.set_ylabel(f"{'XYZ'[j]} [mm]")
    ce = result.report["contour_error_um"]
    ax.set_title(f"{result.report['program']}: max {ce['max']:.2f} um, rms {ce['rms']:.2f} um")
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path)


def plot_error(result, path: Path) -> None:
    """Contour error along the program (feed moves) and the line being executed."""
    from matplotlib.figure import Figure

    tr = result.trace
    err = np.where(tr.feed, tr.err_um, np.nan)
    fig = Figure(figsize=(9, 5), dpi=110)
    ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    ax1.plot(tr.t, err, color="tab:red", lw=0.8)
    ax1.set_ylabel("contour error [um]")
    ce = result.report["contour_error_um"]
    ax1.axhline(ce["max"], color="0.5", lw=0.6, ls=":")
    ax1.set_title(f"max {ce['max']:.2f} um, p95 {ce['p95']:.2f} um, rms {ce['rms']:.2f} um")
    ax2.step(tr.t, tr.line, where="post", color="k", lw=0.8)
    ax2.set_ylabel("line")
    ax2.set_xlabel("time [s]")
    fig.savefig(path)
