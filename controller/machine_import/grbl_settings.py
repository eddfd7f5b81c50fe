"""A grbl ``$$`` settings dump -> machine-file values.

grbl 1.1 prints one ``$N=VALUE`` line per setting (grbl 0.9 adds a ``(description)``), then
``ok``; both forms are read, and so is a console capture that starts with grbl's welcome banner
(``Grbl 1.1h ['$' for help]``, grblHAL's ``GrblHAL 1.1f ['$' or '$HELP' for help]``). Mapped
(grbl's units are mm, mm/min, mm/s^2):

  * $110-$112 max rate [mm/min] -> [limits] max_velocity_mm_per_s (/ 60);
  * $120-$122 acceleration [mm/s^2] -> [limits] max_acceleration_mm_per_s2;
  * $130-$132 max travel L [mm] -> [travel] as -L/2..L/2 about the model's joint-range middle
    (grbl's machine space after homing is -L..0: grbl 1.1 system.c
    ``system_check_travel_limits``, limits.c's position after homing, for either $23 direction);
  * $12 arc tolerance [mm] -> [segmentation] method "chord", chord_tolerance_mm (grbl's own rule:
    chords whose sagitta stays within the tolerance);
  * $11 junction deviation [mm] -> [path] mode "G64", tolerance_mm: grbl's junction deviation
    is the distance from the corner to the circle its cornering speed is sized on, the same
    distance a G64 P blend keeps (controller/planner/blend.py); 0 (grbl stops at every
    corner) -> mode "G61".

A group ($110-$112, $120-$122, $130-$132) with a setting missing, or set to 0 (grbl accepts 0:
the unused axis of a 2-axis laser or plotter), is not written: the bundled values stay.

With the ``$#`` report in the same file (``[G54:x,y,z]`` ... ``[G28:...]``, ``[G30:...]``,
``[G92:...]``; mm, or inches with $13=1: grbl's ``printFloat_CoordValue`` scales coordinates by
INCH_PER_MM, never the ``$$`` settings), the stored offsets go to ``[work]`` [mm] (``g54_mm`` ..
``g59_mm``, ``g28_mm``, ``g30_mm``, ``g92_mm``). G54-G59 are the systems' origins and G28/G30
stored positions, all in grbl's machine coordinates: machine position m is m + L/2 in the
machine file's frame (the -L/2..L/2 of [travel], L the full $13x length: fit_travel keeps the
coordinates it is given when it shortens a travel to the model's joint range). Without all of
$130-$132 they cannot be placed and are not written. G92 is an offset in work coordinates:
written as printed. Vectors that come out zero (the bundled value) are not written;
``[TLO:...]`` (G43.1's offset, not kept by grbl over a reset) and ``[PRB:...]`` are not mapped.

A dump that numbers its settings as grbl 0.8 and older did (and the 0.9 builds before 0.9g:
``$0=755.906 (x, step/mm)``, ``$9=0.050 (junction deviation, mm)``, ``$10=0.100 (arc,
mm/segment)``, ``$12=3 (n-decimals, int)``) is refused at the first line whose description
shows it: read with 0.9/1.1 numbers it would map the wrong settings.

Not mapped, and said so: $13 report inches (display only, or what it did to the ``$#`` report),
step and pin settings ($0-$6, $100-$102), status, limits, homing and spindle settings. grbl
drives steppers open loop and plans with infinite jerk: the bundled servo and jerk limits are
kept.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

from gantry_sim.controller.config import value_fault
from gantry_sim.controller.errors import ConfigError, cut, shown
from gantry_sim.controller.machine_import.common import (
    Imported,
    Target,
    fit_travel,
    outside_travel,
    read_text,
)
from gantry_sim.controller.machine_import.grbl_offsets import (
    parse_offsets,
    place_offsets,
)

#: a setting line; possessive quantifiers: with the comment absent, two ``\s*`` in a row tried
#: every split of a run of spaces (quadratic in its length) before refusing the line. The number
#: has at most 9 digits: ``int()`` refuses more than 4300 (an internal error, not exit 2).
_LINE = re.compile(r"^\$(\d{1,9}+)\s*+=\s*+([^\s(]++)\s*+(?:\((.*)\))?\s*+$")
_NOT_MAPPED = {
    0: "step pulse time", 1: "step idle delay", 2: "step port invert", 3: "direction invert",
    4: "step enable invert", 5: "limit pins invert", 6: "probe pin invert",
    10: "status report mask",
    13: "report inches: display only (gantry-sim reports mm)",
    20: "soft limits: gantry-sim always refuses programs that leave [travel]",
    21: "hard limits", 22: "homing cycle", 23: "homing direction", 24: "homing feed",
    25: "homing seek", 26: "homing debounce", 27: "homing pull-off",
    30: "max spindle speed", 31: "min spindle speed", 32: "laser mode",
    100: "X steps/mm", 101: "Y steps/mm", 102: "Z steps/mm",
}  # fmt: skip
_MAPPED = {110, 111, 112, 120, 121, 122, 130, 131, 132, 12, 11}
#: A description grbl 0.8 and older printed for a setting grbl 0.9g and 1.1 number otherwise
#: (0.8c report.c ``report_grbl_settings``, 0.7 settings.c ``settings_dump``; the 0.9a-0.9e
#: builds still printed $0-$2 step/mm, $3.. max rate, accel, max travel): the words, the numbers
#: that give the dump away, and where grbl 0.9 and 1.1 have the setting.
_OLD_NUMBERING: tuple[tuple[re.Pattern[str], Callable[[int], bool], str], ...] = (
    (re.compile(r"n-arc|n-decimals"), lambda n: True, "grbl 0.9 and 1.1 have no such setting"),
    (re.compile(r"junction deviation"), lambda n: n != 11, "junction deviation is $11"),
    (re.compile(r"\barc\b|mm/segment"), lambda n: n != 12, "arc tolerance is $12"),
    (re.compile(r"\bsteps?/mm\b"), lambda n: n <= 2, "steps/mm are $100-$102"),
    (re.compile(r"max rate|v_max"), lambda n: n < 100, "max rates are $110-$112"),
    (re.compile(r"accel"), lambda n: n < 100, "accelerations are $120-$122"),
    (re.compile(r"max travel"), lambda n: n < 100, "max travels are $130-$132"),
)


def _is_banner(line: str) -> bool:
    """grbl's welcome line (``Grbl 1.1h ['$' for help]``, ``GrblHAL 1.1f [... for help]``),
    which a console capture of ``$$`` starts with."""
    low = line.lower()
    return low.startswith("grbl") and "for help" in low


def _refuse_old_numbering(n: int, description: str, path: str, line: int) -> None:
    """A ConfigError at ``line`` when ``$n``'s description shows grbl 0.8's numbering."""
    low = description.lower()
    for words, is_old, where in _OLD_NUMBERING:
        if words.search(low) and is_old(n):
            raise ConfigError(
                f"${n} ({cut(description.strip(), 40)}): the dump numbers its settings as grbl "
                f"0.8 (or older) does (grbl 0.9 and 1.1: {where}); gantry-sim reads grbl 0.9 "
                "and 1.1 $$ dumps",
                file=path,
                line=line,
            )


def parse_settings(text: str, path: str) -> dict[int, tuple[float, int]]:
    """``$N=VALUE`` lines -> {N: (value, line)}; blank lines, ``ok``, ``[...]`` messages and
    grbl's welcome banner are skipped, anything else is a ConfigError at its line, and so is a
    description in grbl 0.8's numbering (:data:`_OLD_NUMBERING`)."""
    out: dict[int, tuple[float, int]] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.lower() == "ok" or line.startswith("[") or _is_banner(line):
            continue
        m = _LINE.match(line)
        if m is None:
            raise ConfigError(
                f"not a grbl setting line (expected $N=VALUE): {shown(line, 60)}",
                file=path,
                line=number,
            )
        n = int(m.group(1))
        if m.group(3) is not None:
            _refuse_old_numbering(n, m.group(3), path, number)
        try:
            value = float(m.group(2))
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(
                f"${n} = {shown(m.group(2))}: expected a number", file=path, line=number
            )
        out.setdefault(n, (value, number))
    if not out:
        raise ConfigError("no $N=VALUE line: not a grbl $$ dump", file=path)
    return out


