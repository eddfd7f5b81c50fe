"""A dialect's own limits on a block: its codes, letters and language (grbl's are narrow).

LinuxCNC's rules are the base (codes.py, words.py); a dialect that knows fewer G/M codes or word
letters, or has no parameters, expressions and O-words (grbl 1.1), refuses the rest here with a
message that names the word.
"""

from __future__ import annotations

import functools
import math
import re

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.codes import G_GROUPS, M_GROUPS, g_name, m_accepted
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


def check_signs(block: Block, d: Dialect) -> None:
    """One sign at most before a number (grbl's read_float, g2core's c_atof: ``X--5`` is a
    bad number format; rs274 reads it as -(-5))."""
    signs = _SIGNS.search(strip_line(block.text).replace(COMMENT, ""))
    if signs is not None:
        raise GcodeError(
            f"bad number format '{signs.group()}...': {d.name} reads one sign (+ or -) at most "
            "before a number"
        )


def check_plain(block: Block, d: Dialect) -> None:
    """No parameters or expressions (a dialect without LinuxCNC's language), and one sign at
    most before a number (grbl's read_float: ``X+-1`` is error 2, a bad number format). The
    first offence on the line wins, as grbl reads left to right: a ``#`` where a word's letter
    is expected (error 1), a word whose value is not a number (``X#1``, ``X[1+2]``: error 2)."""
    bad = next((k for k, (_, t) in enumerate(block.words) if not _plain(t)), None)
    setting = None  # the word index of the first '#' setting
    if block.settings:
        setting = block.settings_at[0] if block.settings_at else len(block.words)
    if setting is not None and (bad is None or setting <= bad):
        raise GcodeError(
            f"'#' parameters and [expressions] are not {d.name} features; {d.name} expects a "
            "command letter followed by a number"
        )
    if bad is not None:
        letter = block.words[bad][0]
        raise GcodeError(
            f"bad number format after {letter}: {letter} takes a plain number ('#' parameters "
            f"and [expressions] are LinuxCNC's, {d.name} has none)"
        )
    check_signs(block, d)
    if d.read_order == "grbl":
        _check_grbl_read_order(block, d)


#: grbl's axis commands (gcode.c): G0-G3 and G38.x, G10, G28, G30, G92 (not G28.1, G30.1,
#: G92.1), G43.1 and G49; two on one line are error 24
_GRBL_AXIS_COMMANDS = frozenset((0, 10, 20, 30, 382, 383, 384, 385, 100, 280, 300, 920, 431, 490))
#: grbl's largest tool number (MAX_TOOL_NUMBER, a byte)
_GRBL_MAX_TOOL = 255
#: grbl's largest line number (MAX_LINE_NUMBER, config.h), compared with N's truncated value
_GRBL_MAX_LINE_NUMBER = 10_000_000
#: codes whose other decimal parts grbl refuses as unsupported (error 20), not as "not an
#: integer" (23): G28.x, G30.x, G38.x, G43.x, G61.x, G90.x, G91.x, G92.x
_GRBL_OTHER_DECIMALS_UNSUPPORTED = frozenset((280, 300, 380, 430, 610, 900, 910, 920))


@functools.cache
def _wholes(codes: frozenset[int]) -> frozenset[int]:
    """The whole parts (in tenths) of G codes given in tenths: G38.2 -> G38."""
    return frozenset(c - c % 10 for c in codes)


#: words grbl refuses negative as it reads them (gcode.c: error 4)
_GRBL_NOT_NEGATIVE = "FNPST"


