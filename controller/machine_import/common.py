"""What every importer shares: the target model's figures, the result, travel fitting, reading.

Units: mm, s, kg, N, as in machine files. An importer maps only what has a counterpart in the
machine file; everything else goes to :attr:`Imported.not_mapped` with the reason, and every
assumption it had to make goes to :attr:`Imported.assumed`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.input_files import CONFIG_CAP_BYTES, read_capped
from gantry_sim.controller.planes import Vec3

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Target:
    """The model the imported machine file will run on.

    Attributes:
        mass_kg: moving mass per axis incl. armature [kg] (gains are converted through it).
        joint_range_mm: (lower, upper) joint range per axis [mm]; the travel must fit in it.
    """

    mass_kg: Vec3
    joint_range_mm: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class Imported:
    """An import's result.

    Attributes:
        source: the file read.
        kind: what it was ("LinuxCNC INI", "grbl $$ settings").
        values: machine-file section -> key -> value (only the keys that map).
        assumed: how values were mapped where the conversion needed an assumption.
        not_mapped: what the source sets that the machine file cannot express, with the reason.
    """

    source: str
    kind: str
    values: dict[str, dict[str, Any]]
    assumed: tuple[str, ...] = field(default=())
    not_mapped: tuple[str, ...] = field(default=())


def read_text(path: Path, what: str) -> str:
    """The file's text; unreadable, binary or non-UTF-8 files, and files larger than
    :data:`~gantry_sim.controller.input_files.CONFIG_CAP_BYTES`, are a ConfigError (FILE:
    error)."""
    data = read_capped(path, what, CONFIG_CAP_BYTES)
    if b"\x00" in data:
        raise ConfigError(f"not a {what} (binary data)", file=str(path))
    try:
        return data.decode("utf-8-sig")  # a leading BOM (Notepad) is no text
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise ConfigError(f"not a {what} (invalid UTF-8)", file=str(path), line=line) from None


def fit_travel(
    lo_mm: Vec3, hi_mm: Vec3, target: Target, assumed: list[str]
) -> tuple[list[float], list[float], list[float]]:
    """Travel [mm] per axis and the work origin's joint position [mm] that puts it in the model.

    The middle of each axis' travel goes to the middle of its joint range. The machine starts
    at rest at the work origin (0), so the travel must hold 0:

    * a travel that does not (a configuration whose limits are 61..700) is widened to 0 (said
      in ``assumed``: machine coordinates are taken as work coordinates, and the start is 0);
    * a travel longer than the joint range is shortened to the joint range's length about its
      middle, moved the least that keeps 0 within it (0..1000 on a 600 mm joint: 0..600).

    Returns:
        (min_mm, max_mm, work_origin_joint_mm), each a list of 3.
    """
    out_lo, out_hi, origin = [], [], []
    for i, axis in enumerate(AXES):
        jlo, jhi = target.joint_range_mm[i]
        name = axis.upper()
        lo, hi = float(lo_mm[i]), float(hi_mm[i])
        if not lo <= 0.0 <= hi:
            wide = (min(lo, 0.0), max(hi, 0.0))
            assumed.append(
                f"travel {name} {lo:g}..{hi:g} mm does not hold 0, where the machine starts (at "
                f"rest at the work origin): widened to {wide[0]:g}..{wide[1]:g}"
            )
            lo, hi = wide
        length = jhi - jlo
        if hi - lo > length + 1e-9:
            mid = min(max(0.5 * (lo + hi), -0.5 * length), 0.5 * length)  # 0 within mid +- L/2
            short = (mid - 0.5 * length, mid + 0.5 * length)
            assumed.append(
                f"travel {name} {lo:g}..{hi:g} mm is longer than the model's {axis} joint range "
                f"({length:g} mm): shortened to {short[0]:g}..{short[1]:g}"
                + (
                    ""
                    if mid == 0.5 * (lo + hi)
                    else " (the stretch nearest its middle that holds 0)"
                )
            )
            lo, hi = short
        out_lo.append(lo)
        out_hi.append(hi)
        origin.append(0.5 * (jlo + jhi) - 0.5 * (lo + hi))
    if any(origin):
        assumed.append(
            "work origin: the middle of each axis' travel sits at the middle of the model's "
            f"joint range ([sim] work_origin_joint_mm = {[round(v, 6) for v in origin]})"
        )
    return out_lo, out_hi, origin


def outside_travel(
    work: dict[str, list[float]], lo: list[float], hi: list[float], assumed: list[str]
) -> None:
    """Say so where a [work] origin or stored position [mm] lies outside the written [travel]
    ``lo``..``hi`` [mm] (a travel shortened to the model's joint range: the machine's own
    reaches it). G92 is an offset, not a position, and is not checked."""
    for key, pos in work.items():
        if key == "g92_mm" or all(
            a - 1e-9 <= p <= b + 1e-9 for p, a, b in zip(pos, lo, hi, strict=True)
        ):
            continue
        code = key.removesuffix("_mm").replace("_", ".").upper()
        what = f"a program's {code}" if code in ("G28", "G30") else f"a program in {code}"
        assumed.append(
            f"{key} {[round(p, 6) for p in pos]} lies outside [travel] "
            f"{[round(a, 6) for a in lo]}..{[round(b, 6) for b in hi]}: {what} leaves the "
            "travel (the model is smaller than the machine; --work-offset places a program)"
        )
