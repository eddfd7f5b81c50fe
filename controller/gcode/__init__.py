"""The interpreter: G-code text + dialect -> exact moves (and, when asked, events).

Entry points: :func:`interpret` (text, dialect) -> moves (controller/moves.py: Rapid, Linear,
Arc), in the machine's work frame [mm, mm/min], each with its source line; and
:func:`interpret_events`, the same with dwells, stops and limit changes among them. Invalid
input raises GcodeError with FILE:LINE and what is allowed.

The steps, in the order a line goes through them (module: its one job):

1. ``lexer``           text -> one Block of words per source line (comments, N, %, block delete)
   ``expressions``     numbers, parameters and [expressions]: parsed trees and their evaluation
   ``parameters``      the parameter table: #n, named local #<x> and global #<_x>
   ``predefined``      LinuxCNC's read-only named parameters (#<_x>, #<_metric>, ...)
2. ``control``         running the lines: O-word subroutines, loops, conditionals, their bounds
   ``printer_codes``   Marlin's and g2core's own lines, sorted out before the shared step
3. ``words``           a block's words evaluated and checked against the codes that use them
   ``codes``           which G and M codes exist, their modal groups, what is done with each
   ``dialects``        each dialect's rules, as data; ``dialect_checks`` its own limits on a block
4. ``interpreter``     Interpreter.step: validate a block on a copy of the state, then commit
   ``state``           ModalState, what persists from block to block
   ``coords``          G54-G59.3, G10, the G92 family, G28/G30 and their stored positions
   ``frames``          program coordinates -> the machine's work frame (offsets, XY rotation)
   ``polar``           @ radius and ^ angle
   ``tools``           tool tables and tool length offsets (T, M6, G43)
   ``feed_modes``      G93 inverse time and G95 per revolution -> path speed
   ``modal_save``      M70-M73, the saved modal state
   ``motion_waits``    the commands a controller runs with motion stopped: a stop before the
                       block (LinuxCNC's, grbl's, g2core's rules)
5. ``arc_block``       one G2/G3 block -> an Arc, with the dialect's numbered checks
   ``arc_centre``      the centre from IJK or R, and the swept angle, in plane coordinates
"""

from __future__ import annotations

from typing import Any

__all__ = ["interpret", "interpret_events", "parse_program"]


def __getattr__(name: str) -> Any:
    """The entry points, imported on first use: ``gantry`` reads the dialect table at start-up
    and must not pay for the interpreter (and numpy) until a command interprets a program."""
    if name in __all__:
        from gantry_sim.controller.gcode import interpreter

        return getattr(interpreter, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
