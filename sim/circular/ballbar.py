"""The virtual ballbar: run the circular-test program CCW and CW, analyse, write the outputs.

One simulation runs the whole program (sim.circular.program: CCW then CW, each a tangent
lead-in, the measured full circle and a tangent lead-out). The traced tool tip of each
direction's circle block (the samples whose reference executes that line) is analysed by
sim.circular.figures in the plane's coordinates; positions are work coordinates [mm].
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gantry_sim.controller.config import MachineConfig, Travel
from gantry_sim.controller.errors import ConfigError, GantryError, SimulationError
from gantry_sim.controller.machine_work import NO_WORK
from gantry_sim.controller.planes import Vec3
from gantry_sim.sim.circular.diagnostics import diagnostics_json, fit_diagnostics
from gantry_sim.sim.circular.figures import (
    CircleAnalysis,
    analyse_circle,
    ballbar_json,
    plane_coords,
)
from gantry_sim.sim.circular.program import (
    LEAD_DEG,
    START_DEG,
    CircleTestProgram,
    circle_test_program,
)
from gantry_sim.sim.outdir import atomic_output_dir

if TYPE_CHECKING:
    from gantry_sim.sim.plot_worker import PlotWorker

DIRECTIONS = ("ccw", "cw")
#: the files ``gantry ballbar`` writes into its output folder (sim.outdir.atomic_output_dir)
BALLBAR_FILES = (
    "ballbar.json",
    "ballbar.ngc",
    *(f"trace_{d}.npz" for d in DIRECTIONS),
    "polar.png",
)
#: fewest traced samples (servo periods) on the measured circle for meaningful figures
MIN_SAMPLES = 360


@dataclass(frozen=True)
class BallbarResult:
    """A ballbar test: the program, the simulation, each direction's figures, the contract JSON.

    Attributes:
        program: the circular-test program that was run.
        run: the simulation's result (sim.api.RunResult: report, trace, moves).
        ccw / cw: each direction's figures (sim.circular.figures.CircleAnalysis).
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


def circle_speed_mm_per_s(run: Any, program: CircleTestProgram, direction: str) -> float:
    """Median speed of the reference along one direction's measured circle [mm/s]: the feed
    actually run (below the programmed one where the planner's acceleration caps bind)."""
    keep = np.asarray(run.trace.line) == program.circle_line(direction)
    ref, t = np.asarray(run.trace.ref)[keep], np.asarray(run.trace.t)[keep]
    return float(np.median(np.linalg.norm(np.diff(ref, axis=0), axis=1) / np.diff(t)))


def conditions_json(
    program: CircleTestProgram, machine: MachineConfig, machine_label: str | None
) -> dict:
    """The "conditions" object: what was run, where and how (no date: outputs are reproducible)."""
    return {
        "machine": machine_label or Path(machine.source).name,
        "centre_mm": list(program.centre_mm),
        "directions": [d.upper() for d in program.directions],
        "servo_period_s": machine.servo.period_s,
        "data_arc_deg": 360.0,
        "start_deg": START_DEG,
        "lead_in_deg": LEAD_DEG,
        "lead_out_deg": LEAD_DEG,
    }


def option_error(
    exc: GantryError,
    program_file: str,
    what: str,
    radius_option: str,
    feed_option: str | None,
    machine_file: str,
    centre_outside: bool = False,
) -> GantryError:
    """An error about a generated test program, re-addressed to the option a user can change
    (never a line of a program the user has not seen): a circle the machine cannot run is
    blamed on ``--centre`` where the centre itself lies outside the travel
    (``centre_outside``), else on ``radius_option``."""
    from gantry_sim.sim.budget import BudgetError

    if exc.file == "--radius":  # circle_test_program's own checks
        return ConfigError(exc.message, file=radius_option)
    if exc.file != program_file:
        return exc
    if isinstance(exc, BudgetError):
        return ConfigError(f"{what}: {exc.summary}", file=feed_option or "--max-sim-s")
    if isinstance(exc, SimulationError):
        return SimulationError(f"{what}: {exc.message}", file=machine_file)
    from gantry_sim.controller.planner.travel import TravelError

    option = "--centre" if centre_outside else radius_option
    message = exc.where_and_extent if isinstance(exc, TravelError) else exc.message
    return ConfigError(f"{what} cannot be run on this machine: {message}", file=option)


