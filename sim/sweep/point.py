"""One sweep grid point and its simulation: feed override [%], accel [mm/s^2], jerk [mm/s^3]."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import SimulationError
from gantry_sim.controller.forked import one_process
from gantry_sim.sim.budget import Budget, BudgetError


@dataclass(frozen=True)
class SweepPoint:
    """One grid point: feed override [%]; accel [mm/s^2] and jerk [mm/s^3] for all axes, or None
    to keep the machine's per-axis values."""

    feed_override_pct: float
    max_accel_mm_per_s2: float | None = None
    max_jerk_mm_per_s3: float | None = None

    def key(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)


def machine_for(machine: MachineConfig, point: SweepPoint) -> MachineConfig:
    """``machine`` with the point's accel and jerk on all axes (validated)."""
    changes = {}
    if point.max_accel_mm_per_s2 is not None:
        changes["max_acceleration_mm_per_s2"] = [point.max_accel_mm_per_s2] * 3
    if point.max_jerk_mm_per_s3 is not None:
        changes["max_jerk_mm_per_s3"] = [point.max_jerk_mm_per_s3] * 3
    return machine.with_changes("limits", **changes) if changes else machine


#: the interpreter's program setup for every point: (subroutine search path, max iterations),
#: or () for the defaults
ProgramSetup = tuple[tuple[Path, ...], int] | tuple[()]


def _setup_kwargs(setup: ProgramSetup) -> dict:
    if not setup:
        return {}
    return {"search_path": setup[0], "max_iterations": setup[1]}


def run_point(
    text: str,
    file: str,
    dialect: str,
    machine: MachineConfig,
    point: SweepPoint,
    budget: Budget | None = None,
    setup: ProgramSetup = (),
) -> dict:
    """Simulate one grid point -> a sweep.csv row (a dict over COLUMNS); ``setup`` is
    (search path, max iterations) for the interpreter, or () for the defaults.

    A simulation that fails (SimulationError, e.g. a following-error fault at an aggressive
    setting) is a result, not a crash: its row has status "simulation error: ..." and no figures;
    so is a point whose simulation would exceed ``budget`` (a low feed override): "over the
    budget: ...". Other errors (the program or machine is invalid everywhere) propagate.
    """
    from gantry_sim.sim.api import run_program

    row = {
        "feed_override_pct": point.feed_override_pct,
        "max_accel_mm_per_s2": point.max_accel_mm_per_s2,
        "max_jerk_mm_per_s3": point.max_jerk_mm_per_s3,
    }
    try:
        with one_process():  # the sweep runs a point per core: no forked planning on top
            result = run_program(
                text,
                file=file,
                dialect=dialect,
                machine=machine_for(machine, point),
                feed_override_pct=point.feed_override_pct,
                budget=budget,
                keep_trace=False,  # a point writes no trace.npz and draws no plots:
                plots=False,  # neither is prepared (matplotlib's import, the deflating)
                **_setup_kwargs(setup),
            )
    except (SimulationError, BudgetError) as exc:
        nan = float("nan")
        what = "over the budget" if isinstance(exc, BudgetError) else "simulation error"
        return row | {
            "cycle_time_s": nan,
            "max_error_um": nan,
            "rms_error_um": nan,
            "p95_error_um": nan,
            "status": f"{what}: {exc.message}",
        }
    report = result.run_report
    return row | {
        "cycle_time_s": report.cycle_time_s,
        "max_error_um": report.contour_error_um.max_um,
        "rms_error_um": report.contour_error_um.rms_um,
        "p95_error_um": report.contour_error_um.p95_um,
        "status": "ok",
    }
