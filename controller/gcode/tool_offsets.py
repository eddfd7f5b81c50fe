"""Tool changes and tool offsets as LinuxCNC 2.9's rs274 makes them: T, M6, M61, G43 (H),
G43.1, G43.2, G49 (interp_convert.cc, convert_tool_length_offset), with rs274's non-random tool
changer and its stand-alone tool data base.

The interpreter keeps a tool table (tool number -> :class:`Tool`) and, apart from it, the
spindle's entry (slot 0, ``ModalState.spindle_tool``): what G43 without H and G43 H0 read.

- ``T n`` selects tool n (it must be in the table).
- ``M6`` loads the selected tool: the data base's slot 0 becomes that tool (``T0 M6`` copies
  slot 0 onto itself: nothing changes, as rs274 -g prints), and it becomes the current pocket.
- ``M61 Q n`` makes tool n the current pocket without loading it: slot 0 keeps its data.
- After a block with M6 or M61, rs274 re-reads its tool table (slot 0 from the data base) and
  takes its current point back from the canonical layer (``ModalState.canon``).
- ``G43`` without H on the line of M6/M61 uses the current pocket's entry, on any later line
  slot 0's. ``G43 H n`` uses tool n's entry (H0: slot 0). ``G43.1 X Y Z`` sets the offset's
  given components, keeping the others; ``G43.2 H n`` adds tool n's entry (rs274 2.9.0 refuses
  G43.2 with axis words: "Requested tool -1 not found"). ``G49`` cancels.
- A new offset re-expresses the current point so the tool does not move: the change of the X/Y
  offset turned into the rotated system, the change of Z as is.

Offsets are [mm] (x, y, z); a program's words are in its units times ``s.scale``.
"""

from __future__ import annotations

from dataclasses import replace

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import rotate
from gantry_sim.controller.gcode.parameters import TOOL_DIAMETER, TOOL_NUMBER, TOOL_OFFSET
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.gcode.words import Words, check_tool_number
from gantry_sim.controller.planes import Vec3

ZERO: Vec3 = (0.0, 0.0, 0.0)


#: the tools a "not found" message lists at most
_LISTED_TOOLS = 12


class ToolTable:
    """The interpreter's tool table (changed by G10 L1/L10/L11).

    With no table (``tools=None``) every tool number is accepted and has zero offsets until a
    G10 L1/L10/L11 gives it some.
    """

    def __init__(self, tools: dict[int, Tool] | None) -> None:
        self.tools = dict(tools) if tools is not None else {}
        self.table_less = tools is None
        #: mm per unit of the table (its first entry's; mm without one): what G10 L1 stores in
        self.unit_mm = next(iter(self.tools.values())).unit_mm if self.tools else 1.0

    @property
    def first(self) -> int:
        """The tool in the table's first entry (0: none): rs274's stand-alone interpreter starts
        with its current pocket at index 1, so a G10 L1 of that tool also sets the spindle's."""
        return next(iter(self.tools), 0)

    def lookup(self, number: int) -> Tool | None:
        """Tool ``number``'s entry (None: tool 0, or no table and no entry yet)."""
        if number == 0:
            return None
        if number in self.tools:
            return self.tools[number]
        if self.table_less:
            return None
        held = sorted(self.tools)
        listed = ", ".join(f"T{n}" for n in held[:_LISTED_TOOLS])
        more = f" and {len(held) - _LISTED_TOOLS} more" if len(held) > _LISTED_TOOLS else ""
        raise GcodeError(
            f"requested tool {number} not found in the tool table, which holds "
            f"{listed + more if held else 'no tools'} (give it in the --tool-table file or the "
            "machine file's [tools])"
        )

    def entry(self, s: ModalState, number: int) -> Tool | None:
        """rs274's ``tool_table[find_tool_index(number)]``: tool 0 is the spindle's slot."""
        return s.spindle_tool if number == 0 else self.lookup(number)

    def put(self, tool: Tool) -> None:
        self.tools[tool.number] = tool


def offset_of(tool: Tool | None) -> Vec3:
    return ZERO if tool is None else tool.offset_mm


