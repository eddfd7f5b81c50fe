"""The per-axis limits of a LinuxCNC INI as LinuxCNC's planner has them: [TRAJ]'s maxima (2.7's
names too), the share of [AXIS_L] OFFSET_AV_RATIO left to the planner, jerk where the S-curve
planner reads it, and the joints' following-error limits. Units: mm, s (the INI's lengths times
``scale``, mm per machine unit).
"""

from __future__ import annotations

from collections.abc import Callable

from gantry_sim.controller.machine_import.ini_numbers import number_as, require
from gantry_sim.controller.machine_import.ini_reader import IniFile

#: machine-file keys the per-axis numbers become
VEL, ACC = ("limits", "max_velocity_mm_per_s"), ("limits", "max_acceleration_mm_per_s2")
JERK = ("limits", "max_jerk_mm_per_s3")
LO, HI = ("travel", "min_mm"), ("travel", "max_mm")
FERROR = ("servo", "max_following_error_mm")
#: LinuxCNC's bounds of [AXIS_L] OFFSET_AV_RATIO, and what it uses outside them (iniaxis.cc)
AV_RATIO_MAX, AV_RATIO_REPLACED = 0.9, 0.1


#: a [TRAJ] cap [mm/s or mm/s^2] and the key it was read from (None, "": not set)
Cap = tuple[float | None, str]


def traj_caps(ini: IniFile, scale: float, assumed: list[str]) -> tuple[Cap, Cap]:
    """[TRAJ] MAX_LINEAR_VELOCITY and MAX_LINEAR_ACCELERATION [mm/s, mm/s^2], or in a LinuxCNC
    2.7 configuration (joints as [AXIS_n], no [JOINT_n]) its [TRAJ] MAX_VELOCITY and
    MAX_ACCELERATION, which 2.8 renamed so (update_ini.py); None where not set. A cap is not
    held to the machine file's ranges (configurations write 4000 in/s for "no cap"): only the
    axis limits it lowers are (:func:`capped`'s callers check those)."""
    old = not any(s.startswith("JOINT_") for s in ini.sections)
    out: list[Cap] = []
    for new_key, old_key in (
        ("MAX_LINEAR_VELOCITY", "MAX_VELOCITY"),
        ("MAX_LINEAR_ACCELERATION", "MAX_ACCELERATION"),
    ):
        key, cap = new_key, ini.number("TRAJ", new_key)
        if cap is None and old and (cap := ini.number("TRAJ", old_key)) is not None:
            key = old_key
            assumed.append(
                f"[TRAJ] {old_key} read as {new_key} (a LinuxCNC 2.7 configuration: 2.8 renamed it)"
            )
        out.append((None if cap is None else cap * scale, key))
    return out[0], out[1]


def capped(
    ini: IniFile, value: float | None, cap: Cap, letter: str, key: str, assumed: list[str]
) -> float | None:
    """``value`` [mm/s or mm/s^2] no higher than the [TRAJ] ``cap`` (said when it binds; the
    cap is then held to the machine file's range, at its [TRAJ] line)."""
    limit, traj_key = cap
    if value is None or limit is None or limit >= value:
        return value
    if limit > 0.0:
        require(ini, "TRAJ", traj_key, limit, VEL if "VELOCITY" in key else ACC)
    unit = "mm/s" if "VELOCITY" in key else "mm/s^2"
    assumed.append(f"{letter}: {key} {value:g} {unit} capped by [TRAJ]'s {limit:g} {unit}")
    return limit


def av_ratio(ini: IniFile, asec: str | None, assumed: list[str]) -> float:
    """[AXIS_L] OFFSET_AV_RATIO: the share of the axis' velocity and acceleration LinuxCNC
    keeps for external offsets, so its planner has (1 - ratio) of them (iniaxis.cc); outside
    0..0.9 LinuxCNC uses 0.1."""
    if asec is None or (ratio := ini.number(asec, "OFFSET_AV_RATIO")) is None or ratio == 0.0:
        return 0.0
    if not 0.0 <= ratio <= AV_RATIO_MAX:
        assumed.append(
            f"[{asec}] OFFSET_AV_RATIO {ratio:g} is outside 0..{AV_RATIO_MAX:g}: "
            f"{AV_RATIO_REPLACED:g} used, as LinuxCNC does"
        )
        ratio = AV_RATIO_REPLACED
    assumed.append(
        f"[{asec}] OFFSET_AV_RATIO {ratio:g}: the planner has {1 - ratio:g} of MAX_VELOCITY and "
        "MAX_ACCELERATION (the rest is kept for external offsets, which gantry-sim does not run)"
    )
    return ratio


def jerk_reading(
    ini: IniFile, scale: float, assumed: list[str]
) -> Callable[[str | None], float | None]:
    """A reader of each axis' jerk limit [mm/s^3] (``[AXIS_L] MAX_JERK``, no higher than
    ``[TRAJ] MAX_LINEAR_JERK``) where ``[TRAJ] PLANNER_TYPE = 1`` (LinuxCNC 2.10's S-curve
    planner); else one that gives None, with a note: LinuxCNC 2.9's planner, and 2.10's type 0,
    are trapezoidal (no jerk limit), so the bundled jerk limits stay."""
    planner = ini.number("TRAJ", "PLANNER_TYPE")
    if planner != 1.0:
        set_ = [s for s in ini.sections if ini.get(s, "MAX_JERK") is not None]
        set_ += ["TRAJ"] if ini.get("TRAJ", "MAX_LINEAR_JERK") is not None else []
        assumed.append(
            "no jerk limit in LinuxCNC's trapezoidal planner"
            + (
                f" (MAX_JERK/MAX_LINEAR_JERK in {', '.join(set_)} are read only with [TRAJ] "
                "PLANNER_TYPE = 1)"
                if set_
                else ""
            )
            + ": [limits] max_jerk_mm_per_s3 keeps the bundled values"
        )
        return lambda asec: None
    raw_cap = ini.number("TRAJ", "MAX_LINEAR_JERK")  # checked where it is an axis' limit
    cap = None if raw_cap is None else raw_cap * scale
    assumed.append(
        "[TRAJ] PLANNER_TYPE = 1 (S-curve): [AXIS_L] MAX_JERK, capped by [TRAJ] MAX_LINEAR_JERK "
        "-> [limits] max_jerk_mm_per_s3"
    )

    def axis_jerk(asec: str | None) -> float | None:
        own = number_as(ini, asec, "MAX_JERK", scale, JERK, unchecked_below_zero=True)
        if own is not None and own > 0.0 and (cap is None or own <= cap):
            return own
        if cap is None:  # LinuxCNC's default MAX_JERK 0: the axis sets none
            return None
        return require(ini, "TRAJ", "MAX_LINEAR_JERK", cap, JERK)

    return axis_jerk


def ferror_mm(ini: IniFile, sec: str, scale: float, assumed: list[str]) -> list[float]:
    """[sec] FERROR [mm] as a list (empty where not set); 0, which only a simulated machine
    with perfect feedback runs with, is left out and said."""
    raw = ini.number(sec, "FERROR")
    if raw is None:
        return []
    if raw == 0.0:
        assumed.append(f"[{sec}] FERROR = 0 (no following error allowed: a simulated machine's)")
        return []
    return [require(ini, sec, "FERROR", raw * scale, FERROR, vector=False)]
