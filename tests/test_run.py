"""End to end: the real interpreter, planner and MuJoCo; `gantry run` and its exit statuses."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.servo import DiscretePD
from gantry_sim.sim.api import run_program
from gantry_sim.sim.cli import Terminated, main
from gantry_sim.sim.machine import load_gantry
from tests.machine_variants import AXIS_NAMES, UNLIMITED_FORCE, gantry_variant, write_variant

# ~1 s simulated: a lead-in, a full R5 circle at F3000, a lead-out
CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"
REPORT_KEYS = {
    "program",
    "dialect",
    "cycle_time_s",
    "contour_error_um",
    "parts_um",
    "blocks",
    "limits",
    "sim",
    "timing_s",
}


def machine_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return path


def test_short_circle_end_to_end(machine):
    res = run_program(CIRCLE, file="c.ngc", machine=machine)
    rep = res.report
    assert REPORT_KEYS <= rep.keys()
    assert json.loads(json.dumps(rep)) == rep  # exactly what report.json holds
    assert rep["contour_error_um"].keys() == {"max", "rms", "p95"}
    assert rep["parts_um"].keys() == {
        "chord_max",
        "reference_max",
        "tracking_max",
        "reference_blend_max",
        "reference_planning_max",
    }
    assert [b["line"] for b in rep["blocks"]] == [2, 3, 4]
    assert rep["timing_s"].keys() == {"parse", "plan", "simulate", "analyse", "total"}
    assert rep["sim"]["steps"] == res.trace.t.size * 2
    # the bundled machine keeps a 5 mm circle at F3000 within the 6 um accuracy target
    assert 0.0 < rep["contour_error_um"]["max"] < 6.0
    assert rep["parts_um"]["chord_max"] <= machine.segmentation.chord_tolerance_mm * 1000 + 1e-9
    tr = res.trace
    assert tr.pos.shape == tr.ref.shape == (tr.t.size, 3)
    assert float(tr.err_um[tr.feed].max()) == rep["contour_error_um"]["max"]
    assert np.abs(tr.pos - tr.ref).max() < 0.01  # traced within 10 um of the reference
    # the typed report is what report.json holds, field for field
    typed = res.run_report
    assert typed.to_json() == rep
    assert typed.contour_error_um.max_um == rep["contour_error_um"]["max"]
    assert [b.line for b in typed.blocks] == [2, 3, 4]
    circle = typed.block(3)
    assert circle is not None and circle.kind == "arc"
    assert circle.max_error_um == rep["blocks"][1]["max_error_um"]
    assert typed.block(1) is None  # no feed block on line 1


def test_runner_executes_the_servo_law(machine):
    """The unrolled loop in sim/runner.py applies exactly DiscretePD.force to the encoders."""
    res = run_program(CIRCLE, machine=machine)
    g = load_gantry(machine)
    servo = DiscretePD(machine.servo, g.plant)
    tr = res.trace
    joint = g.work_to_joint_mm(tr.pos)
    from gantry_sim.controller.planner.plan import plan

    traj = plan(res.moves, machine).sample(machine.servo.period_s)
    b = servo.drive_terms(g.work_to_joint_mm(traj.pos), traj.vel, traj.acc)
    for k in (0, 1, 200, 500, tr.t.size - 1):
        expect = servo.force(b[k], joint[k], joint[max(k - 1, 0)])
        assert tr.force_N[k] == pytest.approx(expect, abs=1e-6)


def test_cli_writes_outputs_and_gates(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    out = tmp_path / "out"
    assert main(["run", str(prog), "--out", str(out)]) == 0
    assert "contour error: max" in capsys.readouterr().out
    rep = json.loads((out / "report.json").read_text())
    assert REPORT_KEYS <= rep.keys()
    with np.load(out / "trace.npz") as npz:
        assert {"t", "ref", "pos", "line", "err_um"} <= set(npz.files)
        assert npz["err_um"].shape == npz["t"].shape
    assert (out / "path.png").stat().st_size > 0 and (out / "error.png").stat().st_size > 0
    (out / "report.json").unlink()
    assert main(["run", str(prog), "--out", str(out), "--max-error-um", "0.01"]) == 1
    assert (out / "report.json").exists()


def test_a_program_of_rapids_only_says_it_measured_no_contour_error(
    write_program, tmp_path, capsys
):
    """Rapids are not cutting: with no feed move the contour error is 0 by definition, and a
    gate on it passes; the summary says so rather than print a figure that looks measured."""
    prog = write_program("G21 G90\nG0 X5 Y2\nG0 Z-1\nG0 X0 Y0 Z0\nM2\n")
    out = tmp_path / "out"
    assert main(["run", str(prog), "--out", str(out), "--no-plots", "--max-error-um", "1"]) == 0
    text = capsys.readouterr().out
    assert "contour error: none measured: the program has no feed moves" in text
    assert "contour error: max" not in text
    rep = json.loads((out / "report.json").read_text())
    assert rep["contour_error_um"] == {"max": 0.0, "rms": 0.0, "p95": 0.0}
    assert rep["blocks"] == []


def test_bad_machine_key_exits_2(write_program, tmp_path, capsys):
    mf = machine_file(tmp_path, "[servo]\nkp = 3\n")
    assert (
        main(
            ["run", str(write_program(CIRCLE)), "--machine", str(mf), "--out", str(tmp_path / "o")]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert f"{mf}: error: unknown key 'kp' in [servo]" in err and "Traceback" not in err


def test_program_outside_travel_exits_2_and_leaves_no_report(write_program, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.json").write_text("{}")  # an earlier run's report must not survive
    prog = write_program("G1 X100 F3000\nG1 X400\nM2\n")
    assert main(["run", str(prog), "--out", str(out)]) == 2
    assert f"{prog}:2: error:" in capsys.readouterr().err
    assert not (out / "report.json").exists()


@pytest.mark.parametrize(("interruption", "status"), [(KeyboardInterrupt, 130), (Terminated, 143)])
def test_an_interrupted_run_leaves_the_earlier_whole_run(
    interruption, status, write_program, tmp_path, monkeypatch
):  # type: ignore[no-untyped-def]
    """Ctrl-C or SIGTERM during the simulation: the folder still holds the earlier run, whole
    (a failing run removes it; an interrupted one has not failed)."""
    out = tmp_path / "out"
    prog = write_program(CIRCLE)
    assert main(["run", str(prog), "--out", str(out), "--no-plots"]) == 0
    before = {f.name: f.read_bytes() for f in out.iterdir()}
    assert "report.json" in before

    def interrupted(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise interruption

    monkeypatch.setattr("gantry_sim.sim.api.run_program", interrupted)
    assert main(["run", str(prog), "--out", str(out), "--no-plots"]) == status
    assert {f.name: f.read_bytes() for f in out.iterdir()} == before


def test_divergence_is_an_error(write_program, tmp_path, capsys):
    gains = {"kp_N_per_mm": [1e6, 1e6, 1e6], "kd_N_s_per_mm": [1e4, 1e4, 1e4]}
    mf = write_variant(tmp_path, motors=UNLIMITED_FORCE, sections={"servo": gains})
    out = tmp_path / "out"
    prog = write_program("G1 X1 F600\nM2\n")
    assert main(["run", str(prog), "--machine", str(mf), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert re.search(rf"{re.escape(str(prog))}:1: error: .*(diverged|following error)", err)
    assert not (out / "report.json").exists()


def test_pd_circle_radius_matches_the_discrete_loop_gain(tmp_path):
    """Without friction and damping, a PD-only circle settles at |G(e^{jwT})| times its radius."""
    machine = gantry_variant(
        tmp_path,
        joints={a: {"damping": 0.0, "frictionloss": 0.0} for a in AXIS_NAMES},
        servo={"ff_velocity": [0.0, 0.0, 0.0], "ff_acceleration": [0.0, 0.0, 0.0]},
        limits={
            "max_acceleration_mm_per_s2": [20000.0, 20000.0, 20000.0],
            "max_jerk_mm_per_s3": [2e6, 2e6, 2e6],
        },
    )
    radius = 10.0
    prog = f"G17 G1 X{radius} F12000\nG3 I-{radius} J0 P2\nG1 X0\nM2\n"
    res = run_program(prog, machine=machine)
    tr = res.trace
    speed = np.linalg.norm(np.gradient(tr.ref, tr.t, axis=0), axis=1)
    on_circle = tr.line == 2
    steady = on_circle & (speed > 0.999 * speed[on_circle].max())
    steady &= tr.t > tr.t[steady][0] + 0.05  # the loop's transient (~20 ms) has died out
    assert steady.sum() > 300
    r_ref = np.hypot(tr.ref[steady, 0], tr.ref[steady, 1])
    r_pos = np.hypot(tr.pos[steady, 0], tr.pos[steady, 1])
    omega = float(np.mean(speed[steady])) / radius
    g = load_gantry(machine)
    gain = abs(DiscretePD(machine.servo, g.plant).closed_loop_gain(omega, 0))
    predicted_um = (gain - 1.0) * r_ref.mean() * 1000
    measured_um = (r_pos.mean() - r_ref.mean()) * 1000
    assert predicted_um > 20.0  # a clear effect, far above the reference's sub-um error
    assert measured_um == pytest.approx(predicted_um, rel=0.05)


def test_mujoco_instability_warnings_are_a_simulation_error(machine):
    """MuJoCo resets a state whose accelerations blow up and counts a warning: that is fatal."""
    import mujoco

    from gantry_sim.controller.errors import SimulationError
    from gantry_sim.controller.gcode.interpreter import interpret
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.runner import _check

    g = load_gantry(machine)
    traj = plan(tuple(interpret("G1 X1 F600\nM2\n")), machine).sample(machine.servo.period_s)
    d = mujoco.MjData(g.model)
    work_mm = traj.pos.copy()  # a trace exactly on the reference
    _check(d, machine, traj, work_mm, 0, traj.t.size)
    d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number = 1
    with pytest.raises(SimulationError, match=r"diverged.*BADQACC") as info:
        _check(d, machine, traj, work_mm, 0, traj.t.size)
    assert info.value.line == 1


def test_trace_is_the_tool_site_mujoco_reaches_at_every_tick(machine):
    """The runner records qpos per tick and maps it to the tool site after the loop; replaying
    its held forces through MuJoCo with mj_kinematics at every tick gives the same trace."""
    import mujoco

    from gantry_sim.controller.gcode.interpreter import interpret
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.runner import simulate

    g = load_gantry(machine)
    traj = plan(tuple(interpret(CIRCLE)), machine).sample(machine.servo.period_s)
    sim = simulate(g, machine, traj)
    d = mujoco.MjData(g.model)
    d.qpos[:] = g.joint_qpos_m(g.work_to_joint_mm(traj.pos[0]))
    replay = np.empty_like(sim.pos)
    for k, force in enumerate(sim.force):
        mujoco.mj_kinematics(g.model, d)
        replay[k] = g.tool_to_work_mm(d.site_xpos[g.site_id])
        d.ctrl[list(g.actuator_id)] = force / np.asarray(g.gear)
        mujoco.mj_step(g.model, d, g.substeps)
    assert np.abs(sim.pos - replay).max() <= 1e-9  # [mm]: rounding only
    assert np.abs(sim.pos - traj.pos).max() > 1e-4  # a real trace, not the reference


def test_non_finite_or_far_trace_is_a_simulation_error(machine):
    import mujoco

    from gantry_sim.controller.errors import SimulationError
    from gantry_sim.controller.gcode.interpreter import interpret
    from gantry_sim.controller.planner.plan import plan
    from gantry_sim.sim.runner import _check

    g = load_gantry(machine)
    traj = plan(tuple(interpret("G1 X1 F600\nM2\n")), machine).sample(machine.servo.period_s)
    d = mujoco.MjData(g.model)
    for bad, what in ((np.nan, "non-finite"), (np.inf, "non-finite"), (2.5, "2.5 mm")):
        work_mm = traj.pos.copy()
        work_mm[7, 1] += bad
        with pytest.raises(SimulationError, match=f"on Y is {what}") as info:
            _check(d, machine, traj, work_mm, 0, traj.t.size)
        assert info.value.line == 1


@pytest.mark.parametrize("chained", [True, False])
def test_sigterm_turned_into_an_import_error_is_a_termination(
    chained, write_program, tmp_path, monkeypatch, capsys
):  # type: ignore[no-untyped-def]
    """SIGTERM arriving inside ``import mujoco``: pybind11 reports the module's failed
    initialisation as "ImportError: initialization failed" (exit 3 before); it is the SIGTERM,
    exit 143. ``chained``: the ImportError names the Terminated as its context, or nothing."""
    from gantry_sim.sim import interrupts

    def killed_mid_import(*args, **kwargs):  # type: ignore[no-untyped-def]
        try:
            interrupts.on_signal(15, None)  # the SIGTERM handler
        except BaseException:
            if chained:
                raise ImportError("initialization failed") from None
        raise ImportError("initialization failed")

    monkeypatch.setattr("gantry_sim.sim.api.run_program", killed_mid_import)
    prog = write_program(CIRCLE)
    assert main(["run", str(prog), "--out", str(tmp_path / "o")]) == 143
    assert capsys.readouterr().err == "gantry: terminated\n"

    def bug(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise ImportError("initialization failed")

    monkeypatch.setattr("gantry_sim.sim.api.run_program", bug)  # no SIGTERM this time: a bug
    assert main(["run", str(prog), "--out", str(tmp_path / "o")]) == 3
    assert "internal error" in capsys.readouterr().err
