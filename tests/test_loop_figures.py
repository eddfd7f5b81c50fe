"""Loop figures of controller.loop_figures against the servo law itself, tick by tick."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.loop_figures import (
    AxisLoop,
    bandwidth_hz,
    design_mode,
    gain_margin,
    kv_per_s,
    sampled_mode,
)
from gantry_sim.controller.servo import AxisPlant, DiscretePD

BIG = 1e12  # force limits far away: the linear loop


def _law_matrix(machine, loop: AxisLoop, scale: float) -> np.ndarray:
    """The one-tick map of (mass + ZOH + DiscretePD.step at r = 0) on axis X, built column by
    column from the law itself: state (x, v, x_prev, I_prev) [mm, mm/s, mm, mm s]."""
    servo_cfg = machine.with_changes(
        "servo",
        kp_N_per_mm=[loop.kp_N_per_mm * scale, 1.0, 1.0],
        kd_N_s_per_mm=[loop.kd_N_s_per_mm * scale, 0.0, 0.0],
        ki_N_per_mm_s=[loop.ki_N_per_mm_s * scale, 0.0, 0.0],
        ff_velocity=[0.0] * 3,
        ff_acceleration=[0.0] * 3,
        ff_gravity=0.0,
        period_s=loop.period_s,
    ).servo
    plant = [AxisPlant(loop.mass_kg, 0.0, 0.0, 0.0, -BIG, BIG)] * 3
    servo = DiscretePD(servo_cfg, plant)
    t, m = loop.period_s, loop.mass_kg * 1e-3
    cols = []
    for s in np.eye(4):
        x, v, xp, ip = s
        f, integ, _ = servo.step([0.0] * 3, [0.0] * 3, [x, 0, 0], [xp, 0, 0], (ip, 0, 0), (0, 0, 0))
        cols.append([x + v * t + 0.5 * f[0] / m * t * t, v + f[0] / m * t, x, integ[0]])
    a = np.array(cols).T
    return a if loop.ki_N_per_mm_s else a[:3, :3]


def _radius(machine, loop, scale):
    return float(np.abs(np.linalg.eigvals(_law_matrix(machine, loop, scale))).max())


@pytest.mark.parametrize("ki", [0.0, 20000.0])
def test_gain_margin_is_where_the_sampled_law_goes_unstable(machine, ki):
    loop = AxisLoop(17.0, 1074.0, 5.98, ki, 0.001)
    margin = gain_margin(loop)
    assert 2.0 < margin < 10.0
    assert _radius(machine, loop, 1.0) == pytest.approx(loop.pole_radius(), abs=1e-9)
    assert _radius(machine, loop, margin * (1 - 1e-6)) < 1.0
    assert _radius(machine, loop, margin * (1 + 1e-4)) > 1.0


def test_bundled_gains_have_the_margin_the_machine_file_states(machine):
    """models/gantry.toml: poles |z| <= 0.76 and gains that could grow 4.8x."""
    s = machine.servo
    for mass, kp, kd in zip((17.0, 60.0, 9.0), s.kp_N_per_mm, s.kd_N_s_per_mm, strict=True):
        loop = AxisLoop(mass, kp, kd, 0.0, s.period_s)
        assert loop.pole_radius() == pytest.approx(0.76, abs=0.005)
        assert gain_margin(loop) == pytest.approx(4.75, abs=0.01)
        f, zeta = design_mode(loop)
        assert f == pytest.approx(40.0, rel=1e-3) and zeta == pytest.approx(0.7, rel=2e-3)
        assert kv_per_s(kp, kd) == pytest.approx(251.327 / 1.4, rel=2e-3)


def test_an_unstable_loop_reports_a_margin_below_one(machine):
    loop = AxisLoop(17.0, 1074.0 * 6, 5.98 * 6, 0.0, 0.001)
    margin = gain_margin(loop)
    assert margin == pytest.approx(gain_margin(AxisLoop(17.0, 1074.0, 5.98, 0.0, 0.001)) / 6)
    assert _radius(machine, loop, 1.0) > 1.0
    assert bandwidth_hz(loop) is None


def test_bandwidth_is_the_minus_3_db_point_of_the_sampled_loop():
    loop = AxisLoop(17.0, 1074.0, 5.98, 0.0, 0.001)
    f = bandwidth_hz(loop)
    assert f is not None
    w = 2 * math.pi * f
    assert abs(loop.closed_loop_gain(w)) == pytest.approx(1 / math.sqrt(2), abs=1e-6)
    assert all(
        abs(loop.closed_loop_gain(v)) > 1 / math.sqrt(2) for v in np.linspace(1, w * 0.999, 50)
    )
    fs, zs = sampled_mode(loop)
    assert 0.0 < zs < 1.0 and fs > 0.0
