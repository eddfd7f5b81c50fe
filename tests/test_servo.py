"""The discrete PD servo alone: pure numbers, no MuJoCo."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.servo import AxisPlant, DiscretePD

PLANT = (
    AxisPlant(17.0, 0.04, 4.0, 0.0, -400.0, 400.0),
    AxisPlant(60.0, 0.1, 10.0, 0.0, -1000.0, 1000.0),
    AxisPlant(9.0, 0.03, 2.0, -49.05, -300.0, 300.0),
)


def _pd_only(machine) -> DiscretePD:
    m = machine.with_changes(
        "servo",
        ff_velocity=[0.0] * 3,
        ff_acceleration=[0.0] * 3,
        ff_friction=[0.0] * 3,
        ff_gravity=0.0,
    )
    return DiscretePD(m.servo, PLANT)


def _one_tick(servo: DiscretePD, ref, vel, acc, x, x_prev=None, ref_prev=None):
    ref_rows = np.array([ref_prev if ref_prev is not None else ref, ref], dtype=float)
    b = servo.drive_terms(ref_rows, np.array([vel, vel], float), np.array([acc, acc], float))[1]
    return servo.force(b, x, x if x_prev is None else x_prev)


def test_proportional_action_pushes_towards_the_reference(machine):
    servo = _pd_only(machine)
    kp = machine.servo.kp_N_per_mm
    f = _one_tick(servo, [0.01, -0.01, 0.0], [0, 0, 0], [0, 0, 0], [0.0, 0.0, 0.0])
    assert f[0] == pytest.approx(kp[0] * 0.01)
    assert f[1] == pytest.approx(-kp[1] * 0.01)
    assert f[2] == 0.0


def test_derivative_acts_on_the_change_of_error_and_does_not_kick_at_start(machine):
    servo = _pd_only(machine)
    kp, kd, t = machine.servo.kp_N_per_mm[0], machine.servo.kd_N_s_per_mm[0], machine.servo.period_s
    # error went from 0 to 0.002 mm in one period: D adds kd * 0.002 / T
    f = _one_tick(
        servo, [0.002, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], x_prev=[0, 0, 0], ref_prev=[0, 0, 0]
    )
    assert f[0] == pytest.approx(kp * 0.002 + kd * 0.002 / t)
    # the same error at the first tick (previous error taken equal): no derivative kick
    f0 = _one_tick(servo, [0.002, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0])
    assert f0[0] == pytest.approx(kp * 0.002)


def test_feedforward_terms_use_the_plant_model(machine):
    servo = DiscretePD(machine.with_changes("servo", ff_friction=[1.0, 1.0, 1.0]).servo, PLANT)
    ff = servo.feedforward_N(np.array([[100.0, -50.0, 0.0]]), np.array([[2000.0, 0.0, -1000.0]]))[0]
    # FF1 c v + FF2 m a [kg * mm/s^2 * 1e-3 = N] + friction sign(v) - gravity load
    assert ff[0] == pytest.approx(0.04 * 100 + 17.0 * 2.0 + 4.0)
    assert ff[1] == pytest.approx(0.1 * -50 - 10.0)
    assert ff[2] == pytest.approx(9.0 * -1.0 + 49.05)  # no friction at v = 0; holds the ram up


def test_force_saturates_at_the_drive_limits(machine):
    servo = _pd_only(machine)
    f = _one_tick(servo, [10.0, -10.0, 10.0], [0, 0, 0], [0, 0, 0], [0, 0, 0])
    assert f == (400.0, -1000.0, 300.0)


def _simulate_zoh(servo: DiscretePD, ref, vel, acc, axis=0):
    """Exact zero-order-hold simulation of a pure mass on one axis (numbers only) [mm]."""
    t, m = servo.period_s, PLANT[axis].mass_kg * 1e-3
    x, v, x_prev = ref[0, axis], vel[0, axis], ref[0, axis]
    b = servo.drive_terms(ref, vel, acc)
    out = np.empty(len(ref))
    for k in range(len(ref)):
        out[k] = x
        xs = [0.0, 0.0, 0.0]
        xs[axis] = x
        xp = [0.0, 0.0, 0.0]
        xp[axis] = x_prev
        f = servo.force(b[k], xs, xp)[axis]
        x_prev = x
        x, v = x + v * t + 0.5 * f / m * t * t, v + f / m * t
    return out


def _sine(period_s, n, amp_mm=5.0, omega=20.0):
    t = np.arange(n) * period_s
    ref = np.zeros((n, 3))
    vel, acc = np.zeros((n, 3)), np.zeros((n, 3))
    ref[:, 0] = amp_mm * np.sin(omega * t)
    vel[:, 0] = amp_mm * omega * np.cos(omega * t)
    acc[:, 0] = -amp_mm * omega**2 * np.sin(omega * t)
    return t, ref, vel, acc


def test_closed_loop_matches_its_discrete_transfer_function(machine):
    """A PD-only loop on a ZOH mass tracks a sine at the amplitude |G(e^{jwT})| predicts."""
    servo = _pd_only(machine)
    omega = 60.0
    t, ref, vel, acc = _sine(servo.period_s, 3000, omega=omega)
    x = _simulate_zoh(servo, ref, vel, acc)
    late = t > 1.0  # the loop's transient (~20 ms) is long gone
    fit = np.linalg.lstsq(
        np.column_stack([np.sin(omega * t[late]), np.cos(omega * t[late])]), x[late], rcond=None
    )[0]
    gain = abs(servo.closed_loop_gain(omega, 0))
    assert np.hypot(*fit) / 5.0 == pytest.approx(gain, rel=1e-6)
    assert gain > 1.0 + 1e-3  # a PD loop on a mass peaks: a circle grows (no Kv shrink here)


def test_acceleration_feedforward_removes_most_of_the_tracking_error(machine):
    """On a pure mass (no damping, so FF1 off) FF2 = m a leaves only the hold's small lag."""
    t, ref, vel, acc = _sine(machine.servo.period_s, 1500)
    pd = _simulate_zoh(_pd_only(machine), ref, vel, acc)
    ff2 = machine.with_changes("servo", ff_velocity=[0.0] * 3, ff_gravity=0.0).servo
    ff = _simulate_zoh(DiscretePD(ff2, PLANT), ref, vel, acc)
    late = t > 0.5
    err_pd = np.abs(pd - ref[:, 0])[late].max()
    err_ff = np.abs(ff - ref[:, 0])[late].max()
    assert err_ff < 0.05 * err_pd


def test_vectorised_forces_equal_the_per_tick_law_exactly(machine):
    """DiscretePD.forces (the runner's trace of held forces) is DiscretePD.force, row by row,
    to the last bit -- including rows that saturate."""
    servo = DiscretePD(machine.servo, PLANT)
    rng = np.random.default_rng(1)
    b = rng.normal(0.0, 500.0, (200, 3))
    x = rng.normal(0.0, 1.0, (200, 3))
    x_prev = x + rng.normal(0.0, 0.01, (200, 3))
    got = servo.forces(b, x, x_prev)
    expect = np.array([servo.force(b[k], x[k], x_prev[k]) for k in range(200)])
    assert np.array_equal(got, expect)
    assert (np.abs(got) == [400.0, 1000.0, 300.0]).any()  # the clamp was exercised
