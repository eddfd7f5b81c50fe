"""`gantry machine show`: the effective machine from the machine file and the MJCF."""

from __future__ import annotations

import json

import pytest

from gantry_sim.controller.loop_figures import AxisLoop, gain_margin
from gantry_sim.sim.cli import main


def _show_json(capsys, *extra: str) -> dict:
    assert main(["machine", "show", "--json", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def test_bundled_machine_as_json(capsys, machine):
    info = _show_json(capsys)
    assert info["servo_period_s"] == machine.servo.period_s
    # models/gantry.xml: bodies + armature per axis (its header's table)
    expect = {"x": (15.0, 2.0), "y": (55.0, 5.0), "z": (5.0, 4.0)}
    for i, (name, ax) in enumerate(info["axes"].items()):
        bodies, armature = expect[name]
        assert ax["bodies_kg"] == pytest.approx(bodies)
        assert ax["armature_kg"] == pytest.approx(armature)
        assert ax["moving_mass_kg"] == pytest.approx(bodies + armature)
        kp, kd = machine.servo.kp_N_per_mm[i], machine.servo.kd_N_s_per_mm[i]
        assert ax["kv_per_s"] == pytest.approx(kp / kd)
        assert ax["kv_m_per_min_per_mm"] == pytest.approx(kp / kd * 60 / 1000)
        assert ax["natural_frequency_Hz"] == pytest.approx(40.0, rel=1e-3)
        assert ax["damping_ratio"] == pytest.approx(0.7, rel=2e-3)
        loop = AxisLoop(bodies + armature, kp, kd, 0.0, machine.servo.period_s)
        assert ax["gain_margin"] == pytest.approx(gain_margin(loop))
        assert 4.0 < ax["gain_margin"] < 5.5
        assert 0 < ax["bandwidth_Hz"] < 500.0
        assert ax["max_velocity_mm_per_min"] == machine.limits.max_velocity_mm_per_s[i] * 60
    assert info["axes"]["z"]["gravity_load_N"] == pytest.approx(-5.0 * 9.81)
    assert info["axes"]["y"]["force_max_N"] == 1000.0


def test_table_for_people(capsys):
    assert main(["machine", "show"]) == 0
    out = capsys.readouterr().out
    for row in ("moving mass [kg]", "Kv [(m/min)/mm]", "bandwidth -3 dB [Hz]", "gain margin [x]"):
        assert row in out
    assert "WARNING" not in out
    # the path control a program starts in (a grbl import's $11 sets it): it had not been shown
    assert "path control at program start G64 (blend within 0.01 mm, short moves fit)" in out


def test_path_control_of_a_machine_file_is_shown(tmp_path, capsys):
    mf = tmp_path / "g61.toml"
    mf.write_text('[path]\nmode = "G61"\n[segmentation]\nmethod = "fixed"\n')
    info = _show_json(capsys, "--machine", str(mf))
    assert info["path"]["mode"] == "G61"
    assert main(["machine", "show", "--machine", str(mf)]) == 0
    out = capsys.readouterr().out
    assert "path control at program start G61; arcs in segments of" in out


def test_machine_file_changes_show_through(tmp_path, capsys, machine):
    """Gains 6x the bundled ones exceed the 4.75x margin: shown < 1 with a warning."""
    mf = tmp_path / "stiff.toml"
    kp = [6 * k for k in machine.servo.kp_N_per_mm]
    kd = [6 * k for k in machine.servo.kd_N_s_per_mm]
    mf.write_text(
        f"[servo]\nkp_N_per_mm = {kp}\nkd_N_s_per_mm = {kd}\n[sim]\nbacklash_mm = [0.01, 0, 0]\n"
    )
    info = _show_json(capsys, "--machine", str(mf))
    assert all(ax["gain_margin"] < 1.0 for ax in info["axes"].values())
    assert info["axes"]["x"]["backlash_mm"] == 0.01
    assert main(["machine", "show", "--machine", str(mf)]) == 0
    assert "WARNING: gain margin < 1 on X, Y, Z" in capsys.readouterr().out


def test_bad_machine_file_exits_2(tmp_path, capsys):
    mf = tmp_path / "bad.toml"
    mf.write_text("[servo]\nki_N_per_mm_s = [-1, 0, 0]\n")
    assert main(["machine", "show", "--machine", str(mf)]) == 2
    assert f"{mf}: error: [servo] ki_N_per_mm_s" in capsys.readouterr().err
