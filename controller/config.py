"""Machine files: per-axis limits, travel, segmentation, servo and simulation settings.

A machine file is TOML with the sections and keys of the bundled ``models/gantry.toml`` (which
documents each one). A user's file is laid over the bundled defaults: keys it omits keep the
defaults, unknown sections or keys are errors that list the valid ones, and every value is checked
(type, length, sign) with an error naming the key. Units are in the key names.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.input_files import CONFIG_CAP_BYTES, read_capped
from gantry_sim.controller.machine_work import NO_WORK, WORK_SECTIONS, WorkSetup, take_work_sections
from gantry_sim.controller.planes import Vec3

# --- value checkers: each returns the cleaned value or raises ValueError(what is allowed) ---------
# Every number also has a range that makes physical sense for a machine tool (and keeps the
# planner's and MuJoCo's arithmetic in range): a value outside it is refused with the range in
# the message, instead of overflowing or stalling later.


def _as_float(v: Any) -> float | None:
    """``v`` as a finite float, or None (bool, non-number, NaN, inf, or an integer beyond the
    float range such as a 400-digit TOML integer)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        f = float(v)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


def _number(
    sign: str, lo: float = -math.inf, hi: float = math.inf, unit: str = ""
) -> Callable[[Any], float]:
    """A checker for a number in [lo, hi] (``sign``: "> 0", ">= 0" or "" says the basic rule;
    no range given: any finite number keeping the sign)."""
    basic = f"a finite number {sign}".strip()
    unit_text = f" {unit}" if unit else ""
    bounded = math.isfinite(lo) or math.isfinite(hi)
    what = f"{basic} within {lo:g}..{hi:g}{unit_text}" if bounded else basic

    def check(v: Any) -> float:
        f = _as_float(v)
        ok_sign = f is not None and (f > 0 if sign == "> 0" else f >= 0 if sign == ">= 0" else True)
        if f is None or not ok_sign or not lo <= f <= hi:
            raise ValueError(what)
        return f

    check.what = what  # type: ignore[attr-defined]
    check.top = hi  # type: ignore[attr-defined]
    return check


def _vec3(item: Callable[[Any], float], what: str | None = None) -> Callable[[Any], Vec3]:
    if what is None:
        what = getattr(item, "what", "a finite number").removeprefix("a finite number ")
    text = f"a list of 3 numbers [x, y, z], each {what}"
    top = getattr(item, "top", math.inf)

    def check(v: Any) -> Vec3:
        if not isinstance(v, list) or len(v) != 3:
            raise ValueError(text)
        try:
            return tuple(item(c) for c in v)  # type: ignore[return-value]
        except ValueError:
            raise ValueError(text) from None

    check.top = top  # type: ignore[attr-defined]
    return check


def _choice(*options: str) -> Callable[[Any], str]:
    def check(v: Any) -> str:
        if v not in options:
            raise ValueError("one of " + ", ".join(repr(o) for o in options))
        return v

    return check


def _path_string(v: Any) -> str:
    """A file path: a non-empty string without NUL characters (no file name holds one)."""
    if not isinstance(v, str) or not v or "\0" in v:
        raise ValueError("a non-empty file path without NUL characters")
    return v


# Unbounded checkers, kept for keys that have no range yet; a new number should get one
# (``_number``), so that a value such as 1e308 is refused with the range, not crashed on.
_positive = _number("> 0")
_non_negative = _number(">= 0")
_finite = _number("")
_POS3 = _vec3(_positive, "> 0")
_NONNEG3 = _vec3(_non_negative, ">= 0")
_FIN3 = _vec3(_finite, "finite")

#: coordinates and lengths of travel: up to 100 m either way [mm]
_COORD = _number("", -1e5, 1e5, "mm")
#: feedforward fractions of the plant model (0 off, 1 the model, up to 2 over-compensation)
_FRACTION = _number(">= 0", 0.0, 2.0, "")

