"""A LinuxCNC configuration (INI) -> machine-file values.

Read: [EMCMOT] SERVO_PERIOD [ns]; [TRAJ] LINEAR_UNITS (mm/metric or inch/in/imperial),
COORDINATES, MAX_LINEAR_VELOCITY, MAX_LINEAR_ACCELERATION (2.7: MAX_VELOCITY, MAX_ACCELERATION),
PLANNER_TYPE, MAX_LINEAR_JERK; [KINS] KINEMATICS (``coordinates=``) and JOINTS; per axis
[AXIS_X] (2.8+) with MAX_VELOCITY, MAX_ACCELERATION, MIN_LIMIT, MAX_LIMIT, OFFSET_AV_RATIO,
MAX_JERK, and per joint [JOINT_n] (2.8+) or [AXIS_n] (2.7 and older) with the same keys and the
PID parameters P, I, D, FF0, FF1, FF2, FERROR, MAXERROR_I, BIAS, DEADBAND, MAX_OUTPUT, BACKLASH.
Numbers are read as LinuxCNC reads them (ini_reader), and each is checked against the machine
file's key it becomes where it is read (ini_numbers: a ``FILE:LINE: error:`` at the INI key).

Mapping (units: LINEAR_UNITS -> mm; times in s):
  * velocity/acceleration limits: the axis section's, else its first joint's, times
    (1 - OFFSET_AV_RATIO) (the share LinuxCNC keeps for external offsets), capped by [TRAJ]
    MAX_LINEAR_* (a per-axis cap of a vector limit: said in the notes when it binds);
  * jerk limits: with [TRAJ] PLANNER_TYPE = 1 (2.10's S-curve planner) each axis' MAX_JERK
    capped by MAX_LINEAR_JERK; otherwise LinuxCNC plans with no jerk limit, and the bundled
    jerk limits are kept and said so;
  * travel MIN_LIMIT..MAX_LIMIT (machine coordinates, taken as work coordinates), placed in the
    model's joint range and made to hold 0, where the machine starts (common.fit_travel);
  * the PID as a velocity-mode loop: P is the position-loop gain Kv [1/s], converted to force
    gains through the axis' moving mass (controller.machine_import.gains: kp = m (1.4 P)^2,
    kd = 1.4^2 m P (1 + D), ki = kd I / (1 + D), ff_acceleration = kd FF2 / (m (1 + D)));
    FF1 must be 1 (gantry-sim's derivative acts on the error: the reference velocity is always
    fed forward), FF0, BIAS, DEADBAND, MAX_OUTPUT have no counterpart;
  * MAXERROR_I -> max_error_integral_mm_s; the smallest FERROR of every joint (a gantry's
    second joint too; 0, a simulated machine's, is left out) -> max_following_error_mm;
  * SERVO_PERIOD -> [servo] period_s (and [sim] physics_timestep_s = period / 2 when the
    bundled 0.5 ms does not divide it);
  * [EMCIO] TOOL_TABLE -> [tools], [RS274NGC] PARAMETER_FILE -> [work] (without the G92 offset
    where DISABLE_G92_PERSISTENCE is set) (controller.machine_import.work_files);
    RS274NGC_STARTUP_CODE is listed as not mapped.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.machine_import.common import (
    AXES,
    Imported,
    Target,
    fit_travel,
    outside_travel,
)
from gantry_sim.controller.machine_import.gains import ZETA, force_gains
from gantry_sim.controller.machine_import.ini_limits import (
    ACC,
    HI,
    LO,
    VEL,
    av_ratio,
    capped,
    ferror_mm,
    jerk_reading,
    traj_caps,
)
from gantry_sim.controller.machine_import.ini_numbers import number_as, require
from gantry_sim.controller.machine_import.ini_reader import IniFile, parse_ini, read_ini
from gantry_sim.controller.machine_import.work_files import import_tools, import_work

UNITS_MM = {"mm": 1.0, "metric": 1.0, "inch": 25.4, "in": 25.4, "imperial": 25.4}
BUNDLED_TIMESTEP_S = 0.0005
#: joint keys with no counterpart, and why (listed only when set to something that matters)
_UNMAPPED = {
    "FF0": "position feedforward of a velocity command: no meaning in a force loop",
    "BIAS": "constant output offset (gantry-sim compensates gravity with [servo] ff_gravity)",
    "DEADBAND": "pid error deadband: gantry-sim's servo has none",
    "MAX_OUTPUT": "velocity-command limit of the pid: gantry-sim limits force (MJCF forcerange)",
    "BACKLASH": "backlash compensation of the controller: gantry-sim does not compensate; the "
    "machine's play is [sim] backlash_mm, left at the bundled value",
    "MIN_FERROR": "following-error limit at zero speed: gantry-sim has one limit "
    "([servo] max_following_error_mm)",
    "MAX_ERROR": "pid maxerror (limit on the error P sees): not modelled",
}


def _mm_per_unit(text: str, file: str, line: int) -> float:
    """[TRAJ] LINEAR_UNITS -> mm per machine unit: a name (mm, metric, inch, in, imperial) or,
    in older configurations, a number of machine units per mm (1.0 = mm, 0.03937 = inch)."""
    if text.lower() in UNITS_MM:
        return UNITS_MM[text.lower()]
    try:
        per_mm = float(text)
    except ValueError:
        per_mm = math.nan
    if not (math.isfinite(per_mm) and per_mm > 0):
        raise ConfigError(
            f"[TRAJ] LINEAR_UNITS = {shown(text)}: expected one of {', '.join(UNITS_MM)} or units per mm",
            file=file,
            line=line,
        )
    return 1.0 / per_mm


def _coordinates(ini: IniFile) -> str:
    """Axis letter of each joint, e.g. "XYZ" or "XYYZ" (trivkins' joint order)."""
    kins = ini.get("KINS", "KINEMATICS")
    if kins and (m := re.search(r"coordinates=([A-Za-z]+)", kins[0])):
        return m.group(1).upper()
    coords = ini.get("TRAJ", "COORDINATES")
    if coords:
        return re.sub(r"[^A-Za-z]", "", coords[0]).upper()
    return "XYZ"


def _joint_section(ini: IniFile, joint: int) -> str | None:
    for name in (f"JOINT_{joint}", f"AXIS_{joint}"):
        if name in ini.sections:
            return name
    return None


def import_linuxcnc(path: Path, target: Target) -> Imported:
    """Read a LinuxCNC INI and map what the machine file can express (module doc).

    Raises:
        ConfigError: unreadable file, a malformed line or a non-numeric value that is needed,
            or a number the machine file cannot hold (``FILE:LINE: error:`` at the INI key),
            unknown LINEAR_UNITS, or no X/Y/Z axis at all.
    """
    ini = parse_ini(read_ini(path), str(path))
    assumed: list[str] = []
    unmapped: dict[str, list[str]] = {}
    units_entry = ini.get("TRAJ", "LINEAR_UNITS")
    scale = 1.0
    if units_entry is not None:
        scale = _mm_per_unit(*units_entry)
    else:
        assumed.append("[TRAJ] LINEAR_UNITS not set: taken as mm")
    for name, (text, file, line) in ini.bad.items():
        assumed.append(
            f"{file}:{line}: [{name}] {shown(text)} is not KEY = VALUE: skipped (as LinuxCNC does)"
        )
    coords = _coordinates(ini)
    caps = traj_caps(ini, scale, assumed)
    jerk = jerk_reading(ini, scale, assumed)

    limits: dict[str, list[float | None]] = {"v": [], "a": [], "lo": [], "hi": [], "j": []}
    pid: list[tuple[str, dict[str, float]] | None] = []
    ferror: list[float] = []
    found = []
    for axis in AXES:
        letter = axis.upper()
        joints = [j for j, c in enumerate(coords) if c == letter]
        jsecs = [s for s in (_joint_section(ini, j) for j in joints) if s is not None]
        jsec = _joint_section(ini, joints[0]) if joints else None
        asec = f"AXIS_{letter}" if f"AXIS_{letter}" in ini.sections else None
        if len(joints) > 1:
            assumed.append(
                f"{letter} is driven by joints {joints} (a gantry): joint {joints[0]}'s PID "
                "used, the smallest FERROR of them"
            )

        def value(
            key: str, dest: tuple[str, str], asec: str | None = asec, jsec: str | None = jsec
        ) -> float | None:
            for sec in (asec, jsec):  # 0 or less: a limit not set (_vector says so)
                if (
                    v := number_as(
                        ini,
                        sec,
                        key,
                        scale,
                        dest,
                        unchecked_below_zero=dest[0] == "limits",
                        finite_only=dest[0] == "travel",  # fit_travel shortens it
                    )
                ) is not None:
                    return v
            return None

        found.append(asec is not None or jsec is not None)
        v, a = value("MAX_VELOCITY", VEL), value("MAX_ACCELERATION", ACC)
        ratio = av_ratio(ini, asec, assumed)
        if ratio:
            v, a = (None if x is None else (1.0 - ratio) * x for x in (v, a))
        limits["v"].append(capped(ini, v, caps[0], letter, "MAX_VELOCITY", assumed))
        limits["a"].append(capped(ini, a, caps[1], letter, "MAX_ACCELERATION", assumed))
        limits["lo"].append(value("MIN_LIMIT", LO))
        limits["hi"].append(value("MAX_LIMIT", HI))
        limits["j"].append(jerk(asec))
        for sec in jsecs:
            ferror += ferror_mm(ini, sec, scale, assumed)
        if jsec is None:
            pid.append(None)
            continue
        gains = {k: ini.number(jsec, k) for k in ("P", "I", "D", "FF0", "FF1", "FF2", "MAXERROR_I")}
        pid.append((jsec, {k: v for k, v in gains.items() if v is not None}))
        for key, why in _UNMAPPED.items():
            raw = ini.number(jsec, key)
            if raw is not None and raw != 0.0:
                unmapped.setdefault(f"{key} ({why})", []).append(f"{jsec} = {raw:g}")
        ff1 = gains["FF1"]
        if ff1 is not None and ff1 != 1.0:
            unmapped.setdefault(
                "FF1 (gantry-sim's derivative acts on the error, which feeds the reference "
                "velocity forward fully: FF1 = 1)",
                [],
            ).append(f"{jsec} = {ff1:g}")
    if not any(found):
        raise ConfigError(
            "no [AXIS_X/Y/Z], [JOINT_n] or [AXIS_n] section: not a LinuxCNC machine configuration",
            file=str(path),
        )
    return _assemble(ini, path, target, scale, limits, pid, ferror, assumed, unmapped)


def _vector(values: list[float | None], key: str, what: str, assumed: list[str]) -> list | None:
    """A 3-vector for the machine file, None if no axis sets it; axes that do not set it keep
    the bundled value -- which a vector key cannot express, so the missing ones are said."""
    if all(v is None for v in values):
        return None
    missing = [a.upper() for a, v in zip(AXES, values, strict=True) if v is None or v <= 0]
    if missing:
        assumed.append(f"{what} not set for {', '.join(missing)}: {key} not written")
        return None
    return [float(v) for v in values]  # type: ignore[arg-type]


def _assemble(ini, path, target, scale, limits, pid, ferror, assumed, unmapped) -> Imported:
    values: dict[str, dict] = {"limits": {}, "travel": {}, "servo": {}, "sim": {}}
    if (v := _vector(limits["v"], "max_velocity_mm_per_s", "MAX_VELOCITY", assumed)) is not None:
        values["limits"]["max_velocity_mm_per_s"] = v
    if (
        a := _vector(limits["a"], "max_acceleration_mm_per_s2", "MAX_ACCELERATION", assumed)
    ) is not None:
        values["limits"]["max_acceleration_mm_per_s2"] = a
    if all(x is not None for x in limits["lo"] + limits["hi"]):
        lo, hi, origin = fit_travel(limits["lo"], limits["hi"], target, assumed)
        values["travel"] = {"min_mm": lo, "max_mm": hi}
        values["sim"]["work_origin_joint_mm"] = origin
    elif any(x is not None for x in limits["lo"] + limits["hi"]):
        assumed.append("MIN_LIMIT/MAX_LIMIT not set on every axis: [travel] not written")
    if (j := _vector(limits["j"], "max_jerk_mm_per_s3", "MAX_JERK", assumed)) is not None:
        values["limits"]["max_jerk_mm_per_s3"] = j
    period_s = number_as(ini, "EMCMOT", "SERVO_PERIOD", 1e-9, ("servo", "period_s"), False)
    if period_s is not None:
        values["servo"]["period_s"] = period_s
        ratio = period_s / BUNDLED_TIMESTEP_S
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            step = ("sim", "physics_timestep_s")
            values["sim"]["physics_timestep_s"] = require(
                ini, "EMCMOT", "SERVO_PERIOD", period_s / 2, step, vector=False
            )
            assumed.append(
                f"SERVO_PERIOD {period_s * 1e9:g} ns is not a multiple of the bundled 0.5 ms "
                f"physics step: [sim] physics_timestep_s = {period_s / 2:g} s (two steps per tick)"
            )
    _map_pid(ini, pid, target, scale, values, assumed)
    if ferror:
        values["servo"]["max_following_error_mm"] = min(ferror)
        if len(set(ferror)) > 1:
            assumed.append(
                f"FERROR differs per joint ({', '.join(f'{f:g}' for f in ferror)} mm): gantry-sim "
                "has one limit, the smallest is used"
            )
    notes = [f"{what}: {', '.join(where)}" for what, where in unmapped.items()]
    if (name := ini.get("EMCIO", "TOOL_TABLE")) is not None:
        if tools := import_tools(Path(path), name[0], scale, assumed, notes):
            values["tools"] = tools
    if (name := ini.get("RS274NGC", "PARAMETER_FILE")) is not None:
        keep_g92 = not ini.number("RS274NGC", "DISABLE_G92_PERSISTENCE")
        if work := import_work(Path(path), name[0], scale, assumed, notes, keep_g92):
            values["work"] = work
            if "min_mm" in values["travel"]:
                outside_travel(
                    work, values["travel"]["min_mm"], values["travel"]["max_mm"], assumed
                )
    if (startup := ini.get("RS274NGC", "RS274NGC_STARTUP_CODE")) is not None:
        notes.append(
            f"[RS274NGC] RS274NGC_STARTUP_CODE = {shown(startup[0])} (the codes LinuxCNC runs "
            "before every program: put them at the program's start)"
        )
    assumed += ini.notes  # complete now: every number has been read
    return Imported(
        source=str(path),
        kind="LinuxCNC INI",
        values={s: kv for s, kv in values.items() if kv},
        assumed=tuple(assumed),
        not_mapped=tuple(notes),
    )


def _map_pid(
    ini: IniFile,
    pid: list[tuple[str, dict[str, float]] | None],
    target: Target,
    scale: float,
    values: dict,
    assumed: list[str],
) -> None:
    if all(p is not None and "P" in p[1] for p in pid) and not all(
        p is not None and p[1]["P"] > 0 for p in pid
    ):
        assumed.append("P <= 0 on some axis (no position loop): [servo] gains not written")
        return
    if not all(p is not None and "P" in p[1] for p in pid):
        if any(p is not None and "P" in p[1] for p in pid):
            assumed.append("P not set on every axis: [servo] gains not written (bundled kept)")
        else:
            assumed.append("no PID P gains: [servo] gains not written (bundled kept)")
        return
    joints = [p for p in pid if p is not None]
    servo = values["servo"]
    for key in ("kp_N_per_mm", "kd_N_s_per_mm", "ff_acceleration", "ki_N_per_mm_s"):
        servo[key] = []
    for (sec, p), m in zip(joints, target.mass_kg, strict=True):
        g = force_gains(p["P"], p.get("I", 0.0), p.get("D", 0.0), p.get("FF2", 0.0), m)
        for key, made, source in (
            ("kp_N_per_mm", g.kp_N_per_mm, "P"),
            ("kd_N_s_per_mm", g.kd_N_s_per_mm, "D" if "D" in p else "P"),
            ("ff_acceleration", g.ff_acceleration, "FF2"),
            ("ki_N_per_mm_s", g.ki_N_per_mm_s, "I"),
        ):
            servo[key].append(require(ini, sec, source, made, ("servo", key)))
    if not any(servo["ki_N_per_mm_s"]):
        del servo["ki_N_per_mm_s"]
    if all("MAXERROR_I" in p for _, p in joints):
        integral = ("servo", "max_error_integral_mm_s")
        servo[integral[1]] = [
            require(ini, sec, "MAXERROR_I", p["MAXERROR_I"] * scale, integral) for sec, p in joints
        ]
    ps = ", ".join(f"{a.upper()} {p['P']:g}" for a, (_, p) in zip(AXES, joints, strict=True))
    assumed.append(
        f"PID P ({ps} 1/s) is the position-loop gain Kv of a velocity-mode drive; the drive's "
        f"velocity-loop gain is not in the INI and is chosen for damping ratio {ZETA} on the "
        "model's moving mass m: kp = m (2 zeta P)^2, kd = kp / P * (1 + D), ki = kd I / (1 + D), "
        "ff_acceleration = kd FF2 / (m (1 + D)) (controller/machine_import/gains.py)"
    )
