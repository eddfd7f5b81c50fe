"""The commands a controller runs only once motion has stopped: an exact stop before the block.

LinuxCNC's task sends most machine commands that are not motions (the spindle, the coolant,
tool length and coordinate offsets, immediate outputs) only once its motion queue has drained,
so the tool comes to rest at the junction before the block that holds one, even between two
moves in line in G64. The interpreter then puts a zero-time exact stop
(:class:`~gantry_sim.controller.moves.Stop`, its ``code`` the command's) before the block's
motion, where rs274 executes those commands (before the block's motion, RS274/NGC's order of
execution); under cutter compensation it follows the move held back, as a G4 does.

Measured on LinuxCNC 2.9's own planner (``benchmarks/linuxcnc_peer.py``'s ``run_one``,
2026-11-29): in G64 P0.01 at F1200, ``M3 S500``, ``G1 X10``, then the code on a line of its own,
then ``G1 X20``; periods of 1 ms at rest between the two moves:

* at rest (3-115 periods): any S word (its value unchanged, or on the G1 line itself), M3, M4,
  M5, M19, M7, M8, M9, M64, M65, M66, M68, G43 H0, G43.1, G49, G92, G92.1, G55 (another
  coordinate system), G10 L2 P1 and G10 L20 P1 (the active system's offsets), G4 P0;
* passed at speed: F, M62, M63, M67 (outputs synchronised with motion), M48, M50, M70, G10 L2 P2
  (a system not in use), G54 (the one in use), G18, G91, G61, G64 P0.02.

Measured the same way on 2026-11-30, with a tool table of T1-T99 in the peer configuration:
``T2 M6`` (290 periods: the tool change), G10 L1 P2 Z1, G10 L1 P2 R1, G10 L10 P2 Z1 and G10 L11
P2 Z1 (a tool table entry, of a tool not loaded: 10-13 periods) came to rest; ``T2`` (the tool
prepared) and ``M61 Q2`` (the loaded tool's number set) passed at speed. The time LinuxCNC
spends at rest (its I/O handshakes: 3-13 periods, 115 for M9, 290 for the tool change here, a
real changer's seconds) is not modelled: the stop takes no time.

grbl 1.1 (read in its source, gnea/grbl ``gcode.c``, ``spindle_control.c``,
``coolant_control.c``, ``system.c`` and ``config.h``) empties its planner buffer
(``protocol_buffer_synchronize``) before a change of the spindle's state (M3, M4, M5, "even in
laser mode"), of the coolant's (M7, M8, M9), before G10 L2/L20, G28.1 and G30.1 (their EEPROM
writes, ``FORCE_BUFFER_SYNC_DURING_EEPROM_WRITE``), and before every change of the work
coordinate offsets (G54-G59 to another system, G92, G92.1, G43.1 or G49 changing the tool
length offset: ``FORCE_BUFFER_SYNC_DURING_WCO_CHANGE``; both options are on by default), and
only where something changes (M3 while M3 is on passes). A new S with the spindle on syncs too,
except on a line that moves in laser mode ($32 = 1): the ``grbl`` dialect takes an S on a line
without motion as a stop and one on a motion line as a laser's power change, not a stop
(programs that set S on their moves are laser programs; a spindle machine's programs change S
on lines of their own). In laser mode, with the spindle on in M3 (constant power), a line that
moves nothing in its motion mode and changes the mode between G1/G2/G3 and any other (a bare
``G0`` between two cuts) syncs too, so that the power follows (gcode.c's
``GC_PARSER_LASER_FORCE_SYNC``).

g2core (read in its source, synthetos/g2 edge-preview 1fb59404): every command it puts in the
planner queue (``mp_queue_command``: planner.cpp) is a block whose exit speed the back-planning
forces to zero (plan_line.cpp, "TEMPORARY force PTZ"), so the machine stops at it. The commands
of a G-code block that are queued are its S (``spindle_set_speed``: the spindle and ESC
toolheads ask for the stop at every S, changed or not; a laser toolhead may not), T
(``cm_select_tool``), M6 (``cm_change_tool``), M3/M4/M5 (``spindle_set_direction``), M7/M8/M9
(``coolant_control_sync``, whatever the coolant's state), all run before the block's motion
(gcode_parser.cpp ``_execute_gcode_block``), and the program stops and ends (M0, M1, M60,
M2, M30: a stop after the motion, the interpreter's ``Stop`` events). G92, G54-G59, G10,
G20/G21 and G90/G91 change the model only: no stop. (G28.3, which queues too, is run here as
a G92: not modelled.)
"""

from __future__ import annotations

from gantry_sim.controller.gcode.codes import g_name
from gantry_sim.controller.gcode.coords import SYSTEMS
from gantry_sim.controller.gcode.state import ModalState
from gantry_sim.controller.gcode.words import Words

__all__ = ["motion_wait"]

