"""Numbers of a LinuxCNC INI checked against the machine-file key they become, where they are
read: a value the machine file cannot hold (``MAX_VELOCITY = 1e99`` in inches, ``P = 1e200``)
is a ``FILE:LINE: error:`` naming the INI key, not a bad machine file without a line.

Units: ``factor`` converts the INI's number to the machine file's unit (mm per machine unit for
lengths, 1e-9 for SERVO_PERIOD's ns); the result is in the machine file's unit.
"""

from __future__ import annotations

import math

from gantry_sim.controller.config import value_fault, value_top
from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.machine_import.ini_reader import IniFile


def require(
    ini: IniFile, section: str, key: str, value: float, dest: tuple[str, str], vector: bool = True
) -> float:
    """``value``, made from ``[section] key`` of ``ini``, if the machine file's ``dest``
    (section, key; a per-axis ``vector`` key or not) may hold it; else a ConfigError at the INI
    key's line."""
    fault = value_fault(dest[0], dest[1], value, vector)
    if fault is None:
        return value
    entry = ini.get(section, key)
    text, file, line = entry if entry is not None else ("", ini.path, None)
    raise ConfigError(
        f"[{section}] {key} = {shown(text)} gives [{dest[0]}] {dest[1]} = {value:g}, which "
        f"must be {fault}",
        file=file,
        line=line,
    )


def number_as(
    ini: IniFile,
    section: str | None,
    key: str,
    factor: float,
    dest: tuple[str, str],
    vector: bool = True,
    unchecked_below_zero: bool = False,
    finite_only: bool = False,
) -> float | None:
    """``[section] key`` times ``factor``, checked as :func:`require` does; None when the key
    (or the section) is absent. ``unchecked_below_zero``: a value <= 0 is returned as it is,
    for the caller's own rule (a velocity limit of 0: that axis' limits are not written);
    ``finite_only``: any finite value is returned, for a caller that fits it to the range
    itself (soft limits of +-1e10 meaning none, shortened to the model's travel)."""
    if section is None or (raw := ini.number(section, key)) is None:
        return None
    value = raw * factor
    if (unchecked_below_zero and raw <= 0.0) or (finite_only and math.isfinite(value)):
        return value
    if dest[0] == "limits" and value > (top := value_top(*dest)):
        # LinuxCNC's idiom for "no limit" (1e99 is its own default of MAX_LINEAR_VELOCITY)
        ini.note(
            f"[{section}] {key} = {raw:g} read as no limit: [{dest[0]}] {dest[1]} = {top:g}, the "
            "largest the machine file holds"
        )
        return top
    return require(ini, section, key, value, dest, vector)
