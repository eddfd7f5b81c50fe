"""The virtual ballbar against servo theory (short MuJoCo simulations, R 10 mm at 50 mm/s).

1. Unequal axis lags make a 45-degree ellipse whose axis flips with direction. With the
   velocity feedforward off, viscous damping c [N s/mm] needs a following error e = c v / kp
   along each axis: a first-order lag 1/Kv = c / kp [s] per axis (Kv, the position gain).
   Tracing x = R cos(wt - w/Kv_x), y = R sin(wt - w/Kv_y), the radius is
   R (1 - (d/2) sin 2 theta) with d = w (1/Kv_y - 1/Kv_x): an ellipse of magnitude
   (major - minor) R |d| = v |1/Kv_x - 1/Kv_y| whose major axis is at 45 deg when X lags
   more (CCW) and at 135 deg when the direction reverses. Equal lags: no ellipse.
2. Coulomb friction F [N] against a PD loop (no integrator) leaves a following error F / kp
   opposing the motion; it reverses with the axis, so at each quadrant crossing the radius
   steps by 2 F / kp (X at 0 and 180 deg, Y at 90 and 270 deg). Without friction: no steps.
"""

from __future__ import annotations

import pytest

from gantry_sim.sim.circular.ballbar import run_ballbar
from tests.machine_variants import FRICTIONLESS, gantry_variant, joint_attribute

R_MM = 10.0
FEED = 3000.0  # mm/min = 50 mm/s; v^2/R = 250 mm/s^2, far below the accel limits
V = FEED / 60.0


def lagging_machine(tmp_path, damping_x_N_s_per_m, damping_y_N_s_per_m):
    joints = {a: dict(FRICTIONLESS[a]) for a in FRICTIONLESS}
    joints["x"]["damping"] = damping_x_N_s_per_m
    joints["y"]["damping"] = damping_y_N_s_per_m
    return gantry_variant(tmp_path, joints, {"ff_velocity": [0.0, 0.0, 1.0]})


def test_unequal_lags_give_a_45_degree_ellipse_that_flips_with_direction(tmp_path):
    machine = lagging_machine(tmp_path, 400.0, 100.0)
    kp_x, kp_y = machine.servo.kp_N_per_mm[:2]
    lag_x, lag_y = 0.4 / kp_x, 0.1 / kp_y  # [s]: c [N s/mm] / kp [N/mm]
    assert lag_x > 3 * lag_y  # X lags more
    res = run_ballbar(machine, "XY", R_MM, FEED)
    expected_um = V * abs(lag_x - lag_y) * 1e3
    for r in (res.ccw, res.cw):
        assert r.ellipse.magnitude_um == pytest.approx(expected_um, rel=0.05)
    assert res.ccw.ellipse.axis_deg == pytest.approx(45.0, abs=3.0)
    assert res.cw.ellipse.axis_deg == pytest.approx(135.0, abs=3.0)
    e = res.summary["ellipse"]
    assert e["flips_with_direction"] is True
    assert e["axis_deg"] == pytest.approx(45.0, abs=3.0)
    # The ellipse dominates the shape: G is about its magnitude.
    assert res.ccw.circular_deviation_um == pytest.approx(expected_um, rel=0.1)


def test_equal_lags_give_no_ellipse(tmp_path):
    kp_x, kp_y = gantry_variant(tmp_path).servo.kp_N_per_mm[:2]
    machine = lagging_machine(tmp_path, 400.0, 400.0 * kp_y / kp_x)
    res = run_ballbar(machine, "XY", R_MM, FEED)
    unequal_um = V * abs(0.4 / kp_x - 0.1 / kp_y) * 1e3
    for r in (res.ccw, res.cw):
        assert r.ellipse.magnitude_um < 0.02 * unequal_um
    assert res.summary["ellipse"]["flips_with_direction"] is False


def test_friction_steps_at_quadrant_crossings_and_none_without_friction(tmp_path, machine):
    kp_x, kp_y = machine.servo.kp_N_per_mm[:2]
    assert machine.servo.ff_friction[:2] == (0.0, 0.0)
    step_x = 2 * joint_attribute("x", "frictionloss") / kp_x * 1e3  # [um]
    step_y = 2 * joint_attribute("y", "frictionloss") / kp_y * 1e3
    assert min(step_x, step_y) > 1.0  # the bundled machine has friction worth measuring
    with_friction = run_ballbar(machine, "XY", R_MM, FEED)
    for r in (with_friction.ccw, with_friction.cw):
        assert r.reversal_spikes_um == pytest.approx((step_x, step_y, step_x, step_y), rel=0.06)
    without = run_ballbar(gantry_variant(tmp_path, FRICTIONLESS), "XY", R_MM, FEED)
    for r in (without.ccw, without.cw):
        assert max(abs(s) for s in r.reversal_spikes_um) < 0.1 * min(step_x, step_y)


def test_unequal_axis_gains_give_the_servo_mismatch_in_ms(tmp_path):
    """The machine file halves X's kp and turns the velocity feedforward off: each axis lags
    by c / kp (its MJCF damping c over its gain), X now more than Y. The diagnostics give the
    lag difference in ms, and X's friction step doubles (2 F / kp), read as backlash."""
    kp = [537.0, 3790.0, 568.5]
    machine = gantry_variant(tmp_path, servo={"kp_N_per_mm": kp, "ff_velocity": [0.0, 0.0, 1.0]})
    lag_x_ms = joint_attribute("x", "damping") * 1e-3 / kp[0] * 1e3  # c [N s/mm] / kp [N/mm]
    lag_y_ms = joint_attribute("y", "damping") * 1e-3 / kp[1] * 1e3
    assert lag_x_ms - lag_y_ms > 0.04
    d = run_ballbar(machine, "XY", R_MM, FEED).summary["diagnostics"]
    assert d["servo_mismatch_ms"] == pytest.approx(lag_x_ms - lag_y_ms, rel=0.05)
    assert d["path_speed_mm_per_min"] == pytest.approx(FEED, rel=1e-3)
    step_x = 2 * joint_attribute("x", "frictionloss") / kp[0] * 1e3
    assert d["backlash_um"]["X"] == pytest.approx(step_x, rel=0.05)


def test_the_bundled_machine_reads_as_friction_steps_only(machine):
    """Equal bandwidths and an exactly square, true-scaled model: the 2nd harmonic that flips
    with direction is the friction steps' (the plain ellipse), not a servo mismatch. The steps
    (2 F / kp per axis, a PD loop's friction lag) come out as backlash and persistent steps."""
    kp_x, kp_y = machine.servo.kp_N_per_mm[:2]
    step_x = 2 * joint_attribute("x", "frictionloss") / kp_x * 1e3  # [um]
    step_y = 2 * joint_attribute("y", "frictionloss") / kp_y * 1e3
    res = run_ballbar(machine, "XY", R_MM, FEED)
    assert res.summary["ellipse"]["flips_with_direction"] is True
    d = res.summary["diagnostics"]
    assert abs(d["servo_mismatch_ms"]) < 0.005
    assert abs(d["squareness_um_per_m"]) < 5.0 and abs(d["scaling_mismatch_ppm"]) < 5.0
    assert d["backlash_um"] == pytest.approx({"X": step_x, "Y": step_y}, rel=0.05)
    assert max(abs(v) for v in d["lateral_play_um"].values()) < 0.05 * step_y
    for r in (res.ccw, res.cw):
        assert r.reversal_steps_um == pytest.approx((step_x, step_y, step_x, step_y), rel=0.03)
