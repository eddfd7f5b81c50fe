"""Shared fixtures: the bundled machine and small helpers to write programs to disk."""

from __future__ import annotations

from pathlib import Path

import pytest

from gantry_sim.controller.config import MachineConfig, load_machine_config
from gantry_sim.models import DEFAULT_MACHINE

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def machine() -> MachineConfig:
    """The bundled machine file, validated."""
    return load_machine_config(DEFAULT_MACHINE)


@pytest.fixture
def write_program(tmp_path: Path):
    """Write G-code text to a file in tmp_path and return its path."""

    def _write(text: str, name: str = "prog.ngc") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write


@pytest.fixture(autouse=True)
def _work_in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every test runs in its own temporary folder, so a command's default output folder
    (./out) never lands in the checkout; tests name repository files through ROOT.

    The plots are drawn in the run's process (``GANTRY_PLOT_WORKER=0``, for the commands the
    tests run as processes too): the suite's many runs in its own processes share one import of
    matplotlib, where a plot worker per run imported it again (0.5-0.7 s of CPU each, about 35
    s of the suite's). tests/test_plot_worker.py runs the worker, whose plots are these byte for
    byte."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "0")
