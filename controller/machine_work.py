"""The machine file's ``[tools]`` and ``[work]`` sections: the tool table, and the offsets and
stored positions every program starts from.

``[tools]``: one entry per tool, ``N = { length_mm = L, diameter_mm = D }`` with N >= 1 the tool
number (T word), L its length offset along Z [mm] (G43 H) and D its diameter [mm] (optional,
default 0); optional ``x_mm`` / ``y_mm``: X/Y offsets, applied by G43 as rs274 applies a tool
table's (a lathe's; 0 on a mill). A machine file's ``[tools]`` replaces the bundled table as a whole; with no tool in
any file there is no table and every tool has zero length (as ``gantry parse`` without
``--tool-table``).

``[work]``, each ``[x, y, z]`` in mm of the machine's work frame (where ``[sim]
work_origin_joint_mm`` puts X0 Y0 Z0), laid over the bundled values key by key as the other
sections: ``g54_mm`` .. ``g59_3_mm`` the origins of G54..G59.3, ``g92_mm`` a G92 offset in
effect at the start (all zero: none), ``g28_mm`` / ``g30_mm`` the positions G28 / G30 go to
(the spindle's, as G28.1 stores them). LinuxCNC keeps these in its parameter file
(linuxcnc.var: #5161.., #5181.., #5210.., #5221..); here they become those numbered parameters
before the program's first line (:meth:`WorkSetup.parameters`). Programs start in G54.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.gcode.parameters import (
    G28_HOME,
    G30_HOME,
    G92_ENABLED,
    G92_OFFSET,
    g5x_base,
)
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.planes import Vec3

#: the sections this module reads out of a machine file
WORK_SECTIONS = ("tools", "work")
#: [work] keys of the coordinate systems G54..G59.3, in rs274's order (index 1..9)
SYSTEM_KEYS = (
    "g54_mm",
    "g55_mm",
    "g56_mm",
    "g57_mm",
    "g58_mm",
    "g59_mm",
    "g59_1_mm",
    "g59_2_mm",
    "g59_3_mm",
)
WORK_KEYS = (*SYSTEM_KEYS, "g92_mm", "g28_mm", "g30_mm")
TOOL_KEYS = ("length_mm", "diameter_mm", "x_mm", "y_mm")
#: largest |coordinate| accepted [mm] (as --work-offset)
MAX_MM = 1e6
ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class WorkSetup:
    """Tool table and initial offsets [mm, work frame] (see the module docstring).

    Attributes:
        tools: the tool table by ascending number, or None for no table (zero lengths).
        systems_mm: origins of G54..G59.3 (9 vectors).
        g92_mm: G92 offset in effect at the start.
        g28_mm / g30_mm: stored G28 / G30 positions.
    """

    tools: tuple[Tool, ...] | None = None
    systems_mm: tuple[Vec3, ...] = (ZERO,) * 9
    g92_mm: Vec3 = ZERO
    g28_mm: Vec3 = ZERO
    g30_mm: Vec3 = ZERO

    def tool_table(self) -> dict[int, Tool] | None:
        """Tools by number for the interpreter, or None (no table)."""
        return None if self.tools is None else {t.number: t for t in self.tools}

    def parameters(self) -> dict[int, float]:
        """The numbered parameters [mm] a program starts with (rs274's layout)."""
        values: dict[int, float] = {}
        for index, origin in enumerate(self.systems_mm, 1):
            for i in range(3):
                values[g5x_base(index) + i] = origin[i]
        for base, vec in (
            (G92_OFFSET, self.g92_mm),
            (G28_HOME, self.g28_mm),
            (G30_HOME, self.g30_mm),
        ):
            for i in range(3):
                values[base + i] = vec[i]
        values[G92_ENABLED] = 1.0 if self.g92_mm != ZERO else 0.0
        return values

    def placed(self, g54_mm: Vec3) -> WorkSetup:
        """This setup with G54's origin at ``g54_mm`` (``--work-offset``)."""
        g54: Vec3 = (float(g54_mm[0]), float(g54_mm[1]), float(g54_mm[2]))
        return replace(self, systems_mm=(g54, *self.systems_mm[1:]))

    def with_tools(self, tools: dict[int, Tool]) -> WorkSetup:
        """This setup with ``tools`` as its table (``--tool-table`` replaces ``[tools]``)."""
        return replace(self, tools=tuple(tools[n] for n in sorted(tools)))


NO_WORK = WorkSetup()


def _vec(value: Any, where: str, file: str) -> Vec3:
    ok = isinstance(value, list) and len(value) == 3
    ok = ok and all(not isinstance(v, bool) and isinstance(v, (int, float)) for v in value)
    if not ok or not all(math.isfinite(v) and abs(v) < MAX_MM for v in value):
        raise ConfigError(
            f"{where} = {shown(value)}: must be a list of 3 finite numbers [x, y, z] in mm, "
            f"each |v| < {MAX_MM:g}",
            file=file,
        )
    return (float(value[0]), float(value[1]), float(value[2]))


def _number(value: Any, where: str, file: str, minimum: float | None) -> float:
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    ok = ok and abs(value) < MAX_MM and (minimum is None or value >= minimum)
    if not ok:
        bound = "" if minimum is None else f", >= {minimum:g}"
        raise ConfigError(
            f"{where} = {shown(value)}: must be a finite number [mm]{bound}", file=file
        )
    return float(value)


def _tools(table: dict[str, Any], file: str) -> tuple[Tool, ...] | None:
    tools: dict[int, Tool] = {}
    for key, entry in table.items():
        number = int(key) if key.isdigit() else 0
        if number < 1 or number > 99999:
            raise ConfigError(
                f"[tools] '{key}': a tool's key is its number, an integer 1..99999 "
                "(e.g. 3 = { length_mm = 42.5, diameter_mm = 6.0 })",
                file=file,
            )
        if not isinstance(entry, dict) or "length_mm" not in entry:
            raise ConfigError(
                f"[tools] {key} must be a table {{ length_mm = L, diameter_mm = D }} [mm]",
                file=file,
            )
        unknown = sorted(set(entry) - set(TOOL_KEYS))
        if unknown:
            raise ConfigError(
                f"unknown key '{unknown[0]}' in [tools] {key}; valid keys: {', '.join(TOOL_KEYS)}",
                file=file,
            )
        length = _number(entry["length_mm"], f"[tools] {key} length_mm", file, None)
        diameter = _number(entry.get("diameter_mm", 0.0), f"[tools] {key} diameter_mm", file, 0.0)
        x, y = (
            _number(entry.get(k, 0.0), f"[tools] {key} {k}", file, None) for k in ("x_mm", "y_mm")
        )
        tools[number] = Tool(number, length, diameter, x, y)
    return tuple(tools[n] for n in sorted(tools)) if tools else None


def take_work_sections(data: dict[str, Any], file: str, base: WorkSetup = NO_WORK) -> WorkSetup:
    """Remove ``[tools]`` and ``[work]`` from a machine file's parsed TOML ``data`` and lay them
    over ``base``; ConfigError naming the key on a bad value."""
    setup = base
    tools = data.pop("tools", None)
    if tools is not None:
        if not isinstance(tools, dict):
            raise ConfigError("'tools' must be a table [tools]", file=file)
        setup = replace(setup, tools=_tools(tools, file))
    work = data.pop("work", None)
    if work is None:
        return setup
    if not isinstance(work, dict):
        raise ConfigError("'work' must be a table [work]", file=file)
    systems = list(setup.systems_mm)
    stored = {"g92_mm": setup.g92_mm, "g28_mm": setup.g28_mm, "g30_mm": setup.g30_mm}
    for key, value in work.items():
        if key not in WORK_KEYS:
            raise ConfigError(
                f"unknown key '{key}' in [work]; valid keys: {', '.join(WORK_KEYS)}", file=file
            )
        vec = _vec(value, f"[work] {key}", file)
        if key in SYSTEM_KEYS:
            systems[SYSTEM_KEYS.index(key)] = vec
        else:
            stored[key] = vec
    return replace(
        setup,
        systems_mm=tuple(systems),
        g92_mm=stored["g92_mm"],
        g28_mm=stored["g28_mm"],
        g30_mm=stored["g30_mm"],
    )
