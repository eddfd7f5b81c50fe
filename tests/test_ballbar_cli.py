"""`gantry ballbar` and `gantry tune` from the outside: contract keys, files, errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gantry_sim.sim.circular.tune import circle_error_um
from gantry_sim.sim.cli import main

CONTRACT_TOP = {
    "plane",
    "radius_mm",
    "feed_mm_per_min",
    "cw",
    "ccw",
    "bidirectional_deviation_um",
    "ellipse",
}
CONTRACT_DIRECTION = {
    "circular_deviation_um",
    "radial_deviation_um",
    "reversal_spikes_um",
    "centre_offset_um",
}
#: keys added after the contract (issue 14): every contract key stays, these come on top
ADDED_TOP = {"centre_mm", "diagnostics", "conditions", "circular_hysteresis_um"}
ADDED_DIRECTION = {"reversal_steps_um"}
DIAGNOSTICS = {
    "servo_mismatch_ms",
    "squareness_um_per_m",
    "scaling_mismatch_ppm",
    "backlash_um",
    "lateral_play_um",
    "path_speed_mm_per_min",
    "model_residual_rms_um",
}


@pytest.mark.parametrize("plane,axes", [("XY", (0, 1, 2)), ("XZ", (0, 2, 1)), ("YZ", (1, 2, 0))])
def test_ballbar_prints_the_contract_object_and_writes_its_files(tmp_path, capsys, plane, axes):
    out = tmp_path / "bb"
    rc = main(["ballbar", "--plane", plane, "--radius", "5", "--feed", "3000", "--out", str(out)])
    assert rc == 0
    printed = json.loads(capsys.readouterr().out)
    assert set(printed) == CONTRACT_TOP | ADDED_TOP
    assert set(printed["diagnostics"]) == DIAGNOSTICS
    assert set(printed["diagnostics"]["backlash_um"]) == set(plane)
    assert set(printed["diagnostics"]["lateral_play_um"]) == set(plane)
    assert printed["centre_mm"] == [0.0, 0.0, 0.0]
    for d in ("cw", "ccw"):
        assert set(printed[d]) == CONTRACT_DIRECTION | ADDED_DIRECTION
        assert len(printed[d]["reversal_steps_um"]) == 4
        assert set(printed[d]["radial_deviation_um"]) == {"max", "min"}
        assert len(printed[d]["reversal_spikes_um"]) == 4
        assert len(printed[d]["centre_offset_um"]) == 2
        g = printed[d]["circular_deviation_um"]
        f = printed[d]["radial_deviation_um"]
        assert 0 < g < 50 and f["min"] <= f["max"]
    assert set(printed["ellipse"]) == {"axis_deg", "magnitude_um", "flips_with_direction"}
    assert (printed["plane"], printed["radius_mm"], printed["feed_mm_per_min"]) == (plane, 5, 3000)
    assert json.loads((out / "ballbar.json").read_text()) == printed
    assert (out / "polar.png").read_bytes()[:4] == b"\x89PNG"
    assert "G2" in (out / "ballbar.ngc").read_text() and "G3" in (out / "ballbar.ngc").read_text()
    i1, i2, n = axes
    for d in ("cw", "ccw"):
        z = np.load(out / f"trace_{d}.npz")
        assert {"t", "ref", "pos"} <= set(z.files)
        assert np.all(np.diff(z["t"]) > 0)
        # Work coordinates: the circle of radius 5 about the origin, in the plane.
        r = np.hypot(z["pos"][:, i1], z["pos"][:, i2])
        assert np.all(np.abs(r - 5.0) < 0.05)
        assert np.all(np.abs(z["pos"][:, n]) < 0.05)


@pytest.mark.parametrize(
    "args,where",
    [
        (["--radius", "-5"], "--radius: error:"),
        (["--feed", "0"], "--feed: error:"),
        (["--radius", "400"], "error:"),  # leaves the travel
        (["--radius", "0.05", "--feed", "20000"], "--radius: error:"),  # too few samples
    ],
)
def test_ballbar_rejects_bad_input_with_status_2(capsys, args, where):
    assert main(["ballbar", *args]) == 2
    err = capsys.readouterr().err
    assert where in err and "Traceback" not in err


def test_ballbar_bad_machine_file_is_status_2(tmp_path, capsys):
    bad = tmp_path / "m.toml"
    bad.write_text("[servo]\nkp_N_per_mm = 5\n")
    assert main(["ballbar", "--machine", str(bad)]) == 2
    assert f"{bad}: error:" in capsys.readouterr().err


def test_tune_without_feedforward_follows_the_square_root_of_the_radius(tmp_path, capsys):
    """A PD loop without feedforward lags its inertia: error ~ m v^2 / (R kp), so the feed
    that keeps a fixed error grows as sqrt(R)."""
    machine_file = tmp_path / "noff.toml"
    machine_file.write_text(
        "[servo]\nff_velocity = [0.0, 0.0, 0.0]\nff_acceleration = [0.0, 0.0, 0.0]\n"
    )
    out = tmp_path / "tune"
    argv = ["tune", "--radii", "5,10", "--tolerance-um", "10", "--machine", str(machine_file)]
    assert main([*argv, "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert json.loads((out / "tune.json").read_text()) == printed
    assert (out / "tune.png").read_bytes()[:4] == b"\x89PNG"
    assert printed["tolerance_um"] == 10.0
    rows = printed["rows"]
    assert [r["radius_mm"] for r in rows] == [5.0, 10.0]
    for r in rows:
        assert {"radius_mm", "max_feed_mm_per_min", "max_error_um"} <= set(r)
        assert r["limited_by"] == "tolerance" and r["max_error_um"] <= 10.0
    ratio = rows[1]["max_feed_mm_per_min"] / rows[0]["max_feed_mm_per_min"]
    assert ratio == pytest.approx(math.sqrt(2.0), rel=0.1)
    # The answer is tight: two resolution steps higher fails.
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE

    machine = load_machine_config(DEFAULT_MACHINE, machine_file)
    above = rows[0]["max_feed_mm_per_min"] + 2 * printed["feed_resolution_mm_per_min"]
    assert circle_error_um(machine, "XY", 5.0, above)[0] > 10.0


def test_tune_rejects_bad_radii(capsys):
    assert main(["tune", "--radii", "5,x"]) == 2
    assert "--radii: error:" in capsys.readouterr().err
    assert main(["tune", "--radii", "5,-1"]) == 2