def _positive(settings: dict[int, tuple[float, int]], n: int, path: str) -> float | None:
    if n not in settings:
        return None
    value, line = settings[n]
    if value <= 0:
        raise ConfigError(f"${n} = {value:g}: must be > 0", file=path, line=line)
    return value


def _axis_group(
    settings: dict[int, tuple[float, int]], first: int, path: str, assumed: list[str]
) -> list[float] | None:
    """$first..$first+2 (X, Y, Z; grbl's units), or None when the group is not written: a
    setting missing, or 0 (grbl takes 0, the value of an axis the machine does not have); said
    in ``assumed``. A negative value is a ConfigError at its line."""
    values: list[float | None] = []
    for n in range(first, first + 3):
        value, line = settings.get(n, (None, 0))
        if value is not None and value < 0:
            raise ConfigError(
                f"${n} = {value:g}: must be > 0 (or 0: an unused axis)", file=path, line=line
            )
        values.append(value)
    name = f"${first}-${first + 2}"
    if zeros := [f"${first + i}=0" for i, v in enumerate(values) if v == 0]:
        assumed.append(
            f"{', '.join(zeros)}: the axis looks unused (a 2-axis laser or plotter): {name} not "
            "written (bundled kept)"
        )
        return None
    if any(v is None for v in values):
        if any(v is not None for v in values):
            assumed.append(f"{name} incomplete: not written (bundled kept)")
        return None
    return [float(v) for v in values if v is not None]