def _check_grbl_read_order(block: Block, d: Dialect) -> None:
    """grbl's checks made word by word as it reads a line (gcode.c ``gc_execute_line``, step
    1), so that the first offending word names the error: a G or M code grbl does not know
    (error 20; a decimal part grbl refuses, G28.2, G61.1, G91.2, also 20), a known code with a
    decimal part (G1.5, G59.1, M3.5: "command value not integer", error 23), a second axis
    command (``G0 G1``, ``G92 X1 G0``, ``G28 G92``: error 24, before the modal group), a second
    code of a modal group (``G0 X1 G80``: error 21), a negative F, N, P, S or T (error 4), a
    word of LinuxCNC's ``@``, ``^`` or ``$``, which are no letters to grbl (error 1). A
    repeated letter stops the reading: read_words names it (error 25). Then the first check of
    step 3: an N above grbl's largest line number (error 27)."""
    assert d.g_codes is not None and d.m_codes is not None
    axis_command = False
    groups: dict[str, int] = {}
    letters: set[str] = set()
    for letter, tree in block.words:
        value = tree[1] if tree[0] == "num" else -tree[1][1]
        if letter in "GM":
            g = letter == "G"
            # gcode.c: int_value = trunc(value), mantissa = round(100 * (value - int_value)),
            # into a uint8_t and a uint16_t: G257 is a G1 with a mantissa of 25600
            int_value = math.trunc(value)
            if value >= 0:
                int_value %= 256
            mantissa = round(100 * (value - int_value)) % 65536
            whole = int_value * 10 if g else int_value
            if value >= 256 and (mantissa or not g):
                _refuse_wrapped(letter, value, int_value, whole, d)
            # a G code in tenths (G28.1: mantissa 10); -1: a decimal part no code has (G1.05)
            if g:
                code = whole + mantissa // 10 if mantissa % 10 == 0 and mantissa < 100 else -1
            else:
                code = whole
            known = d.g_codes if g else d.m_codes
            name = g_name(code) if code in known and (g or not mantissa) else f"{letter}{value:g}"
            if not g and mantissa and value >= 0:  # gcode.c checks an M's mantissa first
                raise GcodeError(
                    f"{name} is not a {d.name} code: M{whole} takes no decimal part (command "
                    "value not integer)"
                )
            if value < 0 or whole not in (_wholes(known) if g else known):
                raise GcodeError(f"{name} is not supported: {d.name} has no {name}")
            if code not in known or (not g and mantissa):
                if whole in _GRBL_OTHER_DECIMALS_UNSUPPORTED:
                    raise GcodeError(f"{name} is not supported: {d.name} has no {name}")
                whole_name = g_name(whole) if g else f"M{whole}"
                raise GcodeError(
                    f"{name} is not a {d.name} code: {whole_name} takes no decimal part "
                    "(command value not integer)"
                )
            if g and code in _GRBL_AXIS_COMMANDS:
                if axis_command:
                    raise GcodeError(
                        f"axis command conflict: {name} and another of G0-G3, G10, G28, G30, "
                        f"G38.x, G43.1, G49, G92 on one line; {d.name} takes one per line"
                    )
                axis_command = True
            group = (G_GROUPS if g else M_GROUPS)[code]
            if letter + group in groups:
                first = groups[letter + group]
                names = (g_name(first), name) if g else (f"M{first}", name)
                raise GcodeError(
                    f"two {letter} codes from one modal group on a line ({names[0]} and "
                    f"{names[1]}); use one {group.replace('_', ' ')} code per line"
                )
            groups[letter + group] = code
        elif not letter.isalpha():  # LinuxCNC's @ ^ $: no letter to grbl's reader (error 1)
            raise GcodeError(
                f"bad character {letter!r}; {d.name} expects a command letter A-Z followed by "
                "a number"
            )
        elif d.letters is not None and letter not in d.letters:  # as gcode.c meets it
            raise GcodeError(f"{letter} word is not supported: {d.name} has no {letter} word")
        elif letter in letters:
            return  # read_words names a repeated letter
        else:
            letters.add(letter)
            if letter in _GRBL_NOT_NEGATIVE and value < 0.0:
                raise GcodeError(f"negative {letter} word; {letter} must be >= 0 on {d.name}")
            if letter == "T" and value > _GRBL_MAX_TOOL:
                raise GcodeError(
                    f"T{value:g} is above {d.name}'s largest tool number, {_GRBL_MAX_TOOL}"
                )
    line_number = next((tree for letter, tree in block.words if letter == "N"), None)
    if line_number is not None and line_number[0] == "num":  # a negative one is error 4
        if math.trunc(line_number[1]) > _GRBL_MAX_LINE_NUMBER:
            raise GcodeError(
                f"invalid line number N{line_number[1]:.10g}: {d.name} takes line numbers up "
                f"to {_GRBL_MAX_LINE_NUMBER:,}"
            )
    if groups.get("Gtool_length") == 431 and letters & set("XYZ") != {"Z"}:
        raise GcodeError("G43.1 on grbl takes a Z word (the tool length offset) and no other axis")


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
            has_none = f" ({d.name} has no M{code})" if d.m_codes is not None else ""
            raise GcodeError(
                f"unsupported M code M{code}{has_none}; {m_accepted(d.name, allowed_m)}"
            )
    if d.letters is not None:
        for letter in w.values:
            if letter not in d.letters:
                raise GcodeError(f"{letter} word is not supported: {d.name} has no {letter} word")
    if w.g.get("nonmodal") == 100 and "L" in w.values:
        _check_g10_numbers(w.values, d)


