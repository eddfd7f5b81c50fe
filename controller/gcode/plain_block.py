"""Plain motion blocks: a G0 or G1 (or the modal one) with X, Y, Z and F words (and E, where the
dialect has an extruder), nothing else.

Most lines of CAM output are such blocks (``G1 X12.3 Y4.56``, ``X12.4 Y4.61 F1200``), and
nearly every line of a printer's file (``G1 X53.2 Y6.48 E14.81``). The interpreter's general
step reads a block's words into modal groups and checks every code, letter, offset, cycle and
compensation rule against it: 45 us a line of 0.05-0.5 mm polylines, three quarters of their
parse. For a plain block most of that can say nothing, so
:meth:`~gantry_sim.controller.gcode.interpreter.Interpreter.step` first asks
:func:`plain_motion` whether the block is one, and runs only what such a block does (its
``_plain_step``); anything else, or a plain block in a state where more applies (cutter
compensation on), takes the general step. The two give the same moves, state and errors
(tests/test_plain_block.py compares them on random programs in every dialect).
"""

from __future__ import annotations

from collections.abc import Sequence

from gantry_sim.controller.gcode.dialects import Dialect
from gantry_sim.controller.gcode.expressions import MAX_MAGNITUDE, Tree

__all__ = ["plain_letters", "plain_motion"]

#: the words a plain block may hold besides its G0 / G1 (and E, with an extruder)
_LETTERS = frozenset("XYZF")


def plain_letters(d: Dialect) -> frozenset[str]:
    """The letters a plain block of dialect ``d`` may hold besides its G: X, Y, Z, F, and E
    where it has an extruder (Marlin); an empty set where a plain block does more than the plain
    step does in ``d`` (its G0 and G1 or one of the letters unknown to it, one of them read as a
    whole number, or rules of its own for which commands wait for motion)."""
    letters = _LETTERS | {"E"} if d.extruder else _LETTERS
    plain = (
        d.motion_waits in ("", "linuxcnc", "grbl", "g2core")
        and (d.g_codes is None or {0, 10} <= d.g_codes)
        and (d.letters is None or (letters | {"G"}) <= d.letters)
        and not (letters & d.integer_words)
    )
    return letters if plain else frozenset()


def plain_motion(
    words: Sequence[tuple[str, Tree]], letters: frozenset[str]
) -> tuple[int | None, dict[str, float]] | None:
    """(the G0 / G1 of the block as a motion code in tenths, 0 or 10, or None where it has
    none; its values of ``letters`` as written) when ``words`` are a plain block's: at most one
    G, of 0 or 1, and each of ``letters`` at most once, every value a number (signed) within
    :data:`~gantry_sim.controller.gcode.expressions.MAX_MAGNITUDE`; else None."""
    motion = None
    values: dict[str, float] = {}
    for letter, tree in words:
        if tree[0] == "num":
            value = tree[1]
        elif tree[0] == "neg" and tree[1][0] == "num":
            value = -tree[1][1]
        else:
            return None
        if letter == "G":
            if motion is not None or value not in (0.0, 1.0):
                return None
            motion = 10 if value == 1.0 else 0
        elif (
            letter in letters and letter not in values and -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE
        ):
            values[letter] = value
        else:
            return None
    return motion, values
