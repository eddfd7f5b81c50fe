"""The servo's integral term (LinuxCNC-style PID with anti-windup): the law alone and in the loop."""

from __future__ import annotations

import numpy as np
import pytest

from gantry_sim.controller.servo import AxisPlant, DiscretePD
from gantry_sim.controller.transmission import motor_side_mm
from gantry_sim.sim.api import run_program
from gantry_sim.sim.machine import load_gantry

PLANT = (
    AxisPlant(17.0, 0.04, 4.0, 0.0, -400.0, 400.0),
    AxisPlant(60.0, 0.1, 10.0, 0.0, -1000.0, 1000.0),
    AxisPlant(9.0, 0.03, 2.0, -49.05, -300.0, 300.0),
)
KI = [20000.0, 60000.0, 10000.0]  # N/(mm s): integral corner ki/kp ~ 16-19 1/s, well below wn


def _pid(machine, **servo) -> DiscretePD:
    return DiscretePD(machine.with_changes("servo", **servo).servo, PLANT)


def test_without_ki_the_step_law_is_the_pd_law(machine):
    servo = DiscretePD(machine.servo, PLANT)
    assert not servo.has_integral
    rng = np.random.default_rng(3)
    integral, sat = (0.0, 0.0, 0.0), (0, 0, 0)
    for _ in range(50):
        b, r, x, xp = (rng.normal(0.0, s, 3).tolist() for s in (300.0, 1.0, 1.0, 1.0))
        f, integral, sat = servo.step(b, r, x, xp, integral, sat)
        assert f == servo.force(b, x, xp)


def test_integral_accumulates_the_error_and_adds_ki_times_it(machine):
    servo = _pid(machine, ki_N_per_mm_s=KI)
    t = servo.period_s
    zero = [0.0, 0.0, 0.0]
    integral, sat = (0.0, 0.0, 0.0), (0, 0, 0)
    r = [0.001, -0.002, 0.0]
    for k in range(1, 4):
        f, integral, sat = servo.step(servo_b(servo, r), r, zero, zero, integral, sat)
        assert integral[0] == pytest.approx(k * 0.001 * t)
        assert integral[1] == pytest.approx(-k * 0.002 * t)
        pd = servo.force(servo_b(servo, r), zero, zero)
        assert f[0] == pytest.approx(pd[0] + KI[0] * k * 0.001 * t)
        assert f[1] == pytest.approx(pd[1] - KI[1] * k * 0.002 * t)
    assert sat == (0, 0, 0)


def servo_b(servo: DiscretePD, r) -> list[float]:
    """b_k of a standing reference r (no feedforward motion terms) [N]."""
    rows = np.array([r, r], dtype=float)
    z = np.zeros((2, 3))
    return servo.drive_terms(rows, z, z)[1].tolist()


def test_no_windup_while_the_drive_saturates_and_the_clamp_holds(machine):
    """A 10 mm error saturates X: the integral stops growing (conditional integration, as in
    LinuxCNC's pid) and never exceeds max_error_integral_mm_s; it integrates again as soon as
    the error turns against the saturated side."""
    servo = _pid(machine, ki_N_per_mm_s=KI, max_error_integral_mm_s=[1e-4, 1e-4, 1e-4])
    zero = [0.0, 0.0, 0.0]
    r = [10.0, 0.0, 0.0]
    b = servo_b(servo, r)
    f, integral, sat = servo.step(b, r, zero, zero, (0.0, 0.0, 0.0), (0, 0, 0))
    assert f[0] == 400.0 and sat[0] == 1
    assert integral[0] == pytest.approx(1e-4)  # one tick: 10 mm * 1 ms = 1e-2, clamped
    _, integral2, sat2 = servo.step(b, r, zero, zero, (0.5e-4, 0.0, 0.0), sat)
    assert integral2[0] == 0.5e-4  # saturated towards +, error +: no integration
    back = [-0.01, 0.0, 0.0]  # the error now points away from the saturated side
    _, integral3, _ = servo.step(servo_b(servo, back), back, zero, zero, integral2, sat2)
    assert integral3[0] == pytest.approx(0.5e-4 - 0.01 * servo.period_s)
    _, integral4, _ = servo.step(servo_b(servo, back), [-1.0, 0, 0], zero, zero, integral3, sat2)
    assert integral4[0] == -1e-4  # clamped on the other side too


def test_integral_removes_the_friction_lag_of_a_constant_feed(machine):
    """PD alone leaves X lagging by frictionloss / kp (4 N / 1074 N/mm = 3.7 um) on a steady
    feed without friction feedforward; the integral term brings that lag to near zero."""
    prog = "G21 G90 G94\nG1 X30 F600\nM2\n"
    lag = {}
    for ki in (0.0, KI[0]):
        m = machine.with_changes("servo", ki_N_per_mm_s=[ki, KI[1], KI[2]])
        tr = run_program(prog, machine=m).trace
        steady = (tr.t > 1.5) & (tr.t < 2.5)  # 10 mm/s cruise from ~0.01 s to 3 s
        lag[ki] = float(np.mean(tr.ref[steady, 0] - tr.pos[steady, 0])) * 1000
    assert lag[0.0] == pytest.approx(4.0 / machine.servo.kp_N_per_mm[0] * 1000, rel=0.1)
    assert abs(lag[KI[0]]) < 0.05 * lag[0.0]


def test_runner_with_integral_and_backlash_executes_the_law(machine):
    """The stateful loop in sim/runner.py applies DiscretePD.step to the motor-side encoders
    (controller.transmission) tick by tick: replaying the law on the trace gives its forces."""
    m = machine.with_changes("servo", ki_N_per_mm_s=KI).with_changes(
        "sim", backlash_mm=[0.01, 0.02, 0.005]
    )
    prog = "G21 G17 G90 G94\nG1 X2 Y1 F3000\nG3 X0 Y3 I-2 J0\nG1 X0 Y0 Z-1\nM2\n"
    res = run_program(prog, machine=m)
    g = load_gantry(m)
    servo = DiscretePD(m.servo, g.plant)
    from gantry_sim.controller.planner.plan import plan

    traj = plan(res.moves, m).sample(m.servo.period_s)
    ref = g.work_to_joint_mm(traj.pos)
    b = servo.drive_terms(ref, traj.vel, traj.acc)
    axis = g.work_to_joint_mm(res.trace.pos)
    enc = axis[0].tolist()
    integral, sat = (0.0, 0.0, 0.0), (0, 0, 0)
    forces = np.empty_like(res.trace.force_N)
    for k in range(axis.shape[0]):
        prev = enc
        enc = [motor_side_mm(axis[k, i], prev[i], m.sim.backlash_mm[i]) for i in range(3)]
        f, integral, sat = servo.step(b[k], ref[k], enc, prev, integral, sat)
        forces[k] = f
    assert np.abs(forces - res.trace.force_N).max() < 1e-6
    assert np.abs(integral).max() > 0.0  # the integral was live
