"""Machine files: per-axis limits, travel, segmentation, servo and simulation settings.

A machine file is TOML with the sections and keys of the bundled ``models/gantry.toml`` (which
documents each one). A user's file is laid over the bundled defaults: keys it omits keep the
defaults, unknown sections or keys are errors that list the valid ones, and every value is checked
(type, length, sign) with an error naming the key. Units are in the key names.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.planes import Vec3

# --- value checkers: each returns the cleaned value or raises ValueError(what is allowed) ---------


def _positive(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ValueError("a finite number > 0")
    return float(v)


def _non_negative(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise ValueError("a finite number >= 0")
    return float(v)


def _finite(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError("a finite number")
    return float(v)


def _vec3(item: Callable[[Any], float], what: str) -> Callable[[Any], Vec3]:
    def check(v: Any) -> Vec3:
        if not isinstance(v, list) or len(v) != 3:
            raise ValueError(f"a list of 3 numbers [x, y, z], each {what}")
        try:
            return tuple(item(c) for c in v)  # type: ignore[return-value]
        except ValueError:
            raise ValueError(f"a list of 3 numbers [x, y, z], each {what}") from None

    return check


def _choice(*options: str) -> Callable[[Any], str]:
    def check(v: Any) -> str:
        if v not in options:
            raise ValueError("one of " + ", ".join(repr(o) for o in options))
        return v

    return check


def _string(v: Any) -> str:
    if not isinstance(v, str) or not v:
        raise ValueError("a non-empty string")
    return v


_POS3 = _vec3(_positive, "> 0")
_NONNEG3 = _vec3(_non_negative, ">= 0")
_FIN3 = _vec3(_finite, "finite")

#: section -> key -> checker. The bundled models/gantry.toml sets every key.
SCHEMA: dict[str, dict[str, Callable[[Any], Any]]] = {
    "limits": {
        "max_velocity_mm_per_s": _POS3,
        "max_acceleration_mm_per_s2": _POS3,
        "max_jerk_mm_per_s3": _POS3,
    },
    "travel": {"min_mm": _FIN3, "max_mm": _FIN3},
    "segmentation": {
        "method": _choice("chord", "fixed"),
        "chord_tolerance_mm": _positive,
        "segment_length_mm": _positive,
    },
    "path": {
        "mode": _choice("G64", "G61", "G61.1"),
        "tolerance_mm": _positive,
        "naive_cam_tolerance_mm": _non_negative,
    },
    "servo": {
        "period_s": _positive,
        "kp_N_per_mm": _POS3,
        "kd_N_s_per_mm": _NONNEG3,
        "ff_velocity": _NONNEG3,
        "ff_acceleration": _NONNEG3,
        "ff_friction": _NONNEG3,
        "ff_gravity": _non_negative,
        "max_following_error_mm": _positive,
        "ki_N_per_mm_s": _NONNEG3,
        "max_error_integral_mm_s": _NONNEG3,
    },
    "sim": {
        "model": _string,
        "physics_timestep_s": _positive,
        "work_origin_joint_mm": _FIN3,
        "backlash_mm": _NONNEG3,
    },
}


@dataclass(frozen=True)
class Limits:
    """Per-axis kinematic limits [x, y, z] of the reference trajectory."""

    max_velocity_mm_per_s: Vec3
    max_acceleration_mm_per_s2: Vec3
    max_jerk_mm_per_s3: Vec3

    def per_axis(self) -> tuple[Vec3, Vec3, Vec3]:
        """(velocity [mm/s], acceleration [mm/s^2], jerk [mm/s^3]) limits, each [x, y, z]."""
        return self.max_velocity_mm_per_s, self.max_acceleration_mm_per_s2, self.max_jerk_mm_per_s3

    def to_json(self) -> dict:
        return {k: list(getattr(self, k)) for k in SCHEMA["limits"]}


@dataclass(frozen=True)
class Travel:
    """Reachable work volume in program (work) coordinates [mm]."""

    min_mm: Vec3
    max_mm: Vec3


@dataclass(frozen=True)
class Segmentation:
    """How arcs become chords: "chord" (sagitta <= chord_tolerance_mm) or "fixed" (Marlin)."""

    method: str
    chord_tolerance_mm: float
    segment_length_mm: float


@dataclass(frozen=True)
class PathSettings:
    """Path control at program start (the program's G61/G61.1/G64 change it).

    mode: "G64" (blend corners within tolerance_mm), "G61" (exact stops at corners) or "G61.1"
    (exact stop at every junction). tolerance_mm: how far the reference may leave the programmed
    path at a blended junction [mm], also G64 without P. naive_cam_tolerance_mm: G64 without Q
    merges consecutive straight moves within this distance of one line [mm] (0: never).

    The default, G64 with 0.01 mm: LinuxCNC starts in G64, and grbl's default junction deviation
    ($11) is 0.01 mm, which is the same corner-to-circle distance as a 0.01 mm blend tolerance.
    """

    mode: str = "G64"
    tolerance_mm: float = 0.01
    naive_cam_tolerance_mm: float = 0.0


@dataclass(frozen=True)
class Servo:
    """Discrete PD per axis with feedforward (see controller.servo for the law and units).

    ff_velocity / ff_acceleration / ff_friction are fractions (0 off, 1 full model) of the plant's
    viscous damping, moving mass and Coulomb friction per axis; ff_gravity the fraction of gravity
    on Z that is compensated. max_following_error_mm is the drive's following-error fault
    limit (LinuxCNC's FERROR): a simulation whose tool tip strays further from the reference fails.
    ki_N_per_mm_s is the integral gain [N/(mm s)] and max_error_integral_mm_s the clamp on the
    error integral [mm s] (LinuxCNC's maxerror-i; 0 = no clamp).
    """

    period_s: float
    kp_N_per_mm: Vec3
    kd_N_s_per_mm: Vec3
    ff_velocity: Vec3
    ff_acceleration: Vec3
    ff_friction: Vec3
    ff_gravity: float
    max_following_error_mm: float
    ki_N_per_mm_s: Vec3
    max_error_integral_mm_s: Vec3


@dataclass(frozen=True)
class SimSettings:
    """MuJoCo settings: the MJCF (absolute path), the physics timestep [s], the joint
    positions [mm] at which the work origin lies, and the transmission's backlash per axis [mm]
    (lost motion between the motor with its encoder and the axis; see controller.transmission)."""

    model: str
    physics_timestep_s: float
    work_origin_joint_mm: Vec3
    backlash_mm: Vec3


@dataclass(frozen=True)
class MachineConfig:
    """A whole machine file, validated. ``source`` names the file(s) it was read from."""

    limits: Limits
    travel: Travel
    segmentation: Segmentation
    servo: Servo
    sim: SimSettings
    source: str = field(default="")
    path: PathSettings = field(default_factory=PathSettings)

    def with_changes(self, section: str, **values: Any) -> MachineConfig:
        """A copy with some keys of one section replaced (values are validated)."""
        from dataclasses import replace

        checked = {k: _check(section, k, v, self.source) for k, v in values.items()}
        return replace(self, **{section: replace(getattr(self, section), **checked)})


def _check(section: str, key: str, value: Any, file: str) -> Any:
    keys = SCHEMA[section]
    if key not in keys:
        raise ConfigError(
            f"unknown key '{key}' in [{section}]; valid keys: {', '.join(keys)}", file=file
        )
    try:
        return keys[key](value)
    except ValueError as exc:
        raise ConfigError(f"[{section}] {key} = {value!r}: must be {exc}", file=file) from None


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError("machine file not found", file=str(path)) from None
    except IsADirectoryError:
        raise ConfigError(
            "machine file is a directory, expected a TOML file", file=str(path)
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", file=str(path)) from None
    except UnicodeDecodeError:
        raise ConfigError("not valid TOML: the file is not UTF-8 text", file=str(path)) from None


def _overlay(merged: dict[str, dict[str, Any]], data: dict[str, Any], path: Path) -> None:
    for section, table in data.items():
        if section not in SCHEMA:
            raise ConfigError(
                f"unknown section [{section}]; valid sections: "
                + ", ".join(f"[{s}]" for s in SCHEMA),
                file=str(path),
            )
        if not isinstance(table, dict):
            raise ConfigError(f"'{section}' must be a table [{section}]", file=str(path))
        for key, value in table.items():
            value = _check(section, key, value, str(path))
            if section == "sim" and key == "model":
                value = str((path.parent / value).resolve())
            merged[section][key] = value


def load_machine_config(defaults: Path, override: Path | None = None) -> MachineConfig:
    """Read the bundled defaults, lay ``override`` (a user's machine file) over them, validate.

    Args:
        defaults: the complete machine file (every key set), e.g. models/gantry.toml.
        override: a machine file of the same format; keys it omits keep the defaults.

    Raises:
        ConfigError: unreadable file, unknown section/key, invalid value, or a missing key
            in ``defaults``; the message names the key and what is allowed.
    """
    merged: dict[str, dict[str, Any]] = {s: {} for s in SCHEMA}
    _overlay(merged, _read_toml(defaults), defaults)
    for section, keys in SCHEMA.items():
        for key in keys:
            if section == "path":  # optional: PathSettings' defaults
                merged[section].setdefault(key, getattr(PathSettings(), key))
            if key not in merged[section]:
                raise ConfigError(f"missing key '{key}' in [{section}]", file=str(defaults))
    source = str(defaults)
    if override is not None:
        _overlay(merged, _read_toml(override), override)
        source = str(override)
    travel = merged["travel"]
    for axis, lo, hi in zip("xyz", travel["min_mm"], travel["max_mm"], strict=True):
        if lo >= hi:
            raise ConfigError(
                f"[travel] {axis}: min_mm ({lo}) must be below max_mm ({hi})", file=source
            )
    sim = merged["sim"]
    if sim["physics_timestep_s"] > merged["servo"]["period_s"]:
        raise ConfigError(
            "[sim] physics_timestep_s must not exceed [servo] period_s "
            f"({sim['physics_timestep_s']} > {merged['servo']['period_s']})",
            file=source,
        )
    ratio = merged["servo"]["period_s"] / sim["physics_timestep_s"]
    if abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise ConfigError(
            "[servo] period_s must be an integer multiple of [sim] physics_timestep_s "
            f"({merged['servo']['period_s']} / {sim['physics_timestep_s']} = {ratio:g})",
            file=source,
        )
    return MachineConfig(
        limits=Limits(**merged["limits"]),
        travel=Travel(**merged["travel"]),
        segmentation=Segmentation(**merged["segmentation"]),
        servo=Servo(**merged["servo"]),
        sim=SimSettings(**merged["sim"]),
        source=source,
        path=PathSettings(**merged["path"]),
    )