#: grbl's spindle state after an M3, M4, M5 (ModalState.spindle).
_GRBL_SPINDLE = {3: 1, 4: -1, 5: 0}
#: grbl's motion modes that light a laser (G1, G2, G3), and its non-modal axis commands (G10,
#: G28, G30, G92: a line's axis words go to them, not to the motion mode)
_GRBL_POWERED = frozenset((10, 20, 30))
_GRBL_AXIS_NONMODAL = frozenset((100, 280, 300, 920))

#: M codes of the groups below that wait for motion: the spindle's on/off and orient, every
#: coolant code, the immediate outputs and the input wait (M62, M63, M67 go with the motion).
_SPINDLE_M = frozenset((3, 4, 5, 19))
_IO_M = frozenset((64, 65, 66, 68))
#: G52, G92, G92.1, G92.2, G92.3 (tenths): the offsets every system shares.
_SHARED_OFFSETS = frozenset((520, 920, 921, 922, 923))
#: G10 L1, L10, L11: a tool table entry (any tool, loaded or not).
_TOOL_TABLE_L = frozenset((1.0, 10.0, 11.0))


def motion_wait(w: Words, before: ModalState, rules: str) -> str | None:
    """The first command of block ``w`` (read after ``before``, the state it starts from) that
    the controller runs only with motion stopped, named as in the program ("S", "M8",
    "G43"...), or None when the block has none; ``rules``: whose ("linuxcnc", "grbl",
    "g2core"; "": none modelled). See the module docstring."""
    if rules == "grbl":
        return _grbl_wait(w, before)
    if rules == "g2core":
        return _g2core_wait(w)
    if rules != "linuxcnc":
        return None
    if "S" in w.values:
        return "S"
    spindle = w.m.get("spindle")
    if spindle in _SPINDLE_M:
        return f"M{spindle}"
    if "coolant" in w.m:
        return f"M{w.m['coolant']}"
    if w.m.get("tool_change") == 6:
        return "M6"
    if w.m.get("io") in _IO_M:
        return f"M{w.m['io']}"
    if "tool_length" in w.g:
        return g_name(w.g["tool_length"])
    system = w.g.get("coordinate_system")
    if system is not None and SYSTEMS[system] != before.coord_index:
        return "G5x"
    nonmodal = w.g.get("nonmodal")
    if nonmodal in _SHARED_OFFSETS:
        return "G92" if nonmodal != 520 else "G52"
    if "g92_reset" in w.g:  # G92.1-G92.3, a group apart in rs274 (words.read_words)
        return "G92"
    if nonmodal == 100 and (w.values.get("L") in _TOOL_TABLE_L or _sets_active_system(w, before)):
        return "G10"
    return None


def _g2core_wait(w: Words) -> str | None:
    """:func:`motion_wait` by g2core's rules (module docstring): S, T, M6, M3-M5, M7-M9."""
    for letter in "ST":
        if letter in w.values:
            return letter
    if w.m.get("tool_change") == 6:
        return "M6"
    spindle = w.m.get("spindle")
    if spindle in _GRBL_SPINDLE:
        return f"M{spindle}"
    if "coolant" in w.m:
        return f"M{w.m['coolant']}"
    return None


def _sets_active_system(w: Words, before: ModalState) -> bool:
    """G10 L2 or L20 on the system in use (P0 is the one in use)."""
    if w.values.get("L") not in (2.0, 20.0):
        return False
    return w.values.get("P", 0.0) in (0.0, float(before.coord_index))  # (checked later)


def _grbl_wait(w: Words, before: ModalState) -> str | None:
    """:func:`motion_wait` by grbl 1.1's rules (module docstring)."""
    moves = any(a in w.values for a in "XYZ")
    if "S" in w.values and before.spindle != 0 and not moves and w.values["S"] != before.rpm:
        return "S"
    motion = w.g.get("motion", before.motion)
    axis_command = w.g.get("nonmodal") in _GRBL_AXIS_NONMODAL or "tool_length" in w.g
    if before.spindle == 1 and not (moves and not axis_command):  # M3, no motion on the line
        if (before.motion in _GRBL_POWERED) != (motion in _GRBL_POWERED):
            return g_name(motion) if motion is not None else "G80"
    spindle = w.m.get("spindle")
    if spindle in _GRBL_SPINDLE and _GRBL_SPINDLE[spindle] != before.spindle:
        return f"M{spindle}"
    coolant = w.m.get("coolant")
    if coolant is not None:
        mist = coolant == 7 or (before.mist and coolant == 8)
        flood = coolant == 8 or (before.flood and coolant == 7)
        if (mist, flood) != (before.mist, before.flood):
            return f"M{coolant}"
    nonmodal = w.g.get("nonmodal")
    if nonmodal in (100, 281, 301, 920, 921):  # G10, G28.1, G30.1, G92, G92.1
        return g_name(nonmodal)
    system = w.g.get("coordinate_system")
    if system is not None and SYSTEMS[system] != before.coord_index:
        return "G5x"
    length = w.g.get("tool_length")
    if length == 490 and any(before.tool_offset_mm):
        return "G49"
    if length == 431 and w.values.get("Z", 0.0) * before.scale != before.tool_offset_mm[2]:
        return "G43.1"
    return None