def apply_tool_offset(s: ModalState, new: Vec3) -> ModalState:
    """Make ``new`` [mm] the tool offset, re-expressing the current point as rs274 does."""
    old = s.tool_offset_mm
    dx, dy, _ = rotate((old[0] - new[0], old[1] - new[1], 0.0), -s.frame.rotation_deg)
    x, y, z = s.position
    position = (x + dx, y + dy, z + old[2] - new[2])
    return replace(s, tool_offset_mm=new, position=position)


def tool_words(s: ModalState, w: Words, table: ToolTable) -> tuple[ModalState, bool]:
    """T, M6/M61 and G43/G43.1/G43.2/G49 of one block, in rs274's order; returns the new
    state and whether the block changed tools (M6/M61: see :func:`after_tool_change`)."""
    v = w.values
    if "T" in v:
        number = round(v["T"])
        table.lookup(number)
        s = replace(s, selected_tool=number)
    change = w.m.get("tool_change")
    if change == 6:
        number = s.selected_tool
        if number != 0:
            db = table.lookup(number) or Tool(number, 0.0)
            s = replace(s, spindle_tool_db=db, tool=number)
        s = replace(s, pocket=number)
    elif change == 61:
        if v.get("Q", -1.0) < 0.0:
            raise GcodeError("M61 needs a Q word >= 0: the tool number now in the spindle")
        number = round(v["Q"])
        table.lookup(number)
        s = replace(s, pocket=number)
    code = w.g.get("tool_length")
    if code is None:
        return s, change is not None
    if code == 490:
        new = ZERO
    elif code == 430:
        if "H" in v:
            new = offset_of(table.entry(s, _whole(v["H"], "H")))
        elif change is not None:  # rs274: the tool is still in its pocket on this line
            new = offset_of(table.entry(s, s.pocket))
        else:
            new = offset_of(s.spindle_tool)
    elif code == 431:
        old = s.tool_offset_mm
        new = (
            v["X"] * s.scale if "X" in v else old[0],
            v["Y"] * s.scale if "Y" in v else old[1],
            v["Z"] * s.scale if "Z" in v else old[2],
        )
    else:
        new = _g43_2(s, v, table)
    return apply_tool_offset(s, new), change is not None


def _g43_2(s: ModalState, v: dict[str, float], table: ToolTable) -> Vec3:
    axes = any(a in v for a in "XYZ")
    if "H" in v and axes:
        raise GcodeError("G43.2: cannot have both H and axis words")
    if "H" not in v:
        if not axes:
            raise GcodeError("G43.2: no axes specified and H word missing")
        # LinuxCNC 2.9.0 looks up the absent H (-1) before reading the axis words
        raise GcodeError(
            "G43.2 with axis words: requested tool -1 not found in the tool table (LinuxCNC "
            "2.9's rs274 refuses G43.2 without H; use G43.2 H<n> or G43.1)"
        )
    add = offset_of(table.entry(s, _whole(v["H"], "H")))
    old = s.tool_offset_mm
    return (old[0] + add[0], old[1] + add[1], old[2] + add[2])


def after_tool_change(s: ModalState) -> ModalState:
    """rs274 after a block with M6/M61: slot 0 reloaded, current point from the canon layer."""
    return replace(s, spindle_tool=s.spindle_tool_db, position=s.canon)


def _whole(value: float, letter: str) -> int:
    number = round(value)
    if number < 0:
        raise GcodeError(f"negative {letter} word; tool numbers are >= 0")
    check_tool_number(letter, value)
    return number


def tool_parameters(tool: Tool) -> dict[int, float]:
    """#5400-#5413 once M6 has loaded ``tool``, as rs274's set_tool_parameters sets them: the
    tool table's own numbers, lengths in its units (the machine's: mm here; ``tool.unit_mm``),
    not converted to the program's (``G21``, ``T1 M6`` with rs274 -g's inch table reads #5410 =
    0.125, and so under G20)."""
    values = dict.fromkeys(range(TOOL_NUMBER, TOOL_NUMBER + 14), 0.0)
    values[TOOL_NUMBER] = float(tool.number)
    for i, offset in enumerate(tool.offset_mm):
        values[TOOL_OFFSET + i] = offset / tool.unit_mm
    values[TOOL_DIAMETER] = tool.diameter_mm / tool.unit_mm
    return values
