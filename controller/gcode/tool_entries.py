"""G10 L1 / L10 / L11: set a tool table entry, as LinuxCNC 2.9's rs274 does (convert_setup_tool).

- ``G10 L1 P<tool> X Y Z R``: the entry's X/Y/Z offsets are the words' values; R is the radius.
- ``G10 L10 P<tool> X Y Z``: offsets so that, with this tool's offset in effect (G43), the
  current point would read X Y Z in the coordinate system in effect.
- ``G10 L11 P<tool> X Y Z``: the same in G59.3 (system 9), without the G92 offset: LinuxCNC's
  way of touching off tools against a fixture.

L10/L11 start from the point the spindle is at (the current point with every offset, the tool
offset included), expressed in the target system: X and Y are turned by that system's rotation,
and a lone X (or Y) keeps the old offset's component along the rotated other axis. If the tool
is the current pocket, the spindle's entry becomes the new one too (rs274 copies it to slot 0);
the offset in effect changes only at the next G43.
"""

from __future__ import annotations

from dataclasses import replace

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import rotate, sub, to_work
from gantry_sim.controller.gcode.parameters import (
    COORD_INDEX,
    G92_ENABLED,
    G92_OFFSET,
    Parameters,
    g5x_base,
)
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.tool_offsets import ToolTable
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.planes import Vec3

#: the words that give G10 L1/L10/L11 something to do (rs274 also counts A B C U V W)
_SETTING = "XYZRQIJ"


def set_tool_entry(
    s: ModalState, p: Parameters, v: dict[str, float], table: ToolTable
) -> ModalState:
    """G10 L1/L10/L11 (``v``: the block's words); returns the state (the spindle's entry)."""
    level = round(v["L"])
    if "P" not in v:
        raise GcodeError(f"G10 L{level} needs a P word: the tool number")
    number = round(v["P"])
    if abs(v["P"] - number) > 0.0002:
        raise GcodeError("P value not an integer with G10")
    if number < 1:
        raise GcodeError(f"P value out of range with G10 L{level}: the tool number, >= 1")
    old = table.lookup(number) or Tool(number, 0.0)
    if not any(c in v for c in _SETTING):
        raise GcodeError(f"G10 L{level} without offsets has no effect")
    if "Q" in v:
        q = round(v["Q"])
        if abs(v["Q"] - q) > 1e-4:
            raise GcodeError("Q number in G10 is not an integer")
        if q > 9:
            raise GcodeError("invalid tool orientation (Q): 0..9")
    k = s.scale
    x, y, z = old.x_mm, old.y_mm, old.z_mm
    if level == 1:
        x = v["X"] * k if "X" in v else x
        y = v["Y"] * k if "Y" in v else y
        z = v["Z"] * k if "Z" in v else z
    else:
        system = 9 if level == 11 else int(p.numbered.get(COORD_INDEX, 1.0) or 1)
        t = _spindle_in_system(s, p, system, g92=level != 11)
        r = p.numbered.get(g5x_base(system) + 9, 0.0)
        x, y = _xy(v, k, t, (x, y), r)
        if "Z" in v:
            z = t[2] - v["Z"] * k
    diameter = 2.0 * v["R"] * k if "R" in v else old.diameter_mm
    new = Tool(number, z, diameter, x, y, table.unit_mm)
    table.put(new)
    if s.pocket == number:
        s = replace(s, spindle_tool=new, spindle_tool_db=new)
    return s


def _spindle_in_system(s: ModalState, p: Parameters, system: int, g92: bool) -> Vec3:
    """rs274's find_current_in_system_without_tlo (with the G92 offset put back for L11)."""
    w = to_work(s.position, s.frame)
    w = (w[0] + s.tool_offset_mm[0], w[1] + s.tool_offset_mm[1], w[2] + s.tool_offset_mm[2])
    base = g5x_base(system)
    t = rotate(sub(w, (p.mm(base), p.mm(base + 1), p.mm(base + 2))), -p.numbered.get(base + 9, 0.0))
    if g92 and p.numbered.get(G92_ENABLED, 0.0):
        t = sub(t, (p.mm(G92_OFFSET), p.mm(G92_OFFSET + 1), p.mm(G92_OFFSET + 2)))
    return t


def _xy(
    v: dict[str, float], k: float, t: Vec3, old: tuple[float, float], r: float
) -> tuple[float, float]:
    """The X/Y offsets of L10/L11 in a system rotated by ``r`` degrees."""
    if "X" in v and "Y" in v:
        x, y, _ = rotate((t[0] - v["X"] * k, t[1] - v["Y"] * k, 0.0), r)
        return x, y
    if "X" not in v and "Y" not in v:
        return old
    ox, oy, _ = rotate((old[0], old[1], 0.0), -r)
    keep = rotate((0.0, oy, 0.0) if "X" in v else (ox, 0.0, 0.0), r)
    if "X" in v:
        nx, ny, _ = rotate((t[0] - v["X"] * k, 0.0, 0.0), r)
    else:
        nx, ny, _ = rotate((0.0, t[1] - v["Y"] * k, 0.0), r)
    return nx + keep[0], ny + keep[1]