#: setting -> the machine-file key it becomes (section, key, whether a per-axis vector) and the
#: factor from grbl's unit ($110-$112 mm/min -> mm/s)
_DESTINATIONS = {
    **{110 + i: ("limits", "max_velocity_mm_per_s", True, 1 / 60.0) for i in range(3)},
    **{120 + i: ("limits", "max_acceleration_mm_per_s2", True, 1.0) for i in range(3)},
    12: ("segmentation", "chord_tolerance_mm", False, 1.0),
    11: ("path", "tolerance_mm", False, 1.0),
}


def _check_held(settings: dict[int, tuple[float, int]], path: str) -> None:
    """A ConfigError at its line for a setting the machine file cannot hold ($110=1e308: a
    velocity beyond 100 m/s; $12=100: a chord tolerance beyond 10 mm). 0 and negative values
    are left to the rules that read them (an unused axis; $11=0: G61; refusals of their own)."""
    for n, (section, key, vector, factor) in _DESTINATIONS.items():
        if n not in settings or settings[n][0] <= 0.0:
            continue
        value, line = settings[n]
        if (fault := value_fault(section, key, value * factor, vector)) is not None:
            raise ConfigError(
                f"${n}={value:g} gives [{section}] {key} = {value * factor:g}, which must be "
                f"{fault}",
                file=path,
                line=line,
            )


def _limits(rates: list[float] | None, accs: list[float] | None) -> dict[str, list[float]]:
    """[limits] from $110-$112 [mm/min] and $120-$122 [mm/s^2] (mm/s, mm/s^2)."""
    limits: dict[str, list[float]] = {}
    if rates is not None:
        limits["max_velocity_mm_per_s"] = [r / 60.0 for r in rates]
    if accs is not None:
        limits["max_acceleration_mm_per_s2"] = accs
    return limits


