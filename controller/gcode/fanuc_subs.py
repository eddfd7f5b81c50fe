"""LinuxCNC 2.9's Fanuc-style subprograms: ``M98 P<n> [L<count>]`` calls ``O<n>`` ... ``M99``.

As rs274 (interp_read.cc read_o, interp_o_word.cc): M98 or M99 must open the line (after an
optional N word); the subprogram starts at a bare ``O<n>`` line (nothing but a comment after
it) and ends at ``M99``. The caller's #1..#30 are passed on, not saved: what the subprogram sets
there stays set after M99. ``L`` repeats the call (``L0``: no call). A bare ``O<n>`` line reached
in sequence is passed over (the program runs into it), and M99 in the main program ends the
program, as ``rs274 -g`` does (LinuxCNC's task would start it again: an endless program).
"""

from __future__ import annotations

import re

from gantry_sim.controller.gcode.lexer import Block

#: a bare O-number line; possessive quantifiers: with no ``/`` or no comment, two ``\s*`` in a
#: row tried every split of a run of spaces, quadratic in its length on every line searched
_BARE_O = re.compile(r"^\s*+/?+\s*+(?:[nN]\s*+\d++\s*+)?+[oO]\s*+(\d++)\s*+(?:\(.*\)|;.*)?\s*+$")


def fanuc_code(block: Block) -> int | None:
    """98 or 99 when the line opens with M98 / M99, else None."""
    if not block.words:
        return None
    letter, tree = block.words[0]
    if letter == "M" and tree[0] == "num" and tree[1] in (98.0, 99.0):
        return int(tree[1])
    return None


def find_program(lines: list[str], start: int, number: int) -> int | None:
    """Index of the bare ``O<number>`` line: searched from ``start`` to the end, then from the
    top (None when there is none)."""
    for i in [*range(start, len(lines)), *range(0, start)]:
        m = _BARE_O.match(lines[i])
        if m is not None and int(m.group(1)) == number:
            return i
    return None
