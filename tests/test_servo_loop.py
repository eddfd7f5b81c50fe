"""The servo loop: held forces are the law's, sub-steps batched bit for bit, ranges carry state."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.servo import DiscretePD
from gantry_sim.sim.machine import MM_PER_M, load_gantry
from gantry_sim.sim.runner import simulate, simulate_pieces
from gantry_sim.sim.servo_loop import ServoLoop

# ~1 s: lead-in, a full R5 circle at F2000, lead-out with a Z move
PROGRAM = "G21 G17 G90 G94\nG1 X5 F2000\nG3 I-5 J0\nG1 X0 Z-1\nM2\n"


def _traj(machine):
    return plan(tuple(interpret(PROGRAM, "linuxcnc", "t")), machine).sample(machine.servo.period_s)


def _stateful(machine):
    return machine.with_changes("servo", ki_N_per_mm_s=[40.0, 40.0, 60.0]).with_changes(
        "sim", backlash_mm=[0.01, 0.02, 0.005]
    )


def _run_ranges(machine, traj, cuts):
    g = load_gantry(machine)
    loop = ServoLoop(g, machine, g.work_to_joint_mm(traj.pos[0]))
    ref = g.work_to_joint_mm(traj.pos)
    qs, fs = [], []
    for lo, hi in itertools.pairwise(cuts):
        q, f = loop.run(ref[lo:hi], traj.vel[lo:hi], traj.acc[lo:hi])
        qs.append(q)
        fs.append(f)
    return np.concatenate(qs), np.concatenate(fs), loop


def test_loop_holds_the_laws_forces_bit_for_bit(machine):
    """Every tick's recorded force is DiscretePD.force of that tick's encoders, exactly, and
    replaying the recorded forces open loop reproduces the loop's motion exactly: the forces
    the loop applied are the law's."""
    import mujoco

    traj = _traj(machine)
    n = traj.t.size
    qpos, force, loop = _run_ranges(machine, traj, [0, n])
    g = loop.gantry
    servo = DiscretePD(machine.servo, g.plant)
    joint = qpos[:, list(g.qpos_adr)] * MM_PER_M
    b = servo.drive_terms(g.work_to_joint_mm(traj.pos), traj.vel, traj.acc)
    for k in range(n):
        assert force[k].tolist() == list(servo.force(b[k], joint[k], joint[max(k - 1, 0)]))
    assert np.abs(force).max() > 1.0  # the machine was driven
    d = mujoco.MjData(g.model)
    d.qpos[:] = qpos[0]
    gear = np.asarray(g.gear)
    for k in range(n):
        assert np.array_equal(d.qpos, qpos[k])
        d.ctrl[list(g.actuator_id)] = force[k] / gear
        mujoco.mj_step(g.model, d, g.substeps)


def test_batched_substeps_are_single_steps_bit_for_bit(machine):
    """mj_step(m, d, nstep) equals nstep calls of mj_step with the force held."""
    import mujoco

    g = load_gantry(machine)
    a, b = mujoco.MjData(g.model), mujoco.MjData(g.model)
    rng = np.random.default_rng(3)
    for _ in range(300):
        ctrl = rng.uniform(-200, 200, g.model.nu)
        a.ctrl[:] = ctrl
        b.ctrl[:] = ctrl
        mujoco.mj_step(g.model, a, 4)
        for _ in range(4):
            mujoco.mj_step(g.model, b)
        assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.qvel, b.qvel)
    assert np.abs(a.qvel).max() > 0.0


@pytest.mark.parametrize("stateful", [False, True])
def test_ranges_of_any_size_give_the_one_range_run_bit_for_bit(machine, stateful):
    """The loop's state (MjData, x_{k-1}, r_{k-1}, integral, saturation, motor-side encoders)
    carries across ranges exactly."""
    m = _stateful(machine) if stateful else machine
    traj = _traj(m)
    n = traj.t.size
    q1, f1, _ = _run_ranges(m, traj, [0, n])
    q2, f2, loop = _run_ranges(m, traj, [0, 1, 2, 39, 500, 501, n])
    assert (loop.stateful is not None) == stateful
    assert np.array_equal(q1, q2) and np.array_equal(f1, f2)


def test_pieces_stream_gives_simulate_bit_for_bit(machine):
    """simulate_pieces on uneven pieces of the trajectory yields simulate's trace exactly."""
    m = _stateful(machine)
    traj = _traj(m)
    n = traj.t.size
    whole = simulate(load_gantry(m), m, traj)
    cuts = [0, 7, 300, 301, n]
    pieces = (traj.slice(lo, hi) for lo, hi in itertools.pairwise(cuts))
    out = list(simulate_pieces(load_gantry(m), m, pieces, traj.pos[0]))
    assert [p.shape[0] for p, _ in out] == [7, 293, 1, n - 301]
    assert np.array_equal(np.concatenate([p for p, _ in out]), whole.pos)
    assert np.array_equal(np.concatenate([f for _, f in out]), whole.force)
