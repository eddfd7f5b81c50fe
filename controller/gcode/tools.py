"""Tool tables: LinuxCNC's ``tool.tbl`` format, read into tool length offsets [mm].

A line is ``T<n> P<pocket> X<x> Y<y> Z<length> D<diameter> ;comment``; X and Y offsets are kept
(rs274's G43 applies them, as a lathe's), the other axes' are read and ignored on this 3-axis
machine. Lengths are in the
table's units, which LinuxCNC takes from the machine (mm here by default; ``rs274 -g`` run
without an INI file reads them in inches: pass ``units_mm=25.4`` for such a table).

How the offset enters the simulation: G43 shifts the program's Z by the tool length (and X/Y by
the tool's X/Y offsets), exactly as rs274 does, and gantry-sim outputs the programmed tool-tip
path; the spindle nose (the machine's controlled point) is that path plus the offset, which the
simulation does not need.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.lexer import split_lines
from gantry_sim.controller.input_files import CONFIG_CAP_BYTES, read_capped

_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


@dataclass(frozen=True)
class Tool:
    """One tool: number, length offset along Z [mm], diameter [mm], X/Y offsets [mm].

    ``unit_mm``: mm per length unit of the table it came from, LinuxCNC's machine units (1 for
    a metric table, 25.4 for ``rs274 -g``'s inch one): the tool parameters #5401-#5410 read
    the table's own numbers, whatever G20/G21 is in effect.
    """

    number: int
    z_mm: float
    diameter_mm: float = 0.0
    x_mm: float = 0.0
    y_mm: float = 0.0
    unit_mm: float = 1.0

    @property
    def offset_mm(self) -> tuple[float, float, float]:
        """(x, y, z) offset [mm], as rs274's G43 applies it."""
        return (self.x_mm, self.y_mm, self.z_mm)


def parse_tool_table(
    text: str,
    name: str = "<tool table>",
    units_mm: float = 1.0,
    skipped: list[tuple[int, str]] | None = None,
) -> dict[int, Tool]:
    """``tool.tbl`` text -> tools by number; GcodeError (file, line) on a bad line, or, given
    ``skipped``, the line number and text of each bad line appended there and the line
    skipped (as LinuxCNC's tool-data loader does: "Unrecognized line skipped")."""
    tools: dict[int, Tool] = {}
    for k, raw in enumerate(split_lines(text), 1):  # lines counted as a program's
        body = raw.split(";", 1)[0].strip().upper()
        if not body:
            continue
        words = dict(_WORD.findall(body))
        rest = _WORD.sub("", body).strip()
        if ("T" not in words or rest) and skipped is not None:
            skipped.append((k, raw.strip()))
            continue
        if "T" not in words or rest:
            raise GcodeError(
                "bad tool table line; expected 'T<n> P<pocket> Z<length> D<diameter> ;comment'",
                file=name,
                line=k,
            )
        number = int(float(words["T"]))
        tools[number] = Tool(
            number,
            float(words.get("Z", 0.0)) * units_mm,
            float(words.get("D", 0.0)) * units_mm,
            float(words.get("X", 0.0)) * units_mm,
            float(words.get("Y", 0.0)) * units_mm,
            units_mm,
        )
    return tools


def read_tool_table(path: Path, units_mm: float = 1.0) -> dict[int, Tool]:
    """Read a ``tool.tbl`` file (GcodeError naming the file when it cannot be read)."""
    data = read_capped(path, "tool table", CONFIG_CAP_BYTES, GcodeError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise GcodeError("not a tool table (invalid UTF-8)", file=str(path), line=line) from None
    return parse_tool_table(text, str(path), units_mm)
