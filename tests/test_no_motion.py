"""Programs that command no motion (an empty program, a dwell alone) run: nothing is commanded,
so there is no contour error, and the machine sits still for the dwell."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gantry_sim.sim.cli import main


@pytest.mark.parametrize(
    ("text", "cycle_s"),
    [("%\n%\n", 0.0), ("G21\nG4 P0.3\nM2\n", 0.3), ("G21 G90\n(only a comment)\nM2\n", 0.0)],
)
def test_a_program_without_moves_runs_with_no_error(tmp_path, capsys, text, cycle_s) -> None:
    prog = tmp_path / "still.ngc"
    prog.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(prog), "--out", str(out), "--json"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["cycle_time_s"] == pytest.approx(cycle_s, abs=1e-9)
    assert report["contour_error_um"]["max"] == 0.0
    with np.load(out / "trace.npz") as trace:
        assert not trace["err_um"].any()
        # at rest where it started: the servo holds the home position
        assert np.abs(trace["pos"] - trace["pos"][0]).max() < 1e-6
    assert "Traceback" not in capsys.readouterr().err