def _travel(
    lengths: list[float], target: Target, values: dict[str, dict], assumed: list[str]
) -> tuple[list[float], list[float]]:
    """[travel] (and [sim] work_origin_joint_mm) from $130-$132 [mm] into ``values``; returns
    the (min_mm, max_mm) written [mm].

    :func:`fit_travel` returns the travel in the coordinates it was given (it may shorten it to
    the joint range, and places that frame's 0 in the joints): grbl's machine position m stays
    m + L/2 with L the full $13x length, however short the written travel."""
    lo = (-0.5 * lengths[0], -0.5 * lengths[1], -0.5 * lengths[2])
    hi = (0.5 * lengths[0], 0.5 * lengths[1], 0.5 * lengths[2])
    tlo, thi, origin = fit_travel(lo, hi, target, assumed)
    values["travel"] = {"min_mm": tlo, "max_mm": thi}
    if any(origin):
        values["sim"] = {"work_origin_joint_mm": origin}
    assumed.append(
        "travel: grbl's $130-$132 lengths L as -L/2..L/2 in work coordinates (grbl's machine "
        "space is -L..0 after homing: machine position m is m + L/2 here; work offsets are not "
        "in $$, a $# report in the same file gives them)"
    )
    return tlo, thi


def _path(settings: dict[int, tuple[float, int]], path: str, assumed: list[str]) -> dict | None:
    """[path] from $11 junction deviation [mm] (None: no $11)."""
    if 11 not in settings:
        return None
    deviation, line = settings[11]
    if deviation < 0:
        raise ConfigError(f"$11 = {deviation:g}: must be >= 0", file=path, line=line)
    assumed.append(
        "$11 junction deviation -> [path] G64 tolerance (the corner-to-circle distance a "
        "blend keeps; grbl sizes a corner's speed on that circle, gantry-sim blends it "
        "with a jerk-limited arc)"
    )
    return {"mode": "G64", "tolerance_mm": deviation} if deviation > 0 else {"mode": "G61"}


def _not_mapped(settings: dict[int, tuple[float, int]], inches_used: bool) -> list[str]:
    """``$N=VALUE (why)`` for every setting the machine file cannot express."""
    notes = []
    for n in sorted(settings):
        if n in _MAPPED:
            continue
        value = settings[n][0]
        why = _NOT_MAPPED.get(n, "not a grbl 1.1 setting gantry-sim knows")
        if n == 13 and inches_used:
            why = (
                "report inches: grbl printed the $# report in inches, read as such and "
                "converted to mm; gantry-sim reports mm"
            )
        notes.append(f"${n}={value:g} ({why})")
    return notes


def import_grbl(path: Path, target: Target) -> Imported:
    """Read a grbl ``$$`` dump and map what the machine file can express (module doc).

    Raises:
        ConfigError: unreadable file, a malformed line, grbl 0.8's numbering, or a negative
            rate, acceleration or travel, a non-positive arc tolerance (``FILE:LINE: error:``).
    """
    src = str(path)
    text = read_text(path, "grbl settings file")
    settings = parse_settings(text, src)
    assumed: list[str] = []
    values: dict[str, dict] = {}
    rates = _axis_group(settings, 110, src, assumed)
    accs = _axis_group(settings, 120, src, assumed)
    lengths = _axis_group(settings, 130, src, assumed)
    _check_held(settings, src)
    if limits := _limits(rates, accs):
        values["limits"] = limits
    box = _travel(lengths, target, values, assumed) if lengths is not None else None
    if (tol := _positive(settings, 12, src)) is not None:
        values["segmentation"] = {"method": "chord", "chord_tolerance_mm": tol}
    if (blend := _path(settings, src, assumed)) is not None:
        values["path"] = blend
    assumed.append(
        "grbl drives steppers open loop: [servo] keeps the bundled gains; grbl plans with "
        "infinite jerk: [limits] max_jerk_mm_per_s3 keeps the bundled values"
    )
    reported = parse_offsets(text, src)
    # grbl prints $# in inches with $13=1 (printFloat_CoordValue), its $$ settings in mm
    inches = bool(reported) and settings.get(13, (0.0, 0))[0] != 0
    if work := place_offsets(reported, inches, lengths, assumed):
        values["work"] = work
        if box is not None:
            outside_travel(work, *box, assumed)
    return Imported(
        source=src,
        kind="grbl $$ settings",
        values=values,
        assumed=tuple(assumed),
        not_mapped=tuple(_not_mapped(settings, inches)),
    )
