"""One block's part in cutter radius compensation: turning it on/off (G40, G41, G42, G41.1,
G42.1 with D), the codes rs274 refuses while it is on, and the compensated motion.

Tool diameters: G41/G42 take the D word's tool (or, without D, the tool in the spindle) from the
tool table [mm]; G41.1/G42.1 take D as the diameter itself (program units). A zero diameter
leaves the path as programmed, as in rs274.
"""

from __future__ import annotations

from collections.abc import Callable

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.codes import g_name
from gantry_sim.controller.gcode.comp_paths import arc, straight
from gantry_sim.controller.gcode.cutter_comp import CutterComp
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.tools import Tool
from gantry_sim.controller.gcode.words import Words
from gantry_sim.controller.moves import Arc, Dwell, Move, Vec3

_SIDES = {410: "left", 411: "left", 420: "right", 421: "right"}
#: rs274's refusals of M62-M68 while compensation is on (interp_convert.cc convert_m)
_IO_REFUSED = {
    62: "set a motion digital output",
    63: "set a motion digital output",
    64: "set an auxiliary digital output",
    65: "set an auxiliary digital output",
    66: "wait for a digital input",
    67: "set a motion analog output",
    68: "set an auxiliary analog output",
}


def check_while_on(comp: CutterComp, w: Words, old: ModalState) -> None:
    """Codes rs274 refuses while compensation is on. A G40 on the same line turns it off
    before the G codes after it in rs274's order (coordinate systems, G10, G92, G28...), not
    before a plane change, M6 or M62-M68, which rs274 runs first."""
    if comp.side is None:
        return
    plane = {170: "XY", 180: "XZ", 190: "YZ"}.get(w.g.get("plane", 0))
    if plane is not None and plane != old.plane:
        raise GcodeError("cannot change planes with cutter radius compensation on; G40 first")
    if w.m.get("tool_change") == 6:
        raise GcodeError("cannot change tools with cutter radius compensation on; G40 first")
    io = w.m.get("io")
    if io is not None:
        raise GcodeError(f"cannot {_IO_REFUSED[io]} (M{io}) with cutter radius compensation on")
    if w.g.get("cutter_comp") == 400:
        return
    if "coordinate_system" in w.g:
        raise GcodeError("cannot change coordinate systems with cutter radius compensation on")
    if "retract" in w.g:
        raise GcodeError("cannot change retract mode with cutter radius compensation on")
    if "path_control" in w.g:
        raise GcodeError("cannot change control mode (G61/G64) with cutter radius compensation on")
    if w.g.get("nonmodal") == 100 and round(w.values.get("L", 0)) in (2, 20):
        p = round(w.values.get("P", 0))
        if p in (0, old.coord_index):
            raise GcodeError(
                "cannot change the active coordinate system with cutter radius compensation on"
            )
    if "tool_length" in w.g:
        raise GcodeError("cannot change tool offset with cutter radius compensation on")
    nonmodal = w.g.get("nonmodal")
    if nonmodal in (280, 300):
        raise GcodeError("cannot use G28 or G30 with cutter radius compensation on")
    # rs274 2.9 lets G92.1-G92.3 through and moves the compensated path with the new offsets,
    # which the compensation here does not follow: refused, a documented difference
    if nonmodal in (920, 921, 922, 923, 520) or "g92_reset" in w.g:
        raise GcodeError("cannot change axis offsets (G92) with cutter radius compensation on")
    if nonmodal == 530:
        raise GcodeError("cannot use G53 with cutter radius compensation on")
    if nonmodal in (281, 301):
        raise GcodeError(
            f"cannot set a reference point ({g_name(nonmodal)}) with cutter radius compensation on"
        )


def switch(
    comp: CutterComp, w: Words, s: ModalState, tool: Callable[[int], Tool | None]
) -> list[Move | Dwell]:
    """G40 / G41 / G42 / G41.1 / G42.1 on this line; returns the moves G40 releases."""
    code = w.g.get("cutter_comp")
    if code is None:
        return []
    if code == 400:
        return comp.turn_off()  # rs274 2.9: the offset point becomes the current point
    if s.plane == "YZ":
        raise GcodeError("cutter radius compensation is only possible in the XY or XZ plane")
    if comp.side is not None:
        raise GcodeError("cannot turn cutter radius compensation on when it is already on")
    v = w.values
    name = g_name(code)
    if code in (411, 421):
        if "D" not in v:
            raise GcodeError(f"{name} with no D word: D is the tool diameter")
        if "L" in v and s.plane != "XZ":
            raise GcodeError(f"{name} with L word, but plane is not G18")
        diameter = v["D"] * s.scale
    else:
        if "D" in v:
            number = round(v["D"])
            if abs(v["D"] - number) > 0.0001:
                raise GcodeError(f"{name} requires D word to be a whole number (a tool number)")
            if number < 0:
                raise GcodeError("negative D word tool radius index used")
        else:
            number = 0  # rs274: no D is index 0, the spindle's entry
        found = tool(number)
        diameter = found.diameter_mm if found is not None else 0.0
    comp.inch = s.inch
    comp.turn_on(_SIDES[code], diameter, s.plane)
    comp.current, comp.programmed, comp.released_end = s.position, s.position, s.work
    return []


def comp_move(
    comp: CutterComp,
    motion: int,
    line: int,
    end: Vec3,
    s: ModalState,
    programmed_arc: Arc | None,
    r_format: bool,
) -> list[Move | Dwell]:
    """A G0/G1/G2/G3 under active compensation; returns the moves it releases."""
    if motion in (0, 10):
        return straight(comp, motion == 0, line, end, s.feed_mm_per_min, s.frame)
    assert programmed_arc is not None
    turn = programmed_arc.turns if programmed_arc.direction == "ccw" else -programmed_arc.turns
    center = (programmed_arc.center[0], programmed_arc.center[1])
    return arc(comp, line, end, center, turn, r_format, programmed_arc.feed_mm_per_min, s.frame)
