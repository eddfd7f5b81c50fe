"""A grbl ``$$`` settings dump -> machine-file values.

grbl 1.1 prints one ``$N=VALUE`` line per setting (grbl 0.9 adds a ``(description)``), then
``ok``; both forms are read. Mapped (grbl's units are mm, mm/min, mm/s^2):

  * $110-$112 max rate [mm/min] -> [limits] max_velocity_mm_per_s (/ 60);
  * $120-$122 acceleration [mm/s^2] -> [limits] max_acceleration_mm_per_s2;
  * $130-$132 max travel [mm] -> [travel] as -L/2..L/2 about the model's joint-range middle
    (grbl's machine space after homing is -L..0; a program's work offsets are not in ``$$``);
  * $12 arc tolerance [mm] -> [segmentation] method "chord", chord_tolerance_mm (grbl's own rule:
    chords whose sagitta stays within the tolerance);
  * $11 junction deviation [mm] -> [path] mode "G64", tolerance_mm: grbl's junction deviation
    is the distance from the corner to the circle its cornering speed is sized on, the same
    distance a G64 P blend keeps (controller/planner/blend.py); 0 (grbl stops at every
    corner) -> mode "G61".

With the ``$#`` report in the same file (``[G54:x,y,z]`` ... ``[G28:...]``, ``[G30:...]``,
``[G92:...]``, mm), the stored offsets go to ``[work]`` (``g54_mm`` .. ``g59_mm``, ``g28_mm``,
``g30_mm``, ``g92_mm``; zero vectors are not written); ``[TLO:...]`` (G43.1's offset, not kept by
grbl over a reset) and ``[PRB:...]`` are not mapped.

Not mapped, and said so: $13 report inches (display only), step
and pin settings ($0-$6, $100-$102), status, limits, homing and spindle settings. grbl drives
steppers open loop and plans with infinite jerk: the bundled servo and jerk limits are kept.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.machine_import.common import Imported, Target, fit_travel, read_text

#: a setting line; possessive quantifiers: with the comment absent, two ``\s*`` in a row tried
#: every split of a run of spaces (quadratic in its length) before refusing the line
_LINE = re.compile(r"^\$(\d++)\s*+=\s*+([^\s(]++)\s*+(?:\(.*\))?\s*+$")
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
_OFFSET_LINE = re.compile(r"^\[(G5[4-9]|G28|G30|G92):([^\]]*)\]$")


def parse_offsets(text: str, path: str) -> dict[str, list[float]]:
    """``$#`` lines ``[G54:x,y,z]`` ... -> [work] key -> [x, y, z] (mm; non-zero ones)."""
    out: dict[str, list[float]] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        m = _OFFSET_LINE.match(raw.strip())
        if m is None:
            continue
        try:
            vec = [float(v) for v in m.group(2).split(",")[:3]]
        except ValueError:
            vec = []
        if len(vec) != 3 or not all(math.isfinite(v) for v in vec):
            raise ConfigError(
                f"[{m.group(1)}:...]: expected three numbers x,y,z", file=path, line=number
            )
        if any(vec):
            out[f"{m.group(1).lower()}_mm"] = vec
    return out


def parse_settings(text: str, path: str) -> dict[int, tuple[float, int]]:
    """``$N=VALUE`` lines -> {N: (value, line)}; blank lines, ``ok`` and ``[...]`` messages are
    skipped, anything else is a ConfigError at its line."""
    out: dict[int, tuple[float, int]] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.lower() == "ok" or line.startswith("["):
            continue
        m = _LINE.match(line)
        if m is None:
            raise ConfigError(
                f"not a grbl setting line (expected $N=VALUE): {shown(line, 60)}",
                file=path,
                line=number,
            )
        try:
            value = float(m.group(2))
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(
                f"${m.group(1)} = {m.group(2)!r}: expected a number", file=path, line=number
            )
        out.setdefault(int(m.group(1)), (value, number))
    if not out:
        raise ConfigError("no $N=VALUE line: not a grbl $$ dump", file=path)
    return out


