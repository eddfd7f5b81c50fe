"""The effective machine: the machine file laid over the bundled one, plus what the MJCF says.

Per axis: the planner's limits, the travel, the moving mass as sim/machine.py reads it (bodies
moved by the joint + armature), damping, friction, gravity load and drive force limits, the
backlash, the servo gains as force-loop PID [N/mm, N s/mm, N/(mm s)] and as the position-loop
gain Kv of the equivalent cascade [1/s, (m/min)/mm], and the loop's figures from
controller.loop_figures: the continuous design's natural frequency and damping ratio, the
sampled loop's dominant mode, -3 dB bandwidth, pole radius and gain margin at the servo period.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.loop_figures import (
    M_PER_MIN_PER_MM_PER_S,
    AxisLoop,
    bandwidth_hz,
    design_mode,
    gain_margin,
    kv_per_s,
    sampled_mode,
)
from gantry_sim.controller.machine_import.common import Target
from gantry_sim.sim.machine import AXES, Gantry


def _finite(v: float | None) -> float | None:
    """JSON has no inf or nan: those become null."""
    return None if v is None or not math.isfinite(v) else float(v)


def import_target(gantry: Gantry) -> Target:
    """The model's figures an importer converts through (masses, joint ranges)."""
    rng = gantry.joint_range_mm()
    return Target(
        mass_kg=tuple(p.mass_kg for p in gantry.plant),  # type: ignore[arg-type]
        joint_range_mm=tuple((float(lo), float(hi)) for lo, hi in rng),  # type: ignore[arg-type]
    )


def effective_machine(machine: MachineConfig, gantry: Gantry) -> dict[str, Any]:
    """The effective machine as a JSON-able dict (keys carry their units)."""
    s, lim = machine.servo, machine.limits
    rng = gantry.joint_range_mm()
    axes = {}
    for i, name in enumerate(AXES):
        plant = gantry.plant[i]
        armature = float(gantry.model.dof_armature[gantry.dof_adr[i]])
        loop = AxisLoop(
            plant.mass_kg, s.kp_N_per_mm[i], s.kd_N_s_per_mm[i], s.ki_N_per_mm_s[i], s.period_s
        )
        f_design, zeta_design = design_mode(loop)
        f_sampled, zeta_sampled = sampled_mode(loop)
        kv = kv_per_s(s.kp_N_per_mm[i], s.kd_N_s_per_mm[i])
        axes[name] = {
            "max_velocity_mm_per_s": lim.max_velocity_mm_per_s[i],
            "max_velocity_mm_per_min": lim.max_velocity_mm_per_s[i] * 60.0,
            "max_acceleration_mm_per_s2": lim.max_acceleration_mm_per_s2[i],
            "max_jerk_mm_per_s3": lim.max_jerk_mm_per_s3[i],
            "travel_mm": [machine.travel.min_mm[i], machine.travel.max_mm[i]],
            "joint_range_mm": [_finite(float(v)) for v in rng[i]],
            "moving_mass_kg": plant.mass_kg,
            "bodies_kg": plant.mass_kg - armature,
            "armature_kg": armature,
            "damping_N_s_per_mm": plant.damping_N_s_per_mm,
            "friction_N": plant.friction_N,
            "gravity_load_N": plant.gravity_load_N,
            "force_min_N": _finite(plant.force_min_N),
            "force_max_N": _finite(plant.force_max_N),
            "peak_acceleration_mm_per_s2": _finite(
                min(-plant.force_min_N, plant.force_max_N) / plant.mass_kg * 1e3
            ),
            "backlash_mm": machine.sim.backlash_mm[i],
            "kp_N_per_mm": s.kp_N_per_mm[i],
            "kd_N_s_per_mm": s.kd_N_s_per_mm[i],
            "ki_N_per_mm_s": s.ki_N_per_mm_s[i],
            "max_error_integral_mm_s": s.max_error_integral_mm_s[i],
            "kv_per_s": _finite(kv),
            "kv_m_per_min_per_mm": _finite(kv * M_PER_MIN_PER_MM_PER_S),
            "ff_velocity": s.ff_velocity[i],
            "ff_acceleration": s.ff_acceleration[i],
            "ff_friction": s.ff_friction[i],
            "natural_frequency_Hz": f_design,
            "damping_ratio": zeta_design,
            "sampled_natural_frequency_Hz": _finite(f_sampled),
            "sampled_damping_ratio": _finite(zeta_sampled),
            "bandwidth_Hz": _finite(bandwidth_hz(loop)),
            "pole_radius": loop.pole_radius(),
            "gain_margin": _finite(gain_margin(loop)),
        }
    return {
        "machine": machine.source,
        "model": machine.sim.model,
        "servo_period_s": s.period_s,
        "physics_timestep_s": machine.sim.physics_timestep_s,
        "ff_gravity": s.ff_gravity,
        "max_following_error_mm": s.max_following_error_mm,
        "segmentation": {
            "method": machine.segmentation.method,
            "chord_tolerance_mm": machine.segmentation.chord_tolerance_mm,
            "segment_length_mm": machine.segmentation.segment_length_mm,
        },
        "path": dataclasses.asdict(machine.path),
        "axes": axes,
    }


