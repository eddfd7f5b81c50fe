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

    The middle of each axis' travel goes to the middle of its joint range. A travel longer than
    the joint range is shortened about its middle to the joint range (said in ``assumed``).

    Returns:
        (min_mm, max_mm, work_origin_joint_mm), each a list of 3.
    """
    out_lo, out_hi, origin = [], [], []
    for i, axis in enumerate(AXES):
        jlo, jhi = target.joint_range_mm[i]
        mid, half = 0.5 * (lo_mm[i] + hi_mm[i]), 0.5 * (hi_mm[i] - lo_mm[i])
        if 2 * half > jhi - jlo + 1e-9:
            half = 0.5 * (jhi - jlo)
            assumed.append(
                f"travel {axis.upper()} {lo_mm[i]:g}..{hi_mm[i]:g} mm is longer than the model's "
                f"{axis} joint range ({jhi - jlo:g} mm): shortened to {mid - half:g}..{mid + half:g}"
            )
        out_lo.append(mid - half)
        out_hi.append(mid + half)
        origin.append(0.5 * (jlo + jhi) - mid)
    if any(origin):
        assumed.append(
            "work origin: the middle of each axis' travel sits at the middle of the model's "
            f"joint range ([sim] work_origin_joint_mm = {[round(v, 6) for v in origin]})"
        )
    return out_lo, out_hi, origin
