"""The quintic Bezier curve of the planner's G2 transitions (controller/quintic_curve.py):
closed-form points and derivatives, arc length and its inverse, the curvature bounds, nearest
points, and the same numbers for a curve alone as in a batch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.quintic_curve import (
    POINT_SEED_SAMPLES,
    QuinticCurve,
    arc_length_derivatives,
    derivatives,
    lengths_at,
    nearest_parameters,
    nearest_points_on,
    power_coefficients,
)


def _s_bend(h: float, k0: float = 0.2, k1: float = -0.2) -> np.ndarray:
    """The transition's control points between two circles of signed curvatures k0 and k1
    meeting tangentially at the origin along +X, cut h from the junction on each side."""

    def at(k: float, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        th = k * s
        p = np.array([math.sin(th) / k, (1 - math.cos(th)) / k, 0.0])
        t = np.array([math.cos(th), math.sin(th), 0.0])
        return p, t, k * np.array([-math.sin(th), math.cos(th), 0.0])

    a, ta, ka = at(k0, -h)
    b, tb, kb = at(k1, h)
    al = 2 * h
    return np.array(
        [
            a,
            a + al / 5 * ta,
            a + 2 * al / 5 * ta + al**2 / 20 * ka,
            b - 2 * al / 5 * tb + al**2 / 20 * kb,
            b - al / 5 * tb,
            b,
        ]
    )


def test_points_and_derivatives_are_the_bezier_curve():
    ctrl = _s_bend(1.2)
    c = QuinticCurve(ctrl)
    t = np.linspace(0.0, 1.0, 11)
    bern = np.array([[math.comb(5, i) * x**i * (1 - x) ** (5 - i) for i in range(6)] for x in t])
    np.testing.assert_allclose(c.points(t), bern @ ctrl, atol=1e-13)
    np.testing.assert_array_equal(c.points(np.array([0.0, 1.0])), ctrl[[0, 5]])
    h = 1e-6  # the derivatives against central differences
    d1 = (c.points(t[1:-1] + h) - c.points(t[1:-1] - h)) / (2 * h)
    np.testing.assert_allclose(c.derivatives(t[1:-1], 1)[1], d1, atol=1e-7)


def test_ends_match_the_circles_tangent_and_curvature():
    c = QuinticCurve(_s_bend(1.0))
    t0, k0, t1, k1 = c.end_frames
    th = -0.2 * 1.0  # the first circle, 1 mm before the junction
    np.testing.assert_allclose(t0, [math.cos(th), math.sin(th), 0.0], atol=1e-14)
    np.testing.assert_allclose(k0, 0.2 * np.array([-math.sin(th), math.cos(th), 0.0]), atol=1e-13)
    th = -0.2 * 1.0  # the second circle (curvature -0.2), 1 mm after it
    np.testing.assert_allclose(t1, [math.cos(th), math.sin(th), 0.0], atol=1e-14)
    np.testing.assert_allclose(k1, -0.2 * np.array([-math.sin(th), math.cos(th), 0.0]), atol=1e-13)


def test_arc_length_and_its_inverse():
    c = QuinticCurve(_s_bend(1.5))
    t = np.linspace(0.0, 1.0, 200_001)
    speed = c.speed(t)
    fine = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    assert c.length_mm == pytest.approx(fine[-1], rel=1e-10)
    probe = np.linspace(0.0, 1.0, 37)
    np.testing.assert_allclose(c.s_of_t(probe), np.interp(probe, t, fine), rtol=0, atol=1e-9)
    s = np.linspace(0.0, c.length_mm, 41)
    np.testing.assert_allclose(c.s_of_t(c.t_of_s(s)), s, rtol=0, atol=1e-12 * c.length_mm)


@pytest.mark.parametrize("h", [0.05, 0.5, 1.5, 3.0])
def test_the_bounds_hold_the_curvature_and_its_rate_everywhere(h):
    c = QuinticCurve(_s_bend(h, 0.4, -0.05))
    t = np.linspace(0.0, 1.0, 20_001)[None]
    _, d1, d2, d3 = derivatives(c.coef[None], t, 3)
    _, p2, p3 = arc_length_derivatives(d1[0], d2[0], d3[0])
    k, dk = c.bounds
    assert np.linalg.norm(p2, axis=1).max() <= k
    assert np.linalg.norm(p3, axis=1).max() <= dk
    assert np.linalg.norm(d1[0], axis=1).max() <= c.speed_max


def test_nearest_points_are_nearest():
    c = QuinticCurve(_s_bend(1.2))
    rng = np.random.default_rng(3)
    on = c.points(rng.uniform(0.0, 1.0, 50))
    normal = np.cross(c.derivatives(c.nearest(on), 1)[1], [0.0, 0.0, 1.0])
    q = on + 0.003 * normal / np.linalg.norm(normal, axis=1)[:, None]
    near = c.nearest_points(q)
    dense = c.points(np.linspace(0.0, 1.0, 100_001))
    brute = np.sqrt(((q[:, None, :] - dense[None, ::10, :]) ** 2).sum(axis=2)).min(axis=1)
    got = np.linalg.norm(near - q, axis=1)
    assert np.all(got <= brute + 1e-12)
    assert np.allclose(got, 0.003, atol=1e-9)


def test_a_curve_alone_has_the_numbers_of_a_batch():
    ctrl = np.stack([_s_bend(h) for h in (0.2, 0.9, 1.7)])
    batch = QuinticCurve.batch(ctrl)
    for c, points in zip(batch, ctrl, strict=True):
        one = QuinticCurve(points)
        assert one.length_mm == c.length_mm and one.bounds == c.bounds
        t = np.linspace(0.0, 1.0, 9)
        np.testing.assert_array_equal(one.points(t), c.points(t))
        np.testing.assert_array_equal(
            one.t_of_s(np.array([0.3, 1.0])), c.t_of_s(np.array([0.3, 1.0]))
        )
    rows = np.repeat(power_coefficients(ctrl), 3, axis=0)
    coef1 = rows[:, 1:, :] * np.arange(1.0, 6.0)[None, :, None]
    cum = np.repeat(np.stack([c.cum for c in batch]), 3, axis=0)
    t = np.tile([0.1, 0.5, 0.9], 3)
    expect = np.concatenate([c.s_of_t(np.array([0.1, 0.5, 0.9])) for c in batch])
    np.testing.assert_array_equal(lengths_at(coef1, cum, t), expect)
    q = np.stack([c.points(np.array([0.25, 0.75])) + 1e-3 for c in batch])
    together = nearest_parameters(power_coefficients(ctrl), q, np.zeros(3), np.ones(3))
    for c, row, got in zip(batch, q, together, strict=True):
        np.testing.assert_array_equal(c.nearest(row), got)


def test_nearest_points_of_many_curves_at_once_are_each_curves_own():
    rng = np.random.default_rng(7)
    ctrl = np.cumsum(rng.normal(size=(40, 6, 3)), axis=1)
    curves = QuinticCurve.batch(ctrl)
    which = rng.integers(0, 40, size=3000)
    q = ctrl[which, 0] + rng.normal(scale=3.0, size=(3000, 3))
    q[:5] = ctrl[which[:5], 0]  # at an end: the end control point exactly
    rows = np.stack([c.row for c in curves])[which]
    got = nearest_points_on(rows, q)
    for j in range(40):
        mine = np.flatnonzero(which == j)
        own = curves[j].points(curves[j].nearest(q[mine], seeds=POINT_SEED_SAMPLES))
        assert np.array_equal(got[mine], own)
    assert np.array_equal(got[:5], ctrl[which[:5], 0])