#: (label, key or function of the axis dict, format) rows of the human table, in groups
_ROWS: tuple[tuple[str, tuple[tuple[str, Any, str], ...]], ...] = (
    (
        "limits",
        (
            ("max velocity [mm/s]", "max_velocity_mm_per_s", "{:.1f}"),
            ("max velocity [mm/min]", "max_velocity_mm_per_min", "{:.0f}"),
            ("max acceleration [mm/s^2]", "max_acceleration_mm_per_s2", "{:.0f}"),
            ("max jerk [mm/s^3]", "max_jerk_mm_per_s3", "{:.0f}"),
            ("travel [mm]", lambda a: "{:g}..{:g}".format(*a["travel_mm"]), "{}"),
        ),
    ),
    (
        "plant (MJCF)",
        (
            ("moving mass [kg]", "moving_mass_kg", "{:.2f}"),
            ("  bodies [kg]", "bodies_kg", "{:.2f}"),
            ("  armature [kg]", "armature_kg", "{:.2f}"),
            ("damping [N s/mm]", "damping_N_s_per_mm", "{:.3f}"),
            ("friction [N]", "friction_N", "{:.2f}"),
            ("gravity load [N]", "gravity_load_N", "{:.2f}"),
            ("drive force [N]", lambda a: _range(a["force_min_N"], a["force_max_N"]), "{}"),
            ("peak acceleration [mm/s^2]", "peak_acceleration_mm_per_s2", "{:.0f}"),
            ("backlash [mm]", "backlash_mm", "{:g}"),
        ),
    ),
    (
        "servo",
        (
            ("kp [N/mm]", "kp_N_per_mm", "{:.1f}"),
            ("kd [N s/mm]", "kd_N_s_per_mm", "{:.3f}"),
            ("ki [N/(mm s)]", "ki_N_per_mm_s", "{:.1f}"),
            ("integral clamp [mm s]", lambda a: _clamp(a["max_error_integral_mm_s"]), "{}"),
            ("Kv = kp/kd [1/s]", "kv_per_s", "{:.1f}"),
            ("Kv [(m/min)/mm]", "kv_m_per_min_per_mm", "{:.2f}"),
            ("feedforward vel/acc/fric", lambda a: _ff(a), "{}"),
        ),
    ),
    (
        "loop",
        (
            ("design wn [Hz]", "natural_frequency_Hz", "{:.1f}"),
            ("design damping ratio", "damping_ratio", "{:.3f}"),
            ("sampled wn [Hz]", "sampled_natural_frequency_Hz", "{:.1f}"),
            ("sampled damping ratio", "sampled_damping_ratio", "{:.3f}"),
            ("bandwidth -3 dB [Hz]", "bandwidth_Hz", "{:.1f}"),
            ("pole radius |z|", "pole_radius", "{:.3f}"),
            ("gain margin [x]", "gain_margin", "{:.2f}"),
        ),
    ),
)


def _range(lo: float | None, hi: float | None) -> str:
    return f"{'-inf' if lo is None else f'{lo:g}'}..{'inf' if hi is None else f'{hi:g}'}"


def _clamp(v: float) -> str:
    return "none" if v == 0 else f"{v:g}"


def _ff(a: dict) -> str:
    return f"{a['ff_velocity']:g}/{a['ff_acceleration']:.3g}/{a['ff_friction']:g}"


def _cell(axis: dict, key: Any, fmt: str) -> str:
    value = key(axis) if callable(key) else axis[key]
    return "-" if value is None else fmt.format(value)


def _path_text(path: dict[str, Any], seg: dict[str, Any]) -> str:
    """Path control at program start and the arcs' segmentation, in one line."""
    mode = path["mode"]
    if mode == "G64":
        mode += f" (blend within {path['tolerance_mm']:g} mm, short moves {path['short_moves']}"
        q = path["naive_cam_tolerance_mm"]
        mode += f", naive-CAM Q {q:g} mm)" if q else ")"
    chords = (
        f"chords within {seg['chord_tolerance_mm']:g} mm"
        if seg["method"] == "chord"
        else f"segments of {seg['segment_length_mm']:g} mm"
    )
    return f"path control at program start {mode}; arcs in {chords}"


def format_table(info: dict[str, Any]) -> str:
    """The effective machine as a table for people: one column per axis."""
    axes = info["axes"]
    width = 28
    lines = [
        f"machine: {info['machine']}",
        f"model:   {info['model']}",
        f"servo period {info['servo_period_s'] * 1e3:g} ms, physics step "
        f"{info['physics_timestep_s'] * 1e3:g} ms, following-error limit "
        f"{info['max_following_error_mm']:g} mm, gravity feedforward {info['ff_gravity']:g}",
        _path_text(info["path"], info["segmentation"]),
        "",
        f"{'':{width}}" + "".join(f"{a.upper():>14}" for a in axes),
    ]
    for group, rows in _ROWS:
        lines.append(f"{group}")
        for label, key, fmt in rows:
            cells = "".join(f"{_cell(axes[a], key, fmt):>14}" for a in axes)
            lines.append(f"  {label:{width - 2}}{cells}")
    margins = [axes[a]["gain_margin"] for a in axes]
    if any(m is not None and m < 1.0 for m in margins):
        lines.append("")
        lines.append(
            "WARNING: gain margin < 1 on "
            + ", ".join(
                a.upper() for a, m in zip(axes, margins, strict=True) if m is not None and m < 1.0
            )
            + ": the sampled loop is unstable at this servo period (lower the gains or the period)"
        )
    return "\n".join(lines)