#: section -> key -> checker. The bundled models/gantry.toml sets every key.
SCHEMA: dict[str, dict[str, Callable[[Any], Any]]] = {
    "limits": {
        # 0.6 mm/min .. 6000 m/min; 0.001 .. 1000 m/s^2 (about 100 g); up to 1e6 m/s^3
        "max_velocity_mm_per_s": _vec3(_number("> 0", 0.01, 1e5, "mm/s")),
        "max_acceleration_mm_per_s2": _vec3(_number("> 0", 1.0, 1e6, "mm/s^2")),
        "max_jerk_mm_per_s3": _vec3(_number("> 0", 1.0, 1e9, "mm/s^3")),
    },
    "travel": {"min_mm": _vec3(_COORD), "max_mm": _vec3(_COORD)},
    "segmentation": {
        "method": _choice("chord", "fixed"),
        "chord_tolerance_mm": _number("> 0", 1e-6, 10.0, "mm"),
        "segment_length_mm": _number("> 0", 1e-3, 1e3, "mm"),
    },
    "path": {
        "mode": _choice("G64", "G61", "G61.1"),
        "tolerance_mm": _number("> 0", 1e-6, 10.0, "mm"),
        "naive_cam_tolerance_mm": _number(">= 0", 0.0, 10.0, "mm"),
        "short_moves": _choice("fit", "blend"),
    },
    "servo": {
        # 10 us .. 100 ms (a drive's current loop .. a slow PLC)
        "period_s": _number("> 0", 1e-5, 0.1, "s"),
        "kp_N_per_mm": _vec3(_number("> 0", 1e-3, 1e7, "N/mm")),
        "kd_N_s_per_mm": _vec3(_number(">= 0", 0.0, 1e6, "N s/mm")),
        "ff_velocity": _vec3(_FRACTION),
        "ff_acceleration": _vec3(_FRACTION),
        "ff_friction": _vec3(_FRACTION),
        "ff_gravity": _FRACTION,
        "max_following_error_mm": _number("> 0", 1e-4, 1e3, "mm"),
        "ki_N_per_mm_s": _vec3(_number(">= 0", 0.0, 1e9, "N/(mm s)")),
        "max_error_integral_mm_s": _vec3(_number(">= 0 (0: no clamp)", 0.0, 1e6, "mm s")),
    },
    "sim": {
        "model": _path_string,
        # 1 us .. 10 ms
        "physics_timestep_s": _number("> 0", 1e-6, 1e-2, "s"),
        "work_origin_joint_mm": _vec3(_COORD),
        "backlash_mm": _vec3(_number(">= 0", 0.0, 10.0, "mm")),
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
    short_moves: in G64, runs of short straight moves are followed on one curve of continuous
    curvature fitted within the tolerance ("fit", controller/planner/polyline_fit.py) or
    blended corner by corner as LinuxCNC blends them ("blend").

    The default, G64 with 0.01 mm: LinuxCNC starts in G64, and grbl's default junction deviation
    ($11) is 0.01 mm, which is the same corner-to-circle distance as a 0.01 mm blend tolerance.
    """

    mode: str = "G64"
    tolerance_mm: float = 0.01
    naive_cam_tolerance_mm: float = 0.0
    short_moves: str = "fit"


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
    """A whole machine file, validated. ``source`` names the file(s) it was read from; ``work``
    holds its [tools] and [work] sections (controller/machine_work.py); ``user_sections`` the
    sections the user's file (or :meth:`with_changes`) set, so defaults that depend on the
    dialect apply only where the user chose nothing."""

    limits: Limits
    travel: Travel
    segmentation: Segmentation
    servo: Servo
    sim: SimSettings
    source: str = field(default="")
    work: WorkSetup = field(default=NO_WORK)
    user_sections: tuple[str, ...] = ()
    path: PathSettings = field(default_factory=PathSettings)

    def with_changes(self, section: str, **values: Any) -> MachineConfig:
        """A copy with some keys of one section replaced (values are validated)."""
        from dataclasses import replace

        checked = {k: _check(section, k, v, self.source) for k, v in values.items()}
        return replace(
            self,
            **{section: replace(getattr(self, section), **checked)},
            user_sections=tuple(sorted({*self.user_sections, section})),
        )


def _check(section: str, key: str, value: Any, file: str) -> Any:
    keys = SCHEMA[section]
    if key not in keys:
        raise ConfigError(
            f"unknown key '{key}' in [{section}]; valid keys: {', '.join(keys)}", file=file
        )
    try:
        return keys[key](value)
    except ValueError as exc:
        raise ConfigError(f"[{section}] {key} = {shown(value)}: must be {exc}", file=file) from None


def _read_toml(path: Path) -> dict[str, Any]:
    data = read_capped(Path(path), "machine file", CONFIG_CAP_BYTES)
    try:
        return tomllib.loads(data.decode("utf-8-sig"))
    except RecursionError:  # arrays or inline tables nested a thousand deep
        raise ConfigError(
            "not valid TOML: arrays or tables nested too deep for the reader", file=str(path)
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", file=str(path)) from None
    except UnicodeDecodeError:
        raise ConfigError("not valid TOML: the file is not UTF-8 text", file=str(path)) from None


def value_fault(section: str, key: str, value: float, vector: bool) -> str | None:
    """What ``[section] key`` allows, where ``value`` may not be its value (a vector key's, on
    any axis); None where it may. For importers, which check each number where they read it."""
    try:
        SCHEMA[section][key]([value] * 3 if vector else value)
    except ValueError as exc:
        return str(exc).replace("a list of 3 numbers [x, y, z], each ", "a finite number ")
    return None


def value_top(section: str, key: str) -> float:
    """The largest value ``[section] key`` holds (on each axis, for a vector key); inf where
    its range has no top."""
    return float(getattr(SCHEMA[section][key], "top", math.inf))


def _overlay(merged: dict[str, dict[str, Any]], data: dict[str, Any], path: Path) -> None:
    for section, table in data.items():
        if section not in SCHEMA:
            raise ConfigError(
                f"unknown section [{section}]; valid sections: "
                + ", ".join(f"[{s}]" for s in (*SCHEMA, *WORK_SECTIONS)),
                file=str(path),
            )
        if not isinstance(table, dict):
            raise ConfigError(f"'{section}' must be a table [{section}]", file=str(path))
        for key, value in table.items():
            value = _check(section, key, value, str(path))
            if section == "sim" and key == "model":
                value = str((path.parent / value).resolve())
            merged[section][key] = value


def load_machine_config(
    defaults: str | os.PathLike[str], override: str | os.PathLike[str] | None = None
) -> MachineConfig:
    """Read the bundled defaults, lay ``override`` (a user's machine file) over them, validate.

    Args:
        defaults: the complete machine file (every key set), e.g. models/gantry.toml (a path
            or a string).
        override: a machine file of the same format; keys it omits keep the defaults.

    Raises:
        ConfigError: unreadable file, unknown section/key, invalid value, or a missing key
            in ``defaults``; the message names the key and what is allowed.
    """
    defaults = Path(defaults)
    override = None if override is None else Path(override)
    merged: dict[str, dict[str, Any]] = {s: {} for s in SCHEMA}
    data = _read_toml(defaults)
    work = take_work_sections(data, str(defaults))
    _overlay(merged, data, defaults)
    for section, keys in SCHEMA.items():
        for key in keys:
            if section == "path":  # optional: PathSettings' defaults
                merged[section].setdefault(key, getattr(PathSettings(), key))
            if key not in merged[section]:
                raise ConfigError(f"missing key '{key}' in [{section}]", file=str(defaults))
    source, user_sections = str(defaults), tuple[str, ...]()
    if override is not None:
        data = _read_toml(override)
        user_sections = tuple(sorted(data))  # sorted: repr() is stable (sweep fingerprints)
        work = take_work_sections(data, str(override), work)
        _overlay(merged, data, override)
        source = str(override)
    travel = merged["travel"]
    for axis, lo, hi in zip("xyz", travel["min_mm"], travel["max_mm"], strict=True):
        if lo >= hi:
            raise ConfigError(
                f"[travel] {axis}: min_mm ({lo}) must be below max_mm ({hi})", file=source
            )
        if not lo <= 0.0 <= hi:  # where every run starts: no program could leave it
            raise ConfigError(
                f"[travel] {axis}: {lo:g}..{hi:g} mm does not hold 0, the work origin, where the "
                "machine starts at rest; min_mm must be <= 0 <= max_mm (the work frame is placed "
                "in the machine by [sim] work_origin_joint_mm)",
                file=source,
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
        work=work,
        user_sections=user_sections,
        path=PathSettings(**merged["path"]),
    )
