"""The compiled PD ticks (sim/pd_ticks.c) give the Python ticks' numbers bit for bit, and their
forces are the law's (controller.servo.DiscretePD.force); MuJoCo's fatal errors inside them
become mujoco.FatalError as in the bindings' mj_step."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.servo import DiscretePD
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML
from gantry_sim.sim import pd_ticks
from gantry_sim.sim.machine import MM_PER_M, load_gantry
from gantry_sim.sim.servo_loop import ServoLoop
from tests.machine_variants import gantry_variant

pytestmark = pytest.mark.skipif(
    not pd_ticks.available(), reason="sim/pd_ticks.c was not built (no C compiler at install)"
)

# a circle at F6000 and a fast diagonal with Z: the drives saturate on the weak-force variant
PROGRAM = "G21 G17 G90 G94\nG1 X5 F6000\nG3 I-5 J0\nG1 X40 Y-30 Z-20 F20000\nG1 X0 Y0 Z0\nM2\n"


def _run(machine, pure_python, cuts=None):
    traj = plan(tuple(interpret(PROGRAM, "linuxcnc", "t")), machine).sample(machine.servo.period_s)
    g = load_gantry(machine)
    loop = ServoLoop(g, machine, g.work_to_joint_mm(traj.pos[0]), pure_python=pure_python)
    assert (loop.compiled is None) == pure_python
    ref = g.work_to_joint_mm(traj.pos)
    n = traj.t.size
    qs, fs = [], []
    for lo, hi in itertools.pairwise(cuts or [0, 1, 333, 334, n]):
        q, f = loop.run(ref[lo:hi], traj.vel[lo:hi], traj.acc[lo:hi])
        qs.append(q)
        fs.append(f)
    b = loop.servo.drive_terms(ref, traj.vel, traj.acc)
    return np.concatenate(qs), np.concatenate(fs), b, g


@pytest.fixture(params=["bundled", "weak drives, gear 2"])
def variant(request, machine, tmp_path):
    """(machine, whether its drives saturate on PROGRAM)."""
    if request.param == "bundled":
        return machine, False
    # forces clamp often (ctrlrange * gear = +-150 N) and ctrl = force / gear is not the force
    motors = {a: {"gear": "2", "ctrlrange": "-75 75", "forcerange": "-150 150"} for a in "xyz"}
    return gantry_variant(tmp_path, motors=motors), True


def test_compiled_ticks_give_the_python_ticks_numbers_bit_for_bit(variant):
    variant, _ = variant
    q_py, f_py, _, _ = _run(variant, pure_python=True)
    q_c, f_c, _, _ = _run(variant, pure_python=False, cuts=[0, 5000, 5001, q_py.shape[0]])
    assert np.array_equal(q_c, q_py)
    assert np.array_equal(f_c, f_py)


def test_compiled_ticks_hold_the_laws_forces(variant):
    """Each tick's force equals DiscretePD.force (the one law) of that tick's encoders."""
    variant, saturates = variant
    qpos, force, b, g = _run(variant, pure_python=False)
    servo = DiscretePD(variant.servo, g.plant)
    joint = qpos[:, list(g.qpos_adr)] * MM_PER_M
    prev = np.vstack([joint[:1], joint[:-1]])
    for k in range(0, qpos.shape[0], 7):
        assert force[k].tolist() == list(servo.force(b[k], joint[k], prev[k]))
    assert np.array_equal(force, servo.forces(b, joint, prev))
    clamped = (force == np.asarray(servo.hi)) | (force == np.asarray(servo.lo))
    assert clamped.any() == saturates


def test_environment_selects_the_python_ticks(machine, monkeypatch):
    g = load_gantry(machine)
    monkeypatch.setenv(pd_ticks.PURE_PYTHON_ENV, "1")
    assert ServoLoop(g, machine, np.zeros(3)).compiled is None
    monkeypatch.setenv(pd_ticks.PURE_PYTHON_ENV, "0")
    assert ServoLoop(g, machine, np.zeros(3)).compiled is not None


def test_without_the_extension_the_python_ticks_run(machine, monkeypatch):
    """An install without a C compiler has no gantry_sim.sim._pd_ticks: the loop falls back."""

    def missing(name, *args):
        raise ImportError(f"No module named {name!r}")

    monkeypatch.setattr(pd_ticks.importlib, "import_module", missing)
    pd_ticks._libraries.cache_clear()
    try:
        assert not pd_ticks.available()
        q_py, f_py, _, _ = _run(machine, pure_python=True)
        g = load_gantry(machine)
        assert ServoLoop(g, machine, np.zeros(3), pure_python=False).compiled is None
    finally:
        monkeypatch.undo()
        pd_ticks._libraries.cache_clear()
    assert pd_ticks.available()
    q_c, f_c, _, _ = _run(machine, pure_python=False)
    assert np.array_equal(q_c, q_py) and np.array_equal(f_c, f_py)


def test_a_fatal_mujoco_error_in_the_compiled_ticks_raises_fatal_error(tmp_path):
    """An arena too small for the constraint rows of an axis at its limit: MuJoCo's
    mju_error inside the C loop becomes mujoco.FatalError (not an exit of the process)."""
    import mujoco

    xml = GANTRY_XML.read_text().replace("<worldbody>", '<size memory="1550"/>\n<worldbody>', 1)
    (tmp_path / "small.xml").write_text(xml)
    (tmp_path / "m.toml").write_text('[sim]\nmodel = "small.xml"\n')
    for asset in GANTRY_XML.parent.glob("*.xml"):
        if asset != GANTRY_XML and not (tmp_path / asset.name).exists():
            (tmp_path / asset.name).write_text(asset.read_text())
    machine = load_machine_config(DEFAULT_MACHINE, tmp_path / "m.toml")
    g = load_gantry(machine)
    loop = ServoLoop(g, machine, np.zeros(3), pure_python=False)
    far = np.tile(g.joint_range_mm()[:, 1] + 100.0, (4000, 1))  # beyond every joint's end
    zeros = np.zeros_like(far)
    with pytest.raises(mujoco.FatalError, match="stack overflow"):
        loop.run(far, zeros, zeros)
    # the handler is left in place: the bindings' own calls still raise as before
    d = mujoco.MjData(g.model)
    d.ctrl[:] = 1e3
    with pytest.raises(mujoco.FatalError, match="stack overflow"):
        mujoco.mj_step(g.model, d, 4000)
