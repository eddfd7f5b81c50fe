"""What single codes do to the modal state: M48-M53 (overrides), G61/G61.1/G64 (path
control), G93/G94/G95 (whether a feed mode clears the feed), grbl's and g2core's M2/M30, and
Marlin's
M82/M83, G92 E (the extruder) and M220 (the feed percentage). Pure functions of the state:
the interpreter (:mod:`~gantry_sim.controller.gcode.interpreter`) calls them in rs274's order.
"""

from __future__ import annotations

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.coords import SYSTEMS, g92, select_system
from gantry_sim.controller.gcode.dialects import Dialect
from gantry_sim.controller.gcode.feed_modes import INVERSE_TIME, UNITS_PER_MINUTE
from gantry_sim.controller.gcode.parameters import Parameters
from gantry_sim.controller.gcode.printer_codes import FEED_PERCENT_MAX
from gantry_sim.controller.gcode.state import ModalState, evolve
from gantry_sim.controller.moves import PathControl

__all__ = [
    "clears_feed",
    "g2core_program_end",
    "grbl_program_end",
    "overrides",
    "path_control",
    "set_extruder",
    "set_feed_percent",
]


def overrides(
    s: ModalState, code: int, v: dict[str, float], comp_side: str | None
) -> tuple[float, float, float, float]:
    """M48-M53 as rs274's convert_m sets them: M48 / M49 turn the feed and speed overrides on
    / off; M50 (feed override), M51 (speed override), M52 (adaptive feed) and M53 (feed hold)
    turn theirs on unless P is 0 (no P: on). Refused with cutter compensation on."""
    if comp_side is not None:
        raise GcodeError(f"cannot switch overrides (M{code}) with cutter radius compensation on")
    feed, speed, adaptive, hold = s.overrides
    on = 0.0 if v.get("P", -1.0) == 0.0 else 1.0
    if code in (48, 49):
        feed = speed = 1.0 if code == 48 else 0.0
    elif code == 50:
        feed = on
    elif code == 51:
        speed = on
    elif code == 52:
        adaptive = on
    else:
        hold = on
    return (feed, speed, adaptive, hold)


def grbl_program_end(s: ModalState, params: Parameters) -> ModalState:
    """grbl 1.1's M2/M30 (gcode.c, step 21): the planner empties (an exact stop), then G1, G17,
    G90, G94, G54, M5 and M9; F, S, T, G20/G21, G91.1, the G92 offset and the tool length
    offset stay. grbl then reads the next line: the stream goes on."""
    s = evolve(
        s, motion=10, plane="XY", incremental=False, feed_mode=940, spindle=0, mist=False,
        flood=False,
    )  # fmt: skip
    return select_system(s, params, SYSTEMS[540])


def g2core_program_end(s: ModalState, params: Parameters) -> ModalState:
    """g2core's M2/M30 (canonical_machine.cpp ``_exec_program_stop_end`` and
    ``_exec_program_finalize``): the G92 offsets suspended as by G92.2 (kept: a G92.3 or a
    bare G92 turns them back on), G54, G17, G90, G91.1, G94, motion cancelled (G80: axis words
    alone move nothing after it, where NIST and grbl set G1), M5, M9 and the overrides on;
    the units, F, S, the tool, its length offset and the path control stay. Nothing stops the
    reading: the next line runs."""
    s = g92(s, params, 922, {})
    s = evolve(
        s, motion=None, plane="XY", incremental=False, arc_absolute=False, feed_mode=940,
        spindle=0, mist=False, flood=False, overrides=ModalState().overrides,
    )  # fmt: skip
    return select_system(s, params, SYSTEMS[540])


def clears_feed(before: int, mode: int, d: Dialect) -> bool:
    """Whether a G93/G94/G95 word (``mode``; ``before``: the mode it replaces) sets the feed
    to 0 before the line's F is read
    (:attr:`~gantry_sim.controller.gcode.dialects.Dialect.feed_mode_clears_feed`)."""
    rule = d.feed_mode_clears_feed
    leaves = mode == UNITS_PER_MINUTE and before == INVERSE_TIME
    enters = mode == INVERSE_TIME and before == UNITS_PER_MINUTE
    return (
        (rule == "linuxcnc" and mode != INVERSE_TIME)
        or (rule == "grbl" and leaves)
        or (rule == "g2core" and (leaves or enters))
    )


def path_control(code: int, v: dict[str, float], scale: float) -> PathControl:
    """G61 (610), G61.1 (611) or G64 (640) with its P (tolerance) and Q (naive-CAM) words in
    program units times ``scale`` [mm per unit]; a P without Q is also the Q, as LinuxCNC 2.9's
    rs274 does (a G64 with neither leaves both to the machine file)."""
    if code != 640:
        return PathControl("G61" if code == 610 else "G61.1")
    p, q = v.get("P"), v.get("Q")
    # rs274 takes a negative P or Q as 0 (its canonical call prints a tolerance of 0)
    p, q = (None if x is None else max(x, 0.0) for x in (p, q))
    if q is None:
        q = p  # rs274: G64 P without Q sets the naive-CAM tolerance to P (SET_NAIVECAM_TOLERANCE)
    return PathControl("G64", None if p is None else p * scale, None if q is None else q * scale)


def set_extruder(s: ModalState, setting: tuple[str, float]) -> ModalState:
    """Marlin's M82/M83 and G92 E (:attr:`~gantry_sim.controller.gcode.lexer.Block.extruder`):
    the extruder's mode or position; nothing moves."""
    e = s.extruder
    if e is None:
        return s
    what, value = setting
    e = e.with_mode(value != 0.0) if what == "relative" else e.at(value * s.scale)
    return evolve(s, extruder=e)


def set_feed_percent(s: ModalState, restore: bool, backup: bool, percent: int | None) -> ModalState:
    """Marlin's M220 (:attr:`~gantry_sim.controller.gcode.lexer.Block.feed_percent`): R
    restores the backed-up percentage, B backs up the one in effect, S sets it."""
    now, saved = s.feed_percent
    new = saved if restore else now
    if backup:
        saved = now
    if percent is not None:
        if not 1 <= percent <= FEED_PERCENT_MAX:
            raise GcodeError(
                f"M220 S{percent}: the feed percentage must be 1 to {FEED_PERCENT_MAX} "
                "(Marlin would plan the moves after it at no speed, or backwards)"
            )
        new = percent
    return evolve(s, feed_percent=(new, saved))
