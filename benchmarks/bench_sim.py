"""Simulation benchmark: speed against raw MuJoCo, accuracy on the bundled machine, fidelity.

    /work/venv/bin/python benchmarks/bench_sim.py        (or: python benchmarks/bench_sim.py)

Prints, measured in this one run:
1. speed: the servo loop's simulated seconds per wall second over raw ``mj_step(m, d, 100)``
   stepping of the same model at rest for the same number of steps (target >= 0.5), and over
   MuJoCo alone on the loop's own motion (its forces replayed open loop, by mujoco.rollout in C
   and by one mj_step(m, d, substeps) per tick from Python; the faster counts): aim >= 0.95.
   Both loops are timed: the compiled PD ticks (sim/pd_ticks.c, built by ``pip install .`` when
   a C compiler is there) and the pure-Python ticks (GANTRY_PURE_PYTHON=1), same numbers;
2. accuracy: max / RMS contour error of an R 10 mm XY circle block at F3000 and F10000 on the
   bundled machine, with its default feedforward and PD only (FF1/FF2 off; gravity
   compensation stays on, it is a static load) -- target <= 6 um max at F3000 with feedforward;
3. fidelity: without friction and damping (a model variant written to a temp folder), the
   steady radius change of a PD-only circle against R (|G(e^{jwT})| - 1) of the discrete loop
   (ZOH mass, one-sample hold, the servo's own PD law) -- target within 5 %.

Why a compiled path (one run on a loaded 2-core machine, 12,875 ticks, 2 physics steps each):
MuJoCo alone on this motion takes 5.9-6.0 us a tick (rollout; 6.1 from a Python loop that only
writes the held forces). The Python ticks cost 6.9 (ratio 0.86-0.89); the leanest Python tick
that still reads qpos, records it, applies the law and writes ctrl measured 6.3 (0.94) -- the
loop body alone is ~0.33 us of interpreter time a tick, against a 0.3 us budget for 0.95. The C
ticks (the same law, the same operations in the same order, -ffp-contract=off) run at 5.6-6.1 us
a tick, 0.99-1.02 of MuJoCo alone, and give the same qpos and forces bit for bit
(tests/test_pd_ticks.py); without a compiler the install skips them and the Python ticks run.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from gantry_sim.controller.config import MachineConfig, load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.servo import DiscretePD
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML
from gantry_sim.sim import pd_ticks
from gantry_sim.sim.api import run_program
from gantry_sim.sim.machine import load_gantry
from gantry_sim.sim.mujoco_lib import timers_off
from gantry_sim.sim.pd_ticks import PURE_PYTHON_ENV
from gantry_sim.sim.runner import simulate

REPEATS = 9


def circle(radius: float, feed: float, turns: int = 1) -> str:
    p = f" P{turns}" if turns > 1 else ""
    return f"G21 G17 G90 G94\nG1 X{radius:g} F{feed:g}\nG3 I-{radius:g} J0{p}\nG1 X0\nM2\n"


def speed(machine: MachineConfig) -> None:
    import mujoco

    text = "".join(circle(10, 3000, 8).splitlines(keepends=True)[:-1]) + "G1 X100 Y50\nM2\n"
    moves = tuple(interpret(text, "linuxcnc", "bench"))
    traj = plan(moves, machine).sample(machine.servo.period_s)
    gantry = load_gantry(machine)
    steps = traj.t.size * gantry.substeps
    loop, python, raw, rolled, replayed, timed = [], [], [], [], [], []
    for _ in range(REPEATS):  # interleaved, best of each: the machine may be loaded
        sim = simulate(gantry, machine, traj)
        loop.append(sim.wall_s)
        os.environ[PURE_PYTHON_ENV] = "1"
        try:
            pure = simulate(gantry, machine, traj)
        finally:
            del os.environ[PURE_PYTHON_ENV]
        assert np.array_equal(pure.pos, sim.pos) and np.array_equal(pure.force, sim.force)
        python.append(pure.wall_s)
        timed.append(_physics_only(gantry, traj, sim.force))  # the bindings' timers on
        with timers_off():  # as the servo loop steps (sim/mujoco_lib.py)
            rolled.append(_physics_only(gantry, traj, sim.force))
            replayed.append(_replayed(gantry, traj, sim.force))
            d = mujoco.MjData(gantry.model)
            d.ctrl[gantry.actuator_id[2]] = -gantry.plant[2].gravity_load_N
            t0 = time.perf_counter()
            for _ in range(steps // 100):
                mujoco.mj_step(gantry.model, d, 100)
            raw.append((time.perf_counter() - t0) * steps / (steps // 100 * 100))
    sim_s, n = traj.duration_s, traj.t.size
    alone = min(min(rolled), min(replayed))
    print(f"1. speed ({sim_s:.1f} s simulated, {steps} physics steps, best of {REPEATS})")
    kind = "compiled ticks" if pd_ticks.available() else "Python ticks: not built"
    print(
        f"   servo loop      : {min(loop) * 1e6 / n:6.2f} us/tick  {sim_s / min(loop):6.1f}x real "
        f"time  ({kind})"
    )
    print(f"   pure Python     : {min(python) * 1e6 / n:6.2f} us/tick  (the same numbers)")
    print(
        f"   raw mj_step(100): {min(raw) * 1e6 / n:6.2f} us/tick  {sim_s / min(raw):6.1f}x real time  (at rest)"
    )
    print(f"   ratio loop/raw  : {min(raw) / min(loop):.2f}   (target >= 0.5, aim 0.85)")
    print(
        f"   MuJoCo alone    : {alone * 1e6 / n:6.2f} us/tick  (the loop's forces replayed open "
        f"loop on the same motion: rollout {min(rolled) * 1e6 / n:.2f}, "
        f"mj_step(nsub) per tick {min(replayed) * 1e6 / n:.2f}; the faster counts)"
    )
    print(f"   ratio loop/MuJoCo alone: {alone / min(loop):.2f}   (aim >= 0.95)")
    print(
        f"   MuJoCo alone with the bindings' profiler timers on: {min(timed) * 1e6 / n:6.2f} "
        f"us/tick (rollout), {min(timed) / min(rolled):.2f} x the time with them off: every "
        "stepping above runs with them off, as the servo loop does (sim/mujoco_lib.py)"
    )
    print(f"   ratio pure Python/MuJoCo alone: {alone / min(python):.2f}")


def _initial_data(gantry, traj):
    import mujoco

    d = mujoco.MjData(gantry.model)
    d.qpos[:] = gantry.joint_qpos_m(gantry.work_to_joint_mm(traj.pos[0]))
    return d


def _replayed(gantry, traj, force: np.ndarray) -> float:
    """Wall time [s] of MuJoCo alone on the loop's trajectory, stepped from Python: per tick the
    held force written to ctrl and one mj_step(m, d, substeps) -- the loop without the law."""
    import mujoco

    m, d = gantry.model, _initial_data(gantry, traj)
    ctrl, step, nsub = d.ctrl, mujoco.mj_step, gantry.substeps
    ux, uy, uz = gantry.actuator_id
    rows = (force / np.asarray(gantry.gear)).tolist()
    t0 = time.perf_counter()
    for fx, fy, fz in rows:
        ctrl[ux] = fx
        ctrl[uy] = fy
        ctrl[uz] = fz
        step(m, d, nsub)
    return time.perf_counter() - t0


def _physics_only(gantry, traj, force: np.ndarray) -> float:
    """Wall time [s] of MuJoCo alone on the loop's trajectory: its held forces, one row per
    physics step, stepped open loop from the same initial state by mujoco.rollout."""
    import mujoco
    from mujoco import rollout

    m = gantry.model
    d = _initial_data(gantry, traj)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    ctrl = np.zeros((force.shape[0], m.nu))
    ctrl[:, list(gantry.actuator_id)] = force / np.asarray(gantry.gear)
    ctrl = np.repeat(ctrl, gantry.substeps, axis=0)[None]
    t0 = time.perf_counter()
    rollout.rollout(m, d, state[None], ctrl, nstep=ctrl.shape[1])
    return time.perf_counter() - t0


def accuracy(machine: MachineConfig) -> None:
    pd_only = machine.with_changes("servo", ff_velocity=[0.0] * 3, ff_acceleration=[0.0] * 3)
    print("2. accuracy: R 10 mm XY circle block, contour error [um]")
    print("   feed      feedforward (default)    PD only")
    for feed in (3000, 10000):
        row = []
        for m in (machine, pd_only):
            blk = run_program(circle(10, feed), machine=m).run_report.block(3)
            assert blk is not None, "the circle block (line 3) has no contour error"
            row.append(f"max {blk.max_error_um:6.2f} rms {blk.rms_error_um:6.2f}")
        print(f"   F{feed:<6}  {row[0]}   {row[1]}")
    print("   target: <= 6 um max at F3000 with the default feedforward")


def fidelity(tmp: Path) -> None:
    text = re.sub(r'(damping|frictionloss)="[^"]*"', r'\1="0"', GANTRY_XML.read_text())
    (tmp / "lossless.xml").write_text(text)
    (tmp / "m.toml").write_text(
        "[limits]\nmax_acceleration_mm_per_s2 = [20000.0, 20000.0, 20000.0]\n"
        "max_jerk_mm_per_s3 = [2e6, 2e6, 2e6]\n"
        "[servo]\nff_velocity = [0.0, 0.0, 0.0]\nff_acceleration = [0.0, 0.0, 0.0]\n"
        '[sim]\nmodel = "lossless.xml"\n'
    )
    machine = load_machine_config(DEFAULT_MACHINE, tmp / "m.toml")
    servo = DiscretePD(machine.servo, load_gantry(machine).plant)
    print("3. fidelity: PD-only circle, no friction/damping: radius change [um]")
    print("   R [mm]  F      w [rad/s]  measured  |G|-1 predicted  ratio")
    for radius, feed in ((10, 6000), (10, 12000), (5, 9000)):
        tr = run_program(circle(radius, feed, 2), machine=machine).trace
        v = np.linalg.norm(np.gradient(tr.ref, tr.t, axis=0), axis=1)
        on = tr.line == 3
        steady = on & (v > 0.999 * v[on].max())
        steady &= tr.t > tr.t[steady][0] + 0.05
        r_ref = np.hypot(tr.ref[steady, 0], tr.ref[steady, 1]).mean()
        r_pos = np.hypot(tr.pos[steady, 0], tr.pos[steady, 1]).mean()
        w = float(v[steady].mean()) / radius
        pred = (abs(servo.closed_loop_gain(w, 0)) - 1) * r_ref * 1000
        meas = (r_pos - r_ref) * 1000
        print(f"   {radius:<6}  {feed:<6} {w:8.2f}  {meas:8.3f}  {pred:15.3f}  {meas / pred:.4f}")
    print("   target: ratio within 0.95..1.05")


def main() -> int:
    machine = load_machine_config(DEFAULT_MACHINE)
    speed(machine)
    accuracy(machine)
    with tempfile.TemporaryDirectory() as tmp:
        fidelity(Path(tmp))
    return 0


if __name__ == "__main__":
    sys.exit(main())