def _check_g10_numbers(v: dict[str, float], d: Dialect) -> None:
    """G10's L and (L2/L20) P among those the dialect has (``g10_levels``,
    ``g10_p0_current``: g2core's cm_set_g10_data)."""
    level = round(v["L"])
    if d.g10_levels is not None and level not in d.g10_levels:
        raise GcodeError(f"G10 L{level} is not supported: {d.name} has no G10 L{level}")
    if d.max_tool_number is not None and level in (1, 10):
        p = math.trunc(v.get("P", 0.0))
        if not 1 <= p <= d.max_tool_number:
            raise GcodeError(
                f"G10 L{level} P{p}: {d.name}'s tool table has tools 1 to {d.max_tool_number}"
            )
    if d.g10_p0_current or level not in (2, 20):
        return
    p = math.trunc(v.get("P", 0.0))
    if not 1 <= p <= d.coordinate_systems:
        raise GcodeError(
            f"G10 L{level} P{p} is not supported: {d.name} has no P{p} here, only its "
            f"{d.coordinate_systems} coordinate systems P1 (G54) .. P{d.coordinate_systems}"
        )


def check_jog(w: Words) -> None:
    """A grbl ``$J=`` line, before the block's own checks: its own F (gcode.c checks it first
    in a jog: error 22)."""
    if "F" not in w.values or w.values["F"] <= 0.0:
        raise GcodeError("a $J= jog needs its own F (units per minute, > 0): zero feed rate")


def jog_moves_as_g1(w: Words) -> bool:
    """Whether a grbl ``$J=`` line's axis words are a G1's: unless the line names a command that
    takes them itself (a motion or G80, G10, G28, G30, G43.1, G49, G92), which grbl checks as
    that command before it refuses the jog."""
    return "motion" not in w.g and _GRBL_AXIS_COMMANDS.isdisjoint(w.g.values())


def check_jog_after(w: Words) -> None:
    """A grbl ``$J=`` line that passed the block's own checks (gcode.c's step 3, where a G2 in
    a jog is checked as any arc is): S and T, which a jog leaves unused (error 36), then any
    code but G20/G21, G90/G91 and G53 (error 16, an invalid jog command)."""
    for letter in "ST":
        if letter in w.values:
            raise GcodeError(f"{letter} word with no code that uses it in a $J= jog")
    codes = [g_name(c) for c in w.g.values() if c not in _JOG_G] + [f"M{c}" for c in w.m.values()]
    if codes:
        raise GcodeError(
            f"invalid jog command: {codes[0]} in a $J= jog, which takes axis words, F, N and "
            "only G20/G21, G90/G91 and G53"
        )


def _refuse_wrapped(letter: str, value: float, int_value: int, whole: int, d: Dialect) -> None:
    """A G or M number above 255, which grbl's gcode.c reads into one byte (``int_value``, the
    number modulo 256) with the rest left as a mantissa of 100 and more: an M is refused at
    once (error 23: no Mxx.x); a G goes on as G``int_value`` with that mantissa, an error 20
    where that code examines its decimal part itself (G28, G38, G61...: none matches) or grbl
    has no such code, else 23."""
    name = f"{letter}{value:g}"
    known = _wholes(d.g_codes or frozenset())
    if letter == "G" and (whole not in known or whole in _GRBL_OTHER_DECIMALS_UNSUPPORTED):
        raise GcodeError(f"{name} is not supported: {d.name} has no {name}")
    raise GcodeError(
        f"{name} is not a {d.name} code: its command number is read into one byte, so {name} "
        f"reads as {letter}{int_value} with a decimal part, and {letter}{int_value} takes no "
        "decimal part (command value not integer)"
    )
