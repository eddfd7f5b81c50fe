"""The bundled MJCF: it compiles, has the contract's names, the documented masses and ranges."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.errors import ConfigError
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML, SCENE_XML
from gantry_sim.sim.machine import AXES, load_gantry


def test_model_and_scene_compile_with_the_contract_names():
    for path in (GANTRY_XML, SCENE_XML):
        m = mujoco.MjModel.from_xml_path(str(path))
        for name in AXES:
            assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name) >= 0
            assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name) >= 0
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tool") >= 0
        sensors = {m.sensor(i).name: m.sensor_type[i] for i in range(m.nsensor)}
        assert mujoco.mjtSensor.mjSENS_FRAMEPOS in sensors.values()
        assert mujoco.mjtSensor.mjSENS_FRAMELINVEL in sensors.values()
        assert (m.geom_contype == 0).all() and (m.geom_conaffinity == 0).all()


def test_plant_read_from_the_model(machine):
    g = load_gantry(machine)
    # masses documented in models/gantry.xml: bodies moved + armature
    assert [p.mass_kg for p in g.plant] == pytest.approx([17.0, 60.0, 9.0])
    assert [p.gravity_load_N for p in g.plant] == pytest.approx([0.0, 0.0, -5.0 * 9.81])
    assert all(p.force_min_N < 0 < p.force_max_N for p in g.plant)
    assert all(p.friction_N > 0 and p.damping_N_s_per_mm > 0 for p in g.plant)
    # the mass matrix agrees (orthogonal slides: diagonal)
    d = mujoco.MjData(g.model)
    mujoco.mj_forward(g.model, d)
    full = np.zeros((g.model.nv, g.model.nv))
    mujoco.mj_fullM(g.model, d, full)
    assert [full[i, i] for i in g.dof_adr] == pytest.approx([17.0, 60.0, 9.0])
    assert g.model.opt.timestep == machine.sim.physics_timestep_s
    assert g.substeps * machine.sim.physics_timestep_s == pytest.approx(machine.servo.period_s)


def test_joint_ranges_are_the_machine_file_travel(machine):
    g = load_gantry(machine)
    travel = np.column_stack([machine.travel.min_mm, machine.travel.max_mm])
    assert g.joint_range_mm() == pytest.approx(g.work_to_joint_mm(travel.T).T)
    # the contract's work volume is reachable
    assert (travel[:, 0] <= [-250, -150, -60]).all() and (travel[:, 1] >= [250, 150, 60]).all()


def test_work_coordinates_follow_the_joints(machine):
    g = load_gantry(machine)
    d = mujoco.MjData(g.model)
    d.qpos[:] = g.joint_qpos_m(np.array([12.5, -30.0, 7.0]))
    mujoco.mj_kinematics(g.model, d)
    work = g.tool_to_work_mm(d.site_xpos[g.site_id])
    assert work == pytest.approx(np.array([12.5, -30.0, 7.0]) - machine.sim.work_origin_joint_mm)


def test_servo_period_must_be_a_multiple_of_the_timestep(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text("[sim]\nphysics_timestep_s = 0.0003\n")
    with pytest.raises(ConfigError, match="integer multiple"):
        load_machine_config(DEFAULT_MACHINE, f)


def test_a_model_without_the_axes_is_refused_listing_what_it_has(tmp_path):
    xml = tmp_path / "bad.xml"
    xml.write_text(
        """<mujoco><worldbody><body name="b"><joint name="u" type="slide"/>
        <geom size="0.1"/><site name="tool"/></body></worldbody>
        <actuator><motor name="x" joint="u"/></actuator></mujoco>"""
    )
    f = tmp_path / "m.toml"
    f.write_text(f'[sim]\nmodel = "{xml.name}"\n')
    with pytest.raises(ConfigError, match=r"no joint named 'x'.*its joints: u"):
        load_gantry(load_machine_config(DEFAULT_MACHINE, f))


def _kinematics(model, qpos_rows, site):
    d = mujoco.MjData(model)
    out = []
    for row in qpos_rows:
        d.qpos[:] = row
        mujoco.mj_kinematics(model, d)
        out.append(d.site_xpos[site].copy())
    return np.array(out)


def test_tool_site_of_recorded_joint_states_is_mujocos_kinematics(machine):
    """The runner maps recorded qpos to the tool site in one pass; on the all-slide gantry that
    is a closed form, which must be MuJoCo's mj_kinematics to rounding."""
    g = load_gantry(machine)
    assert g.site_slides is not None
    rows = g.model.qpos0 + np.random.default_rng(2).uniform(-0.3, 0.3, (50, g.model.nq))
    got = g.tool_site_m(rows)
    assert np.abs(got - _kinematics(g.model, rows, g.site_id)).max() <= 1e-12


def test_tool_site_behind_a_rotating_joint_uses_mujocos_kinematics(tmp_path):
    """A hinge between the world and the tool site (a spindle with an offset tip) makes the
    site a nonlinear function of qpos: no closed form, mj_kinematics per recorded row."""
    motors = "".join(
        f'<motor name="{a}" joint="{a}" ctrlrange="-500 500"/>' for a in ("x", "y", "z")
    )
    xml = tmp_path / "hinged.xml"
    xml.write_text(
        f"""<mujoco><worldbody>
        <body name="b"><joint name="y" type="slide" axis="0 1 0" range="-0.3 0.3"/>
         <geom size="0.05" mass="10"/>
         <body name="c"><joint name="x" type="slide" axis="1 0 0" range="-0.4 0.4"/>
          <geom size="0.05" mass="5"/>
          <body name="r"><joint name="z" type="slide" axis="0 0 1" range="-0.1 0.1"/>
           <geom size="0.05" mass="2"/>
           <body name="s"><joint name="spin" type="hinge" axis="0 1 0"/>
            <geom size="0.02" mass="0.5"/><site name="tool" pos="0.02 0 -0.1"/>
           </body></body></body></body></worldbody>
        <actuator>{motors}</actuator></mujoco>"""
    )
    f = tmp_path / "m.toml"
    f.write_text(f'[sim]\nmodel = "{xml.name}"\n')
    g = load_gantry(load_machine_config(DEFAULT_MACHINE, f))
    assert g.site_slides is None
    rows = g.model.qpos0 + np.random.default_rng(3).uniform(-0.3, 0.3, (20, g.model.nq))
    expect = _kinematics(g.model, rows, g.site_id)
    assert np.array_equal(g.tool_site_m(rows), expect)
    # the hinge does move the tip: a slides-only map would be wrong here
    assert np.ptp(expect[:, 0] - rows[:, g.qpos_adr[0]]) > 1e-3