def _positive(settings: dict, n: int, path: str) -> float | None:
    if n not in settings:
        return None
    value, line = settings[n]
    if value <= 0:
        raise ConfigError(f"${n} = {value:g}: must be > 0", file=path, line=line)
    return value


def import_grbl(path: Path, target: Target) -> Imported:
    """Read a grbl ``$$`` dump and map what the machine file can express (module doc).

    Raises:
        ConfigError: unreadable file, a malformed line, or a non-positive rate, acceleration,
            travel or arc tolerance (``FILE:LINE: error:``).
    """
    src = str(path)
    text = read_text(path, "grbl settings file")
    settings = parse_settings(text, src)
    assumed: list[str] = []
    values: dict[str, dict] = {}
    rates = [_positive(settings, 110 + i, src) for i in range(3)]
    accs = [_positive(settings, 120 + i, src) for i in range(3)]
    travel = [_positive(settings, 130 + i, src) for i in range(3)]
    limits: dict[str, list[float]] = {}
    if all(r is not None for r in rates):
        limits["max_velocity_mm_per_s"] = [r / 60.0 for r in rates]  # type: ignore[operator]
    if all(a is not None for a in accs):
        limits["max_acceleration_mm_per_s2"] = [float(a) for a in accs]  # type: ignore[arg-type]
    if limits:
        values["limits"] = limits
    if all(t is not None for t in travel):
        lo = tuple(-0.5 * t for t in travel)  # type: ignore[operator]
        hi = tuple(0.5 * t for t in travel)  # type: ignore[operator]
        tlo, thi, origin = fit_travel(lo, hi, target, assumed)  # type: ignore[arg-type]
        values["travel"] = {"min_mm": tlo, "max_mm": thi}
        if any(origin):
            values["sim"] = {"work_origin_joint_mm": origin}
        assumed.append(
            "travel: grbl's $130-$132 lengths as -L/2..L/2 in work coordinates (grbl's machine "
            "space is -L..0 after homing; work offsets are not in $$)"
        )
    for name, group in (("$110-$112", rates), ("$120-$122", accs), ("$130-$132", travel)):
        if any(v is not None for v in group) and not all(v is not None for v in group):
            assumed.append(f"{name} incomplete: not written (bundled kept)")
    if (tol := _positive(settings, 12, src)) is not None:
        values["segmentation"] = {"method": "chord", "chord_tolerance_mm": tol}
    if 11 in settings:
        deviation, line = settings[11]
        if deviation < 0:
            raise ConfigError(f"$11 = {deviation:g}: must be >= 0", file=src, line=line)
        values["path"] = (
            {"mode": "G64", "tolerance_mm": deviation} if deviation > 0 else {"mode": "G61"}
        )
        assumed.append(
            "$11 junction deviation -> [path] G64 tolerance (the corner-to-circle distance a "
            "blend keeps; grbl sizes a corner's speed on that circle, gantry-sim blends it "
            "with a jerk-limited arc)"
        )
    assumed.append(
        "grbl drives steppers open loop: [servo] keeps the bundled gains; grbl plans with "
        "infinite jerk: [limits] max_jerk_mm_per_s3 keeps the bundled values"
    )
    if work := parse_offsets(text, src):
        values["work"] = work
        assumed.append("$# offsets (G54-G59, G28, G30, G92) -> [work] (mm)")
    notes = []
    for n in sorted(settings):
        if n in _MAPPED:
            continue
        value = settings[n][0]
        why = _NOT_MAPPED.get(n, "not a grbl 1.1 setting gantry-sim knows")
        notes.append(f"${n}={value:g} ({why})")

    return Imported(
        source=src,
        kind="grbl $$ settings",
        values=values,
        assumed=tuple(assumed),
        not_mapped=tuple(notes),
    )
