"""path.png is drawn by a forked child while the run writes its other outputs
(sim/report.py, controller.forked.Background): the same picture as drawn in one process."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim import path_plot
from gantry_sim.sim.api import run_program, write_run_outputs

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork: Linux only")
def test_path_png_drawn_by_a_child_is_the_one_drawn_here(tmp_path, monkeypatch):
    result = run_program(EXAMPLES / "circle.ngc", machine=load_machine_config(DEFAULT_MACHINE))
    drawn_by = tmp_path / "drawn_by"
    real = path_plot.save_path_plot

    def recording(*args, **kwargs):  # type: ignore[no-untyped-def]
        drawn_by.write_text(str(os.getpid()))
        return real(*args, **kwargs)

    monkeypatch.setattr(path_plot, "save_path_plot", recording)
    pictures = {}
    for workers in ("1", "2"):
        monkeypatch.setenv("GANTRY_PLAN_WORKERS", workers)
        out = tmp_path / f"out{workers}"
        write_run_outputs(result, out)
        pictures[workers] = (out / "path.png").read_bytes()
        assert (drawn_by.read_text() == str(os.getpid())) == (workers == "1")
        assert {p.name for p in out.iterdir()} >= {"path.png", "error.png", "report.json"}
    assert pictures["1"] == pictures["2"] and len(pictures["1"]) > 10_000
