"""A grbl ``$#`` report (``[G54:x,y,z]`` .. ``[G59:...]``, ``[G28:...]``, ``[G30:...]``,
``[G92:...]``) -> the machine file's ``[work]`` [mm], in the frame of the ``[travel]`` that
:mod:`~gantry_sim.controller.machine_import.grbl_settings` writes from $130-$132.

G54-G59 (the systems' origins) and G28/G30 (stored positions) are grbl machine coordinates,
-L..0 per axis after homing (grbl 1.1 system.c ``system_check_travel_limits``): machine position
m is m + L/2 in the -L/2..L/2 frame. G92 is a work-coordinate offset, written as printed. With
$13=1 grbl prints these values in inches (print.c ``printFloat_CoordValue``).
"""

from __future__ import annotations

import math
import re

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.machine_work import MAX_MM
from gantry_sim.controller.units import MM_PER_INCH

_OFFSET_LINE = re.compile(r"^\[(G5[4-9]|G28|G30|G92):([^\]]*)\]$")
#: the ``$#`` entries that are grbl machine coordinates (G92 is a work-coordinate offset)
_MACHINE_KEYS = ("g54_mm", "g55_mm", "g56_mm", "g57_mm", "g58_mm", "g59_mm", "g28_mm", "g30_mm")


#: the largest $# number read: a [work] offset's range (MAX_MM) in inches, less grbl's travel
REPORTED_MAX = MAX_MM / MM_PER_INCH / 2


def parse_offsets(text: str, path: str) -> dict[str, list[float]]:
    """``$#`` lines ``[G54:x,y,z]`` ... -> [work] key -> [x, y, z] as grbl printed them (its
    report units: mm, or inches with $13=1; G54-G59, G28, G30 in machine coordinates), every
    one reported, zeros included (a later report of the same key wins)."""
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
        if any(abs(v) >= REPORTED_MAX for v in vec):  # [G54:1e300,0,0]
            raise ConfigError(
                f"[{m.group(1)}:...]: each number must be within +-{REPORTED_MAX:g} (the "
                f"machine file's offsets stay below {MAX_MM:g} mm, in inches too)",
                file=path,
                line=number,
            )
        out[f"{m.group(1).lower()}_mm"] = vec
    return out


def place_offsets(
    reported: dict[str, list[float]],
    inches: bool,
    lengths: list[float] | None,
    assumed: list[str],
) -> dict[str, list[float]]:
    """The ``$#`` values -> [work] [mm, the machine file's frame].

    ``reported`` is in grbl's report units (inches when ``inches``: $13=1). G54-G59 and G28/G30
    are grbl machine coordinates, -L..0 per axis after homing (L = ``lengths``, $130-$132
    [mm]): m + L/2 in the frame whose [travel] is -L/2..L/2. Without ``lengths`` they cannot be
    placed and are left out; G92, a work-coordinate offset, is kept as is. Vectors that come out
    zero (the bundled value) are left out. What was done goes to ``assumed``.
    """
    scale = MM_PER_INCH if inches else 1.0
    out: dict[str, list[float]] = {}
    for key, vec in reported.items():
        mm = [v * scale for v in vec]
        if key in _MACHINE_KEYS:
            if lengths is None:
                continue
            mm = [v + 0.5 * length for v, length in zip(mm, lengths, strict=True)]
        # 1e-6 mm drops only the float noise of the shift; grbl's 4 inch decimals are steps of
        # 0.00254 mm, so 0.001 mm (its mm report's 3 decimals) keeps all they say. + 0.0: no -0.0
        mm = [round(v, 3 if inches else 6) + 0.0 for v in mm]
        if any(mm):
            out[key] = mm
    unit = "inches (x 25.4: $13=1)" if inches else "mm"
    placed = lengths is not None and any(k in _MACHINE_KEYS for k in reported)
    if placed:
        assumed.append(
            f"$# offsets read in {unit} -> [work]: G54-G59 origins and G28/G30 positions are "
            "grbl machine coordinates, -L..0 per axis after homing (L = $130-$132; grbl's "
            "default build: with HOMING_FORCE_SET_ORIGIN and a $23 bit set that axis' space "
            "is 0..L), written as m + L/2 in the -L/2..L/2 frame of [travel]; G92, a work "
            "offset, as printed; zero vectors (the bundled value) are not written"
        )
    elif "g92_mm" in out:
        assumed.append(f"$# G92 offset read in {unit} -> [work] g92_mm (a work offset)")
    if lengths is None and any(k in _MACHINE_KEYS for k in reported):
        assumed.append(
            "$# G54-G59, G28, G30 not written: they are grbl machine coordinates, placed in the "
            "machine file's frame through the $130-$132 travel, which is not written (bundled "
            "offsets kept)" + ("; G92 written" if "g92_mm" in out else "")
        )
    return out
