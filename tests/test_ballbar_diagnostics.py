"""Ballbar diagnostics on synthetic traces with known answers (exact geometry, no simulation).

Each trace is the nominal circle (R 10 mm about the origin, 360 degrees from 45 degrees, CCW and
CW) passed through a machine error written out in closed form: axis lags, an out-of-square b
axis, unequal axis scales, lost motion per axis (backlash), a sideways shift when an axis
reverses (lateral play). The diagnostics must give back the error that was put in.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.sim.circular.diagnostics import fit_diagnostics, outside_reversal_zones
from gantry_sim.sim.circular.figures import analyse_circle, ballbar_json

R = 10.0  # mm
V = 50.0  # mm/s
N = 7200


def trace(
    sense: float,
    lag_s=(0.0, 0.0),
    square_rad=0.0,
    scale=(0.0, 0.0),
    backlash_mm=(0.0, 0.0),
    lateral_mm=(0.0, 0.0),
    bump=None,
):
    """(N, 2) traced points [mm] of one direction (sense +1 CCW, -1 CW) with these errors.

    lag_s: (tau_a, tau_b) [s], each axis follows its reference tau late; square_rad: b moves
    along (alpha, 1); scale: (k_a, k_b), each axis travels (1 + k) times its command;
    backlash_mm: (B_a, B_b), each axis B/2 behind its command against its motion;
    lateral_mm: (L_a, L_b), b shifted by L_a/2 * sign(v_a) and a by L_b/2 * sign(v_b);
    bump: f(travel since the last crossing [deg]) -> radial bump [um] (a reversal spike).
    """
    phi = math.radians(45.0) + sense * np.linspace(0.0, 2.0 * math.pi, N, endpoint=False)
    w = V / R  # [rad/s]
    a = R * np.cos(phi - sense * w * lag_s[0])
    b = R * np.sin(phi - sense * w * lag_s[1])
    va, vb = np.sign(-sense * np.sin(phi)), np.sign(sense * np.cos(phi))
    a = a - 0.5 * backlash_mm[0] * va + 0.5 * lateral_mm[1] * vb
    b = b - 0.5 * backlash_mm[1] * vb + 0.5 * lateral_mm[0] * va
    a, b = a * (1.0 + scale[0]) + square_rad * b, b * (1.0 + scale[1])
    if bump is not None:
        r = np.hypot(a, b)
        grow = 1.0 + bump(np.degrees(sense * phi) % 90.0) * 1e-3 / r
        a, b = a * grow, b * grow
    return np.column_stack((a, b))


def axis_distance_deg(a: float, b: float) -> float:
    """Distance of two ellipse axes [deg], modulo 180."""
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)


def diagnose(**errors):
    ccw = analyse_circle(trace(+1.0, **errors), np.zeros(2), R, "ccw")
    cw = analyse_circle(trace(-1.0, **errors), np.zeros(2), R, "cw")
    return fit_diagnostics([ccw.nominal, cw.nominal], R, V), ccw, cw


def test_a_perfect_circle_has_no_diagnostics():
    d, _, _ = diagnose()
    assert d.servo_mismatch_ms == pytest.approx(0.0, abs=1e-9)
    assert d.squareness_um_per_m == pytest.approx(0.0, abs=1e-6)
    assert d.scaling_mismatch_ppm == pytest.approx(0.0, abs=1e-6)
    assert d.backlash_um == pytest.approx((0.0, 0.0), abs=1e-6)
    assert d.lateral_play_um == pytest.approx((0.0, 0.0), abs=1e-6)
    assert d.residual_rms_um < 1e-6


@pytest.mark.parametrize("lags_ms", [(2.0, 0.5), (0.3, 1.3)])
def test_axis_lags_give_the_servo_mismatch_in_ms(lags_ms):
    d, ccw, _ = diagnose(lag_s=(lags_ms[0] * 1e-3, lags_ms[1] * 1e-3))
    assert d.servo_mismatch_ms == pytest.approx(lags_ms[0] - lags_ms[1], rel=0.01)
    # A lag mismatch is no geometry error.
    assert abs(d.squareness_um_per_m) < 1.0 and abs(d.scaling_mismatch_ppm) < 1.0
    # It is the 45-degree ellipse that flips with direction, of magnitude v |tau_a - tau_b|.
    assert ccw.ellipse.magnitude_um == pytest.approx(V * abs(lags_ms[0] - lags_ms[1]), rel=0.01)


@pytest.mark.parametrize("alpha_um_per_m", [150.0, -80.0])
def test_an_out_of_square_axis_gives_the_squareness_in_um_per_m(alpha_um_per_m):
    d, ccw, cw = diagnose(square_rad=alpha_um_per_m * 1e-6)
    assert d.squareness_um_per_m == pytest.approx(alpha_um_per_m, rel=0.01)
    assert abs(d.servo_mismatch_ms) < 1e-4 and abs(d.scaling_mismatch_ppm) < 1.0
    # The ellipse at 45 (or 135) degrees keeps its axis in both directions.
    assert ccw.ellipse.axis_deg == pytest.approx(45.0 if alpha_um_per_m > 0 else 135.0, abs=0.5)
    assert cw.ellipse.axis_deg == pytest.approx(ccw.ellipse.axis_deg, abs=0.5)


@pytest.mark.parametrize("scale_ppm", [(120.0, 20.0), (0.0, 75.0)])
def test_unequal_axis_scales_give_the_scaling_mismatch_in_ppm(scale_ppm):
    d, ccw, _ = diagnose(scale=(scale_ppm[0] * 1e-6, scale_ppm[1] * 1e-6))
    assert d.scaling_mismatch_ppm == pytest.approx(scale_ppm[0] - scale_ppm[1], rel=0.01)
    assert abs(d.squareness_um_per_m) < 1.0 and abs(d.servo_mismatch_ms) < 1e-4
    major = 0.0 if scale_ppm[0] > scale_ppm[1] else 90.0
    assert axis_distance_deg(ccw.ellipse.axis_deg, major) < 0.5


def test_lost_motion_gives_the_backlash_per_axis_and_steps_at_its_reversals():
    d, ccw, cw = diagnose(backlash_mm=(6e-3, 3e-3))
    assert d.backlash_um == pytest.approx((6.0, 3.0), rel=1e-3)
    # (cross-talk below 0.5 %: the model places the steps at the traced, not commanded, angle)
    assert d.lateral_play_um == pytest.approx((0.0, 0.0), abs=0.03)
    # The friction-like steps make a 2nd harmonic that flips with direction (the plain ellipse
    # reads it as a servo mismatch of about 0.05 ms here); the joint fit does not.
    assert abs(d.servo_mismatch_ms) < 1e-3
    assert abs(d.squareness_um_per_m) < 0.5 and abs(d.scaling_mismatch_ppm) < 0.5
    summary = ballbar_json("XY", R, V * 60, cw, ccw)
    assert summary["ellipse"]["flips_with_direction"] is True
    # Persistent steps where each axis reverses: a at 0 and 180 deg, b at 90 and 270.
    for r in (ccw, cw):
        assert r.reversal_steps_um == pytest.approx((6.0, 3.0, 6.0, 3.0), rel=0.03)


def test_a_sideways_shift_at_reversal_gives_the_lateral_play():
    d, _, _ = diagnose(lateral_mm=(4e-3, -2e-3))
    assert d.lateral_play_um == pytest.approx((4.0, -2.0), rel=1e-3)
    assert d.backlash_um == pytest.approx((0.0, 0.0), abs=0.01)
    assert abs(d.scaling_mismatch_ppm) < 0.5 and abs(d.servo_mismatch_ms) < 1e-4


def test_all_causes_at_once_are_told_apart():
    d, _, _ = diagnose(
        lag_s=(1e-3, 0.2e-3),
        square_rad=100e-6,
        scale=(50e-6, -30e-6),
        backlash_mm=(5e-3, 2e-3),
        lateral_mm=(1.5e-3, 1e-3),
    )
    assert d.servo_mismatch_ms == pytest.approx(0.8, rel=0.02)
    assert d.squareness_um_per_m == pytest.approx(100.0, rel=0.02)
    assert d.scaling_mismatch_ppm == pytest.approx(80.0, rel=0.02)
    assert d.backlash_um == pytest.approx((5.0, 2.0), rel=0.02)
    assert d.lateral_play_um == pytest.approx((1.5, 1.0), rel=0.03)


def x_reversal_spike(h_um):
    """A spike of h_um that recovers within 6 degrees after X reverses (0 and 180 deg)."""

    def bump(travel_deg):
        return h_um * np.exp(-(((travel_deg - 2.0) / 1.2) ** 2))

    return bump


def test_reversal_spikes_are_kept_out_of_the_fit():
    """Spikes that recover are reversal spikes, not steps, backlash or a scale error: the fit
    leaves out the REVERSAL_ZONE_DEG after each crossing, where they live."""

    def at_x_reversals(travel_deg):
        return x_reversal_spike(5.0)(travel_deg)

    def only_x(sense):
        # the bump function sees travel since any crossing; keep X's (0 and 180 deg) only
        pts = trace(sense)
        phi = np.arctan2(pts[:, 1], pts[:, 0])
        near_x = np.abs(np.sin(phi - sense * np.radians(2.0))) < np.sin(np.radians(45.0))
        spiky = trace(sense, bump=at_x_reversals)
        return np.where(near_x[:, None], spiky, pts)

    ccw = analyse_circle(only_x(+1.0), np.zeros(2), R, "ccw")
    cw = analyse_circle(only_x(-1.0), np.zeros(2), R, "cw")
    for r in (ccw, cw):
        assert r.reversal_spikes_um[0] == pytest.approx(5.0, rel=0.05)
        assert r.reversal_spikes_um[2] == pytest.approx(5.0, rel=0.05)
        assert abs(r.reversal_spikes_um[1]) < 0.3 and abs(r.reversal_steps_um[0]) < 0.3
    d = fit_diagnostics([ccw.nominal, cw.nominal], R, V)
    assert d.backlash_um == pytest.approx((0.0, 0.0), abs=0.05)
    assert abs(d.scaling_mismatch_ppm) < 1.0
    # Fitted over every sample, the spikes would read as a scale error of tens of ppm.
    biased = fit_diagnostics([ccw.nominal, cw.nominal], R, V, zone_deg=0.0)
    assert abs(biased.scaling_mismatch_ppm) > 10.0


def test_reversal_zones_follow_the_direction_of_travel():
    theta = np.radians([1.0, 89.0, 91.0, 179.0, -1.0])
    assert outside_reversal_zones(theta, +1.0, 10.0).tolist() == [False, True, False, True, True]
    assert outside_reversal_zones(theta, -1.0, 10.0).tolist() == [True, False, True, False, False]
