"""What a Dask worker runs for a sweep: the version probe and one grid point on shipped data.

A point's fixed inputs travel as values (program text, machine, budget and the MJCF with the
files it includes as a :class:`~gantry_sim.sim.sweep.model_bundle.ModelBundle`), so a worker
with another file layout simulates the same model as the client: no path of the client's is
opened on a worker.
"""

from __future__ import annotations

from gantry_sim.controller.config import MachineConfig
from gantry_sim.sim.budget import Budget
from gantry_sim.sim.sweep.model_bundle import ModelBundle, materialized, with_model
from gantry_sim.sim.sweep.point import ProgramSetup, SweepPoint, run_point

#: the sweep's fixed inputs: program text, its name, dialect, machine, budget, the model's files
Shared = tuple[str, str, str, MachineConfig, Budget | None, ModelBundle, ProgramSetup]


def installed_version() -> str:
    """The gantry-sim version installed where this runs (a worker answering the client)."""
    from importlib.metadata import version

    return version("gantry-sim")


def run_shipped_point(shared: Shared, point: SweepPoint) -> dict:
    """:func:`~gantry_sim.sim.sweep.grid.run_point` with the model written from the bundle."""
    text, file, dialect, machine, budget, bundle, setup = shared
    with materialized(bundle) as model:
        return run_point(text, file, dialect, with_model(machine, model), point, budget, setup)