def outside_travel(point_mm: Vec3, travel: Travel) -> bool:
    """Whether ``point_mm`` (work coordinates [mm]) lies outside ``travel``."""
    return not all(
        lo <= v <= hi for v, lo, hi in zip(point_mm, travel.min_mm, travel.max_mm, strict=True)
    )


def run_ballbar(
    machine: MachineConfig,
    plane: str = "XY",
    radius_mm: float = 50.0,
    feed_mm_per_min: float = 1000.0,
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 0.0),
    progress: bool = False,
    machine_label: str | None = None,
    budget: Any = None,
    plots_elsewhere: bool = False,
) -> BallbarResult:
    """Simulate the ballbar program on ``machine`` and analyse both directions.

    Args:
        machine: the machine (controller.config.MachineConfig).
        plane: "XY", "XZ" or "YZ".
        radius_mm: circle radius [mm].
        feed_mm_per_min: programmed feed [mm/min].
        centre_mm: circle centre, work coordinates [mm].
        progress: show the simulation's progress bar.
        machine_label: how the test-conditions box names the machine (default: the name of
            the machine file it was read from).
        budget: the simulation's bounds (sim.budget.Budget; default Budget()).
        plots_elsewhere: polar.png will be drawn by a plot worker (sim.plot_worker): nothing
            of the plots is prepared in this process (matplotlib's import, otherwise begun in
            a thread during the run).

    Raises:
        ConfigError: invalid plane/radius/feed, or a circle so short in time that it has fewer
            than MIN_SAMPLES servo samples; PlanningError: the circle leaves the travel;
        SimulationError: the simulation failed.
    """
    from gantry_sim.sim.api import run_program

    what = f"the ballbar circle (R {radius_mm:g} mm, F {feed_mm_per_min:g} mm/min, {plane})"
    try:
        program = circle_test_program(plane, radius_mm, feed_mm_per_min, DIRECTIONS, centre_mm)
        # the program is written in the work frame (--centre): the machine file's [work] offsets
        # must not move it away from the centre the analysis uses
        bare = replace(machine, work=NO_WORK)
        run = run_program(
            program.text,
            file="ballbar.ngc",
            machine=bare,
            progress=progress,
            budget=budget,
            plots=False if plots_elsewhere else None,
        )
    except GantryError as exc:
        outside = outside_travel(centre_mm, machine.travel)
        raise option_error(
            exc, "ballbar.ngc", what, "--radius", "--feed", machine.source, outside
        ) from None
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
    speed = float(np.mean([circle_speed_mm_per_s(run, program, d) for d in DIRECTIONS]))
    diag = fit_diagnostics([results[d].nominal for d in DIRECTIONS], radius_mm, speed)
    extra = {
        "centre_mm": list(program.centre_mm),
        "diagnostics": diagnostics_json(diag, plane),
        "conditions": conditions_json(program, machine, machine_label),
    }
    summary = ballbar_json(plane, radius_mm, feed_mm_per_min, results["cw"], results["ccw"], extra)
    return BallbarResult(program, run, results["ccw"], results["cw"], summary)


def write_ballbar_outputs(
    result: BallbarResult, out_dir: Path, plotter: PlotWorker | None = None
) -> None:
    """Write ballbar.json, polar.png, ballbar.ngc, trace_cw.npz, trace_ccw.npz into ``out_dir``.

    The files are written to a staging folder first and committed only when all succeeded,
    ballbar.json removed first and moved in last (sim.outdir: old or new, never mixed).
    ``plotter``: a plot worker (sim.plot_worker) that draws polar.png while the other files are
    written (drawn here if it fails); None: drawn here.
    """
    from gantry_sim.sim.plot_worker import PolarRequest
    from gantry_sim.sim.trace_writer import save_npz

    polar = PolarRequest(result.ccw, result.cw, result.summary)
    sent = plotter is not None and plotter.draw(polar)
    with atomic_output_dir(out_dir, last="ballbar.json", owns=BALLBAR_FILES) as tmp:
        (tmp / "ballbar.json").write_text(json.dumps(result.summary, indent=2) + "\n")
        (tmp / "ballbar.ngc").write_text(result.program.text)
        for d in DIRECTIONS:
            tr = direction_trace(result.run, result.program, d)
            save_npz(tmp / f"trace_{d}.npz", {"t": tr["t"], "ref": tr["ref"], "pos": tr["pos"]})
        drawn = plotter.wait() if sent and plotter is not None else None
        (tmp / "polar.png").write_bytes((drawn or polar.render())[0])
