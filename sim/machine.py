"""The MuJoCo gantry as the servo sees it: names resolved, plant parameters, units, work origin.

This is the ONE place where SI (MuJoCo: m, kg, N s/m) meets gantry-sim's millimetres:
:data:`MM_PER_M` and the methods of :class:`Gantry` convert; nothing else in sim/ scales lengths.

Conventions: axis order is always (x, y, z) = (0, 1, 2), whatever order the MJCF declares its
joints in. Work (program) coordinates [mm] are the tool-tip site's displacement from where it is
when the joints stand at ``work_origin_joint_mm``; the servo works in joint coordinates [mm].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.servo import AxisPlant
from gantry_sim.sim.site_slides import along_slides, site_slides

AXES = ("x", "y", "z")
TOOL_SITE = "tool"
MM_PER_M = 1000.0
#: damping [N s/m] * this = [N s/mm]
N_S_PER_MM_PER_N_S_PER_M = 1e-3

T = TypeVar("T")


def _names(model: Any, obj: int, count: int) -> list[str]:
    import mujoco

    return [mujoco.mj_id2name(model, obj, i) or f"#{i}" for i in range(count)]


@dataclass(frozen=True)
class Gantry:
    """A compiled model with the indices and plant parameters of axes x, y, z.

    Attributes:
        model: the ``mujoco.MjModel`` (timestep set from the machine file).
        qpos_adr: qpos index of joints x, y, z.
        dof_adr: dof index of joints x, y, z.
        actuator_id: actuator index driving x, y, z.
        site_id: index of the ``tool`` site.
        plant: per-axis :class:`AxisPlant` (mass, damping, friction, gravity, force limits).
        gear: the actuators' gear (joint force = gear * ctrl).
        origin_joint_mm: joint positions of the work origin [mm].
        tool_origin_m: tool-site position at the work origin [m] (world frame).
        substeps: physics steps per servo period.
        site_slides: the tool site's position as an affine function of qpos, when every joint
            between it and the world is a slide: (site at qpos0 [m] (3,), matrix (nq, 3) whose
            row i is the world axis moved by qpos[i], zero for other coordinates), so that
            site = site0 + (qpos - qpos0) @ matrix; None otherwise. Checked against
            ``mj_kinematics`` at load.
    """

    model: Any
    qpos_adr: tuple[int, int, int]
    dof_adr: tuple[int, int, int]
    actuator_id: tuple[int, int, int]
    site_id: int
    plant: tuple[AxisPlant, AxisPlant, AxisPlant]
    gear: tuple[float, float, float]
    origin_joint_mm: tuple[float, float, float]
    tool_origin_m: np.ndarray
    substeps: int
    site_slides: tuple[np.ndarray, np.ndarray] | None = None

    def tool_site_m(self, qpos: np.ndarray) -> np.ndarray:
        """Tool-site world positions (N, 3) [m] of joint states ``qpos`` (N, nq) [m, MuJoCo's].

        The site is a pure function of qpos (what ``mj_kinematics`` computes). With only slides
        between the site and the world (:attr:`site_slides`) it is site(qpos0) plus each joint's
        displacement along its world axis, evaluated for all rows at once; otherwise MuJoCo's
        ``mj_kinematics`` runs once per row.
        """
        qpos = np.asarray(qpos, dtype=float).reshape(-1, self.model.nq)
        if self.site_slides is not None:
            return along_slides(self.site_slides, self.model.qpos0, qpos)
        import mujoco

        d = mujoco.MjData(self.model)
        out = np.empty((qpos.shape[0], 3))
        site = d.site_xpos[self.site_id]
        for k, row in enumerate(qpos):
            d.qpos[:] = row
            mujoco.mj_kinematics(self.model, d)
            out[k] = site
        return out

    def joint_range_mm(self) -> np.ndarray:
        """(3, 2) joint ranges [mm] of x, y, z (lower, upper)."""
        import mujoco

        out = np.full((3, 2), np.inf)
        out[:, 0] = -np.inf
        for i, name in enumerate(AXES):
            j = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if self.model.jnt_limited[j]:
                out[i] = self.model.jnt_range[j] * MM_PER_M
        return out

    def joint_qpos_m(self, joint_mm: np.ndarray) -> np.ndarray:
        """Joint positions [mm] in axis order -> a full qpos vector [m]."""
        return _qpos_m(self.model, self.qpos_adr, joint_mm)

    def work_to_joint_mm(self, work_mm: np.ndarray) -> np.ndarray:
        """Program (work) coordinates (..., 3) [mm] -> joint coordinates (..., 3) [mm]."""
        return np.asarray(work_mm, dtype=float) + np.asarray(self.origin_joint_mm)

    def tool_to_work_mm(self, tool_m: np.ndarray) -> np.ndarray:
        """Tool-site world positions (..., 3) [m] -> program (work) coordinates (..., 3) [mm]."""
        return (np.asarray(tool_m, dtype=float) - self.tool_origin_m) * MM_PER_M


def _lookup(model: Any, obj: Any, kind: str, name: str, count: int, file: str) -> int:
    import mujoco

    idx = mujoco.mj_name2id(model, obj, name)
    if idx < 0:
        valid = ", ".join(_names(model, obj, count)) or "none"
        raise ConfigError(
            f"the model has no {kind} named '{name}' (gantry-sim needs {kind}s "
            f"{', '.join(repr(a) for a in AXES) if kind != 'site' else repr(TOOL_SITE)}); "
            f"its {kind}s: {valid}",
            file=file,
        )
    return idx


def load_gantry(machine: MachineConfig) -> Gantry:
    """Load ``machine.sim.model``, resolve axes, read the plant, set the timestep.

    Raises:
        ConfigError: the model cannot be loaded, lacks a joint/actuator named x, y, z or the
            ``tool`` site (the message lists the ones it has), a joint is not a slide along its
            world axis, or an actuator is not a plain force motor.
    """
    file = machine.sim.model
    model, data = _load_model(file, machine.sim.physics_timestep_s)
    joints, acts, site = _resolve_names(model, file)
    plant, gear = _read_plant(model, joints, acts, file)
    qpos_adr = _xyz([int(model.jnt_qposadr[j]) for j in joints])
    origin = machine.sim.work_origin_joint_mm
    gantry = Gantry(
        model=model,
        qpos_adr=qpos_adr,
        dof_adr=_xyz([int(model.jnt_dofadr[j]) for j in joints]),
        actuator_id=acts,
        site_id=site,
        plant=plant,
        gear=gear,
        origin_joint_mm=origin,
        tool_origin_m=_tool_origin_m(model, data, qpos_adr, site, origin),
        substeps=round(machine.servo.period_s / machine.sim.physics_timestep_s),
        site_slides=site_slides(model, site),
    )
    _check_travel(gantry, machine, file)
    return gantry


def _xyz(values: Sequence[T]) -> tuple[T, T, T]:
    """Three per-axis values (x, y, z) as a typed triple."""
    x, y, z = values
    return (x, y, z)


def _load_model(file: str, timestep_s: float) -> tuple[Any, Any]:
    """Compile the MJCF at ``file`` with the machine file's physics timestep [s]: (model, data)."""
    from pathlib import Path

    import mujoco

    from gantry_sim.controller.input_files import check_model_file

    check_model_file(Path(file), "the MJCF model")
    try:
        model = mujoco.MjModel.from_xml_path(file)
    except (ValueError, OSError) as exc:
        raise ConfigError(f"cannot load the MJCF model: {exc}".strip(), file=file) from None
    model.opt.timestep = timestep_s
    data = mujoco.MjData(model)
    mujoco.mj_setConst(model, data)
    return model, data


def _resolve_names(model: Any, file: str) -> tuple[tuple[int, int, int], tuple[int, int, int], int]:
    """Step 1, names: the indices of joints x, y, z, of actuators x, y, z and of the tool site."""
    import mujoco

    joints = _xyz(
        [_lookup(model, mujoco.mjtObj.mjOBJ_JOINT, "joint", a, model.njnt, file) for a in AXES]
    )
    acts = _xyz(
        [_lookup(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator", a, model.nu, file) for a in AXES]
    )
    site = _lookup(model, mujoco.mjtObj.mjOBJ_SITE, "site", TOOL_SITE, model.nsite, file)
    return joints, acts, site


def _read_plant(
    model: Any, joints: tuple[int, int, int], acts: tuple[int, int, int], file: str
) -> tuple[tuple[AxisPlant, AxisPlant, AxisPlant], tuple[float, float, float]]:
    """Step 2, plant: per axis the AxisPlant (moved mass, damping, friction, gravity load,
    force range [N]) and the actuator's gear, after checking that each joint is a slide along
    its world axis and each actuator a plain force motor on it."""
    import mujoco

    gravity = np.asarray(model.opt.gravity, dtype=float)
    plant = []
    gear = []
    for i, (name, j, a) in enumerate(zip(AXES, joints, acts, strict=True)):
        unit = np.eye(3)[i]
        if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_SLIDE or not np.allclose(
            model.jnt_axis[j], unit
        ):
            raise ConfigError(
                f"joint '{name}' must be a slide joint along the world {name.upper()} axis "
                f'(axis="{" ".join(str(int(c)) for c in unit)}")',
                file=file,
            )
        if (
            model.actuator_trnid[a, 0] != j
            or model.actuator_gaintype[a] != mujoco.mjtGain.mjGAIN_FIXED
            or model.actuator_biastype[a] != mujoco.mjtBias.mjBIAS_NONE
            or model.actuator_dyntype[a] != mujoco.mjtDyn.mjDYN_NONE
            or model.actuator_gainprm[a, 0] != 1.0
        ):
            raise ConfigError(
                f"actuator '{name}' must be a <motor> on joint '{name}' (ctrl is a force [N])",
                file=file,
            )
        g = float(model.actuator_gear[a, 0])
        lo, hi = -np.inf, np.inf
        if model.actuator_ctrllimited[a]:
            lo, hi = model.actuator_ctrlrange[a] * g
        if model.actuator_forcelimited[a]:
            flo, fhi = model.actuator_forcerange[a] * g
            lo, hi = max(lo, flo), min(hi, fhi)
        if not (lo < 0 < hi):
            raise ConfigError(
                f"actuator '{name}' needs a force range around 0 (ctrlrange/forcerange)", file=file
            )
        dof = model.jnt_dofadr[j]
        body = model.jnt_bodyid[j]
        moved_kg = float(model.body_subtreemass[body])
        plant.append(
            AxisPlant(
                mass_kg=moved_kg + float(model.dof_armature[dof]),
                damping_N_s_per_mm=float(model.dof_damping[dof]) * N_S_PER_MM_PER_N_S_PER_M,
                friction_N=float(model.dof_frictionloss[dof]),
                gravity_load_N=moved_kg * float(gravity @ unit),
                force_min_N=float(lo),
                force_max_N=float(hi),
            )
        )
        gear.append(g)
    return _xyz(plant), _xyz(gear)


def _qpos_m(model: Any, qpos_adr: tuple[int, int, int], joint_mm: np.ndarray) -> np.ndarray:
    """Joint positions [mm] in axis order -> a full qpos vector [m] (others at qpos0)."""
    qpos = model.qpos0.copy()
    for i, adr in enumerate(qpos_adr):
        qpos[adr] = joint_mm[i] / MM_PER_M
    return qpos


def _tool_origin_m(
    model: Any,
    data: Any,
    qpos_adr: tuple[int, int, int],
    site: int,
    origin_joint_mm: tuple[float, float, float],
) -> np.ndarray:
    """Step 3, work origin: the tool site's world position [m] with the joints at the work
    origin ``origin_joint_mm`` [mm] (``mj_kinematics`` on ``data``)."""
    import mujoco

    data.qpos[:] = _qpos_m(model, qpos_adr, np.asarray(origin_joint_mm))
    mujoco.mj_kinematics(model, data)
    return data.site_xpos[site].copy()


def _check_travel(gantry: Gantry, machine: MachineConfig, file: str) -> None:
    """The machine file's [travel] (work mm) must lie inside the joints' ranges."""
    rng = gantry.joint_range_mm()
    lo = gantry.work_to_joint_mm(np.asarray(machine.travel.min_mm))
    hi = gantry.work_to_joint_mm(np.asarray(machine.travel.max_mm))
    for i, name in enumerate(AXES):
        if lo[i] < rng[i, 0] - 1e-9 or hi[i] > rng[i, 1] + 1e-9:
            raise ConfigError(
                f"[travel] {name} {machine.travel.min_mm[i]:g}..{machine.travel.max_mm[i]:g} mm "
                f"(joint {lo[i]:g}..{hi[i]:g} mm with the work origin) leaves joint '{name}' "
                f"range {rng[i, 0]:g}..{rng[i, 1]:g} mm in the model",
                file=machine.source,
            )
