"""A dialect's own limits on a block: its codes, letters and language (grbl's are narrow).

LinuxCNC's rules are the base (codes.py, words.py); a dialect that knows fewer G/M codes or word
letters, or has no parameters, expressions and O-words (grbl 1.1), refuses the rest here with a
message that names the word.
"""

from __future__ import annotations

import re

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.codes import M_GROUPS, g_name, m_accepted
from gantry_sim.controller.gcode.dialects import Dialect
from gantry_sim.controller.gcode.lexer import COMMENT, Block, strip_line
from gantry_sim.controller.gcode.words import Words

#: M codes of LinuxCNC (every dialect without its own list); M56 is grbl's alone; user M-codes
#: M100-M199 are checked for their program file by the interpreter.
LINUXCNC_M = frozenset(M_GROUPS) - {56}
#: what a grbl jog may carry besides X/Y/Z and F
_JOG_G = frozenset((200, 210, 900, 910, 530))


def _plain(tree: tuple) -> bool:
    return tree[0] == "num" or (tree[0] == "neg" and tree[1][0] == "num")


def check_plain(block: Block, d: Dialect) -> None:
    """No parameters or expressions (a dialect without LinuxCNC's language), and one sign at
    most before a number (grbl's read_float: ``X+-1`` is error 2, a bad number format)."""
    if block.settings or not all(_plain(t) for _, t in block.words):
        raise GcodeError(
            f"'#' parameters and [expressions] are not {d.name} features; {d.name} expects a "
            "command letter followed by a number"
        )
    signs = _SIGNS.search(strip_line(block.text).replace(COMMENT, ""))
    if signs is not None:
        raise GcodeError(
            f"bad number format '{signs.group()}...': {d.name} reads one sign (+ or -) at most "
            "before a number"
        )


_SIGNS = re.compile(r"[+-][+-]+")


def check_codes(w: Words, d: Dialect) -> None:
    """Every G and M code and every letter is one the dialect knows."""
    if d.g_codes is not None:
        for code in w.g.values():
            if code not in d.g_codes:
                raise GcodeError(f"{g_name(code)} is not supported: {d.name} has no {g_name(code)}")
    allowed_m = LINUXCNC_M if d.m_codes is None else d.m_codes
    for code in w.m.values():
        if code not in allowed_m:
            raise GcodeError(f"unsupported M code M{code}; {m_accepted(d.name, allowed_m)}")
    if d.letters is not None:
        for letter in w.values:
            if letter not in d.letters:
                raise GcodeError(f"{letter} word is not supported: {d.name} has no {letter} word")


def check_jog(w: Words) -> None:
    """A grbl ``$J=`` line: only G20/G21, G90/G91, G53, X/Y/Z and a required F."""
    for code in w.g.values():
        if code not in _JOG_G:
            raise GcodeError(f"{g_name(code)} is not supported in a $J= jog (G20/21, G90/91, G53)")
    if w.m:
        raise GcodeError("M codes are not supported in a $J= jog")
    for letter in w.values:
        if letter not in "XYZF":
            raise GcodeError(f"{letter} word with no code that uses it in a $J= jog")
    if "F" not in w.values or w.values["F"] <= 0.0:
        raise GcodeError("a $J= jog needs its own F (units per minute, > 0): zero feed rate")
