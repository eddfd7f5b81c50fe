"""The virtual ballbar: run the circular-test program CCW and CW, analyse, write the outputs.

One simulation runs the whole program (sim.ballbar_program: CCW then CW, each a tangent
lead-in, the measured full circle and a tangent lead-out). The traced tool tip of each
direction's circle block (the samples whose reference executes that line) is analysed by
sim.circular in the plane's coordinates; positions are work coordinates [mm].
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError, GantryError, SimulationError
from gantry_sim.sim.circular.figures import (
    CircleAnalysis,
    analyse_circle,
    ballbar_json,
    plane_coords,
)
from gantry_sim.sim.circular.program import CircleTestProgram, circle_test_program
from gantry_sim.sim.outdir import atomic_output_dir

DIRECTIONS = ("ccw", "cw")
#: fewest traced samples (servo periods) on the measured circle for meaningful figures
MIN_SAMPLES = 360


@dataclass(frozen=True)
class BallbarResult:
    """A ballbar test: the program, the simulation, each direction's figures, the contract JSON.

    Attributes:
        program: the circular-test program that was run.
        run: the simulation's result (sim.api.RunResult: report, trace, moves).
        ccw / cw: each direction's figures (sim.circular.CircleAnalysis).
        summary: the ``gantry ballbar`` contract object.
    """

    program: CircleTestProgram
    run: Any
    ccw: CircleAnalysis
    cw: CircleAnalysis
    summary: dict


def direction_trace(run: Any, program: CircleTestProgram, direction: str) -> dict[str, np.ndarray]:
    """The trace arrays "t", "ref", "pos" of one direction's three blocks (lead-in to lead-out)."""
    line = np.asarray(run.trace.line)
    keep = np.isin(line, program.lines[direction])
    return {k: np.asarray(getattr(run.trace, k))[keep] for k in ("t", "ref", "pos")}


def circle_samples(run: Any, program: CircleTestProgram, direction: str) -> np.ndarray:
    """Traced tool-tip points (N, 3) [mm] of one direction's measured circle block."""
    keep = np.asarray(run.trace.line) == program.circle_line(direction)
    return np.asarray(run.trace.pos)[keep]


def option_error(
    exc: GantryError,
    program_file: str,
    what: str,
    radius_option: str,
    feed_option: str | None,
    machine_file: str,
) -> GantryError:
    """An error about a generated test program, re-addressed to the option a user can change
    (never a line of a program the user has not seen)."""
    from gantry_sim.sim.budget import BudgetError

    if exc.file == "--radius":  # circle_test_program's own checks
        return ConfigError(exc.message, file=radius_option)
    if exc.file != program_file:
        return exc
    if isinstance(exc, BudgetError):
        return ConfigError(f"{what}: {exc.summary}", file=feed_option or "--max-sim-s")
    if isinstance(exc, SimulationError):
        return SimulationError(f"{what}: {exc.message}", file=machine_file)
    return ConfigError(f"{what} cannot be run on this machine: {exc.message}", file=radius_option)


def run_ballbar(
    machine: MachineConfig,
    plane: str = "XY",
    radius_mm: float = 50.0,
    feed_mm_per_min: float = 1000.0,
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 0.0),
    progress: bool = False,
    budget: Any = None,
) -> BallbarResult:
    """Simulate the ballbar program on ``machine`` and analyse both directions.

    Args:
        machine: the machine (controller.config.MachineConfig).
        plane: "XY", "XZ" or "YZ".
        radius_mm: circle radius [mm].
        feed_mm_per_min: programmed feed [mm/min].
        centre_mm: circle centre, work coordinates [mm].
        progress: show the simulation's progress bar.
        budget: the simulation's bounds (sim.budget.Budget; default Budget()).

    Raises:
        ConfigError: invalid plane/radius/feed, or a circle so short in time that it has fewer
            than MIN_SAMPLES servo samples; PlanningError: the circle leaves the travel;
        SimulationError: the simulation failed.
    """
    from gantry_sim.sim.api import run_program

    what = f"the ballbar circle (R {radius_mm:g} mm, F {feed_mm_per_min:g} mm/min, {plane})"
    try:
        program = circle_test_program(plane, radius_mm, feed_mm_per_min, DIRECTIONS, centre_mm)
        run = run_program(
            program.text, file="ballbar.ngc", machine=machine, progress=progress, budget=budget
        )
    except GantryError as exc:
        raise option_error(exc, "ballbar.ngc", what, "--radius", "--feed", machine.source) from None
    centre_ab = plane_coords(np.array([program.centre_mm]), plane)[0]
    samples = {d: circle_samples(run, program, d) for d in DIRECTIONS}
    fewest = min(len(v) for v in samples.values())
    if fewest < MIN_SAMPLES:
        raise ConfigError(
            f"the {radius_mm:g} mm circle takes only {fewest} servo periods at this feed; a "
            f"ballbar needs at least {MIN_SAMPLES}: use a larger radius or a lower feed",
            file="--radius",
        )
    results = {
        d: analyse_circle(plane_coords(samples[d], plane), centre_ab, radius_mm, d)
        for d in DIRECTIONS
    }
    summary = ballbar_json(plane, radius_mm, feed_mm_per_min, results["cw"], results["ccw"])
    return BallbarResult(program, run, results["ccw"], results["cw"], summary)


