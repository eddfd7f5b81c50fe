"""gantry_sim.sim.circular.figures on synthetic traces with known answers (exact geometry, no simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.sim.circular.figures import (
    analyse_circle,
    ballbar_json,
    bidirectional_deviation_um,
    circular_hysteresis_um,
    ellipse_flips,
    fit_circle,
    harmonic_ellipse,
    plane_coords,
)

R = 50.0  # mm
N = 7200


def circle_points(dev_um, centre=(0.0, 0.0), start_deg=45.0, sense=1.0, turns=1.0, n=N):
    """Points at angles start + sense * [0, 360*turns) about centre, radius R + dev_um(theta)."""
    theta = np.radians(start_deg) + sense * np.linspace(0, 2 * np.pi * turns, n, endpoint=False)
    r = R + dev_um(theta) * 1e-3
    return np.column_stack((centre[0] + r * np.cos(theta), centre[1] + r * np.sin(theta)))


def test_fit_circle_recovers_centre_and_radius_from_a_quarter_arc():
    t = np.linspace(0.2, 1.8, 50)
    pts = np.column_stack((3.0 + 7.0 * np.cos(t), -2.0 + 7.0 * np.sin(t)))
    c, r = fit_circle(pts)
    assert np.allclose(c, [3.0, -2.0], atol=1e-9)
    assert r == pytest.approx(7.0, abs=1e-9)


def test_plane_coords_use_the_plane_name_order():
    p = np.array([[1.0, 2.0, 3.0]])
    assert plane_coords(p, "XY").tolist() == [[1.0, 2.0]]
    assert plane_coords(p, "XZ").tolist() == [[1.0, 3.0]]
    assert plane_coords(p, "YZ").tolist() == [[2.0, 3.0]]
    with pytest.raises(ValueError, match="XY, XZ, YZ"):
        plane_coords(p, "ZX")


@pytest.mark.parametrize("axis_deg", [0.0, 30.0, 45.0, 135.0, 170.0])
def test_rotated_ellipse_gives_its_axis_and_magnitude(axis_deg):
    d_um = 10.0  # semi-axes R + d and R - d
    t = np.linspace(0, 2 * np.pi, N, endpoint=False)
    a, b = R + d_um * 1e-3, R - d_um * 1e-3
    phi = math.radians(axis_deg)
    x, y = a * np.cos(t), b * np.sin(t)
    pts = np.column_stack(
        (x * math.cos(phi) - y * math.sin(phi), x * math.sin(phi) + y * math.cos(phi))
    )
    res = analyse_circle(pts, np.zeros(2), R, "ccw")
    assert res.ellipse.magnitude_um == pytest.approx(2 * d_um, rel=1e-3)
    diff = (res.ellipse.axis_deg - axis_deg + 90.0) % 180.0 - 90.0
    assert abs(diff) < 0.01
    assert res.circular_deviation_um == pytest.approx(2 * d_um, rel=1e-3)
    assert res.radial_deviation_max_um == pytest.approx(d_um, rel=1e-3)
    assert res.radial_deviation_min_um == pytest.approx(-d_um, rel=1e-3)
    assert np.allclose(res.centre_offset_um, 0.0, atol=1e-6)
    assert np.allclose(res.reversal_spikes_um, 0.0, atol=0.05 * d_um)


def test_offset_circle_gives_centre_offset_and_radial_deviation_about_nominal():
    off = np.array([3e-3, -4e-3])  # mm: 3 um, -4 um
    pts = circle_points(lambda th: np.full_like(th, 2.0), centre=off)
    res = analyse_circle(pts, np.zeros(2), R, "ccw")
    assert res.centre_offset_um == pytest.approx((3.0, -4.0), abs=1e-6)
    assert res.fitted_radius_mm == pytest.approx(R + 2e-3, abs=1e-9)
    assert res.circular_deviation_um == pytest.approx(0.0, abs=1e-6)
    # About the nominal centre the radius is R + 2 um + 5 um cos(theta - theta_off).
    assert res.radial_deviation_max_um == pytest.approx(7.0, abs=1e-3)
    assert res.radial_deviation_min_um == pytest.approx(-3.0, abs=1e-3)
    assert res.ellipse.magnitude_um == pytest.approx(0.0, abs=1e-6)


def bump(theta, at_deg, h_um, sense, width_deg=1.0, delay_deg=2.0):
    """A spike of height h just after the crossing at ``at_deg`` in the direction of motion."""
    psi = np.degrees(np.angle(np.exp(1j * sense * (theta - np.radians(at_deg)))))
    return h_um * np.exp(-(((psi - delay_deg) / width_deg) ** 2))


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_spike_of_known_size_at_90_degrees(sense):
    h = 4.0
    pts = circle_points(lambda th: bump(th, 90.0, h, sense), sense=sense)
    res = analyse_circle(pts, np.zeros(2), R, "ccw" if sense > 0 else "cw")
    spikes = res.reversal_spikes_um
    assert len(spikes) == 4
    assert spikes[1] == pytest.approx(h, rel=0.03)
    for k in (0, 2, 3):
        assert abs(spikes[k]) < 0.03 * h
    assert res.circular_deviation_um == pytest.approx(h, rel=0.01)


def test_spikes_on_an_ellipse_are_measured_above_it():
    h = -3.0  # an inward spike
    pts = circle_points(lambda th: 20.0 * np.cos(2 * (th - np.pi / 4)) + bump(th, 270.0, h, 1.0))
    res = analyse_circle(pts, np.zeros(2), R, "ccw")
    assert res.reversal_spikes_um[3] == pytest.approx(h, rel=0.05)
    for k in (0, 1, 2):
        assert abs(res.reversal_spikes_um[k]) < 0.05 * abs(h)
    assert res.ellipse.axis_deg == pytest.approx(45.0, abs=0.1)


def test_step_at_every_crossing_gives_the_step_height():
    # A PD loop with Coulomb friction: each axis's offset flips sign when it reverses, so the
    # deviation jumps by 2e at each crossing.
    e_a, e_b = 3.0, 5.0
    pts = circle_points(lambda th: _friction(th, e_a, e_b))
    res = analyse_circle(pts, np.zeros(2), R, "ccw")
    assert res.reversal_spikes_um == pytest.approx((2 * e_a, 2 * e_b, 2 * e_a, 2 * e_b), rel=0.06)


def _friction(theta, e_a, e_b):
    # CCW: v_a = -sin, v_b = cos; offset = +e * sign(-v) along each axis (the axis lags).
    return e_a * np.sign(np.sin(theta)) * np.cos(theta) - e_b * np.sign(np.cos(theta)) * np.sin(
        theta
    )


def test_data_past_360_degrees_is_dropped():
    pts = circle_points(lambda th: 5.0 * np.cos(2 * th), turns=1.25, n=9000)
    res = analyse_circle(pts, np.zeros(2), R, "ccw")
    assert len(res.deviation_um) == pytest.approx(7200, abs=2)


def test_bidirectional_deviation_spans_both_traces():
    a_um = 6.0
    cw = analyse_circle(
        circle_points(lambda th: 0 * th, centre=(a_um * 1e-3, 0), sense=-1), np.zeros(2), R, "cw"
    )
    ccw = analyse_circle(
        circle_points(lambda th: 0 * th, centre=(-a_um * 1e-3, 0)), np.zeros(2), R, "ccw"
    )
    assert cw.circular_deviation_um == pytest.approx(0.0, abs=1e-6)
    assert bidirectional_deviation_um(cw, ccw) == pytest.approx(2 * a_um, rel=1e-3)


def test_ellipse_flip_rule():
    t = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    e45 = harmonic_ellipse(t, 2.0 * np.cos(2 * (t - np.pi / 4)))
    e135 = harmonic_ellipse(t, 2.0 * np.cos(2 * (t - 3 * np.pi / 4)))
    e50 = harmonic_ellipse(t, 2.0 * np.cos(2 * (t - np.radians(50))))
    tiny = harmonic_ellipse(t, 0.01 * np.cos(2 * (t - 3 * np.pi / 4)))
    assert e45.axis_deg == pytest.approx(45.0) and e45.magnitude_um == pytest.approx(4.0)
    assert ellipse_flips(e45, e135)
    assert not ellipse_flips(e45, e50)
    assert not ellipse_flips(e45, tiny)


def test_ballbar_json_has_the_contract_keys_then_the_added_ones():
    ccw = analyse_circle(
        circle_points(lambda th: 3 * np.cos(2 * (th - np.pi / 4))), np.zeros(2), R, "ccw"
    )
    cw = analyse_circle(
        circle_points(lambda th: 3 * np.cos(2 * (th + np.pi / 4)), sense=-1), np.zeros(2), R, "cw"
    )
    out = ballbar_json("XY", R, 1000.0, cw, ccw, {"added": 1})
    top = {"plane", "radius_mm", "feed_mm_per_min", "cw", "ccw", "bidirectional_deviation_um"}
    assert set(out) == top | {"ellipse", "circular_hysteresis_um", "added"}
    assert list(out)[-1] == "added"  # added keys come after the contract's
    per_direction = {"circular_deviation_um", "radial_deviation_um", "reversal_spikes_um"}
    for d in ("cw", "ccw"):
        assert set(out[d]) == per_direction | {"centre_offset_um", "reversal_steps_um"}
        assert set(out[d]["radial_deviation_um"]) == {"max", "min"}
        assert len(out[d]["reversal_spikes_um"]) == 4 and len(out[d]["centre_offset_um"]) == 2
    assert set(out["ellipse"]) == {"axis_deg", "magnitude_um", "flips_with_direction"}
    assert out["ellipse"]["flips_with_direction"] is True
    assert out["ellipse"]["axis_deg"] == pytest.approx(45.0, abs=0.01)


@pytest.mark.parametrize("shift_deg", [0.0, 37.0])
def test_circular_hysteresis_is_the_largest_radial_gap_between_the_directions(shift_deg):
    """CCW traces R + A cos 2(t - 45 deg), CW the flipped ellipse R - A cos 2(t - 45 deg): at
    the same angle their radii differ by up to 2 A, wherever the samples fall."""
    a_um = 1.5

    def ell(sign):
        return lambda th: sign * a_um * np.cos(2 * (th - np.pi / 4))

    ccw = analyse_circle(circle_points(ell(1.0)), np.zeros(2), R, "ccw")
    cw = analyse_circle(
        circle_points(ell(-1.0), start_deg=45.0 + shift_deg, sense=-1, n=N - 7),
        np.zeros(2),
        R,
        "cw",
    )
    assert circular_hysteresis_um(cw, ccw) == pytest.approx(2 * a_um, rel=1e-3)
    same = analyse_circle(circle_points(ell(1.0), sense=-1), np.zeros(2), R, "cw")
    assert circular_hysteresis_um(same, ccw) == pytest.approx(0.0, abs=1e-3)
