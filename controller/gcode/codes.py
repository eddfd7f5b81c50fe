"""Which G and M codes exist, their modal groups, and what gantry-sim does with each.

Codes are kept in tenths (G90.1 -> 901) so that comparisons are exact. Modal groups follow
LinuxCNC (two codes of one group on a line is an error). Each code is either handled by the
interpreter, accepted as having no effect on the X/Y/Z tool-tip path in work coordinates
(spindle, coolant, tool change, path blending, work offsets, which do not move the work
coordinates), or refused with the reason.
"""

from __future__ import annotations

# G code (tenths) -> modal group name ("nonmodal" is LinuxCNC's group 0).
G_GROUPS: dict[int, str] = {
    **dict.fromkeys((0, 10, 20, 30, 330, 331, 382, 383, 384, 385, 50, 51, 52, 730, 760), "motion"),
    **dict.fromkeys((740, 800, 810, 820, 830, 840, 850, 860, 870, 880, 890), "motion"),
    **dict.fromkeys((170, 180, 190, 171, 181, 191), "plane"),
    **dict.fromkeys((900, 910), "distance"),
    **dict.fromkeys((901, 911), "arc_distance"),
    **dict.fromkeys((930, 940, 950), "feed_mode"),
    **dict.fromkeys((200, 210), "units"),
    **dict.fromkeys((400, 410, 411, 420, 421), "cutter_comp"),
    **dict.fromkeys((430, 431, 432, 490), "tool_length"),
    **dict.fromkeys((980, 990), "retract"),
    **dict.fromkeys((540, 550, 560, 570, 580, 590, 591, 592, 593), "coordinate_system"),
    **dict.fromkeys((610, 611, 640), "path_control"),
    **dict.fromkeys((960, 970), "spindle_mode"),
    **dict.fromkeys((70, 80), "lathe_mode"),
    **dict.fromkeys((40, 100, 280, 281, 300, 301, 520, 530, 920, 921, 922, 923), "nonmodal"),
    53: "nonmodal",  # G5.3: ends a G5.2 NURBS (rs274's modal group 0)
    **dict.fromkeys((700, 710, 711, 720, 721), "nonmodal"),  # lathe finishing/roughing cycles
}

#: codes the interpreter implements itself (coordinate systems: controller/gcode/coords.py).
# fmt: off
G_HANDLED = frozenset(
    (0, 10, 20, 30, 800, 170, 180, 190, 900, 910, 901, 911, 200, 210, 530,
     540, 550, 560, 570, 580, 590, 591, 592, 593, 100, 280, 281, 300, 301, 920, 921, 922, 923,
     430, 431, 432, 490, 930, 950, 980, 990, 520)
)
#: canned cycles (controller/gcode/canned_cycles.py).
G_HANDLED = G_HANDLED | frozenset((730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890))
#: cutter radius compensation (controller/gcode/cutter_comp.py).
G_HANDLED = G_HANDLED | frozenset((410, 411, 420, 421))
#: splines G5, G5.1, G5.2, G5.3 (controller/gcode/splines.py).
G_HANDLED = G_HANDLED | frozenset((50, 51, 52, 53))

#: codes accepted with no effect on the programmed X/Y/Z tool-tip path in work coordinates.
G_NO_PATH_EFFECT = frozenset(
    (40, 940, 400, 610, 611, 640, 960, 970, 80)
)
# fmt: on
#: refused codes -> why.
G_REFUSED: dict[int, str] = {
    **dict.fromkeys(
        (330, 331, 760),
        "spindle-synchronised motion (threading, rigid tapping) follows the spindle's measured "
        "angle, and gantry-sim simulates no spindle",
    ),
    **dict.fromkeys(
        (382, 383, 384, 385),
        "a probing move ends where a probe input trips, and the simulation has no probe or "
        "workpiece to touch",
    ),
    **dict.fromkeys((171, 181, 191), "UVW planes are not supported on this XYZ machine"),
    70: "lathe diameter mode (G7) reads X as a diameter, and this is a mill (G8, radius mode, is "
    "the default and accepted)",
    **dict.fromkeys(
        (700, 710, 711, 720, 721), "lathe roughing/finishing cycles (G70-G72) need a lathe"
    ),
}

# M code -> modal group (LinuxCNC's M groups 4, 6, 7, 8, 9).
M_GROUPS: dict[int, str] = {
    # M99 after other words: the main program's end (rs274 -g; opening a line it is M98's
    # return, controller/gcode/fanuc_subs.py)
    **dict.fromkeys((0, 1, 2, 30, 60, 99), "stopping"),
    **dict.fromkeys((6, 61), "tool_change"),
    **dict.fromkeys((62, 63, 64, 65, 66, 67, 68), "io"),  # digital/analog outputs, wait input
    **dict.fromkeys((70, 71, 72, 73), "modal_state"),  # save/invalidate/restore/auto-restore
    **dict.fromkeys(range(100, 200), "user"),  # user M-codes: programs M100..M199 (if present)
    **dict.fromkeys((3, 4, 5, 19), "spindle"),  # M19: orient the spindle (R angle, Q, P)
    **dict.fromkeys((7, 8, 9), "coolant"),
    **dict.fromkeys((48, 49, 50, 51, 52, 53, 56), "override"),  # M56: grbl's parking override
}
M_PROGRAM_END = frozenset((2, 30, 99))


def g_name(code: int) -> str:
    """``G90.1`` for 901, ``G1`` for 10."""
    whole, tenth = divmod(code, 10)
    return f"G{whole}" if tenth == 0 else f"G{whole}.{tenth}"


def m_accepted(dialect_name: str, codes: frozenset[int]) -> str:
    """A dialect's own M codes, for messages: "grbl accepts: M0, M1, ..."."""
    return f"{dialect_name} accepts: " + ", ".join(f"M{m}" for m in sorted(codes))


def m_allowed() -> str:
    """The M codes gantry-sim accepts, for messages."""
    return ", ".join(f"M{m}" for m in sorted(M_GROUPS) if m != 56 and m < 100) + (
        ", M100-M199 (when a program file of that name is on the subroutine path)"
    )