def plot_polar(result: BallbarResult, path: Path) -> None:
    """Polar plot of the radial deviation about the LSQ centre, magnified, CCW and CW overlaid.

    As ballbar software shows it: angle = position on the circle (0 deg along the plane's
    first axis, 90 deg along its second), radius = deviation [um] on a scale whose zero is the
    dashed least-squares circle, so an ellipse, a spike or a step is seen where it happens.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = result.summary
    devs = np.concatenate([result.ccw.deviation_um, result.cw.deviation_um])
    lo, hi = float(devs.min()), float(devs.max())
    span = max(hi - lo, 1.0)
    fig = plt.figure(figsize=(7, 8))
    ax = fig.add_subplot(projection="polar")
    for res, colour in ((result.ccw, "tab:blue"), (result.cw, "tab:red")):
        order = np.argsort(res.theta_deg)
        th = np.radians(res.theta_deg[order])
        label = f"{res.direction.upper()}  G = {res.circular_deviation_um:.2f} um"
        ax.plot(
            np.append(th, th[0]),
            np.append(res.deviation_um[order], res.deviation_um[order][0]),
            color=colour,
            lw=0.6,
            label=label,
        )
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.zeros_like(ring), "k--", lw=0.8, label="least-squares circle (0 um)")
    ax.set_rorigin(lo - 1.2 * span)
    ax.set_rlim(lo - 0.1 * span, hi + 0.1 * span)
    a, b = s["plane"][0], s["plane"][1]
    ax.set_thetagrids([0, 90, 180, 270], [f"+{a}", f"+{b}", f"-{a}", f"-{b}"])
    ax.set_rlabel_position(67.5)
    ax.tick_params(axis="y", labelsize=7)
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    e = s["ellipse"]
    fig.suptitle(
        f"Ballbar {s['plane']}  R {s['radius_mm']:g} mm  F {s['feed_mm_per_min']:g} mm/min\n"
        f"radial deviation about the LSQ centre [um], magnified; G(b) "
        f"{s['bidirectional_deviation_um']:.2f} um\nellipse {e['magnitude_um']:.2f} um at "
        f"{e['axis_deg']:.0f} deg (CCW), flips with direction: {e['flips_with_direction']}",
        fontsize=9,
    )
    fig.tight_layout(rect=(0, 0.04, 1, 0.93))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_ballbar_outputs(result: BallbarResult, out_dir: Path) -> None:
    """Write ballbar.json, polar.png, ballbar.ngc, trace_cw.npz, trace_ccw.npz into ``out_dir``.

    The files are written to a staging folder first and committed only when all succeeded,
    ballbar.json removed first and moved in last (sim.outdir: old or new, never mixed).
    """
    with atomic_output_dir(out_dir, last="ballbar.json") as tmp:
        (tmp / "ballbar.json").write_text(json.dumps(result.summary, indent=2) + "\n")
        (tmp / "ballbar.ngc").write_text(result.program.text)
        for d in DIRECTIONS:
            np.savez_compressed(
                tmp / f"trace_{d}.npz", **direction_trace(result.run, result.program, d)
            )
        plot_polar(result, tmp / "polar.png")
