"""Step 1 and 2 of a block: evaluate its words and check that each has a code that uses it.

A block's G and M codes are sorted into LinuxCNC's modal groups (two of one group is an error,
except G80 beside another motion code, which rs274 ignores); every other letter appears at most
once and must have a code on the line (or the modal motion) that uses it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.codes import G_GROUPS, M_GROUPS, g_name, m_accepted, m_allowed
from gantry_sim.controller.gcode.dialects import LINUXCNC, Dialect
from gantry_sim.controller.gcode.expressions import (
    MAX_MAGNITUDE,
    ParameterReader,
    Tree,
    evaluate,
)
from gantry_sim.controller.gcode.lexer import Block
from gantry_sim.controller.gcode.parameters import (
    INTEGER_TOL,
    MAX_PARAMETER,
    MAX_SETTABLE_PARAMETER,
    SETTABLE_SYSTEM,
    parameter_index,
)

_OTHER_AXES = "ABCUVW"
#: rotary axes rs274 -g has (A/B/C); a word of 0 keeps such an axis where it always is (at 0)
ROTARY_AXES = "ABC"
#: canned cycles (tenths): they take R and L (and P, Q, I/J/K as each needs).
_CYCLES = frozenset((730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890))
#: motion codes rs274 runs only with an axis word on their line (G5, G5.1, G33, G33.1, G38.x and
#: the canned cycles; not G0-G3, G5.2, G76 or G80)
_NEED_AXES = _CYCLES | {50, 51, 330, 331, 382, 383, 384, 385}
#: the codes that take each word only some codes use (for the unused-word message)
_RS274_NEEDS = {
    "P": "G2, G3, G4, G5, G5.2, G10, G64, G76, G82, G86, G88, G89, M19, M50-M53, M62-M66, M98 "
    "or a user M code (M100-M199)",
    "Q": "G64, G73 or G83",
    "H": "G43 or G43.2",
    "R": "G2, G3 or a canned cycle",
    "D": "G41, G41.1, G42, G42.1 or G96",
    "L": "G10 or a canned cycle",
    "E": "a code that takes E (none here; G-code numbers have no exponent, so 1e3 reads as 1 "
    "then an E word)",
}
#: M groups kept apart here that rs274 reads as one (group 7: M3-M5 and M19 with M70-M73)
_SHARED_M_GROUP = {"spindle": "modal_state", "modal_state": "spindle"}
#: G92.1, G92.2, G92.3: in rs274 2.9 a modal group apart from group 0's G4, G10, G28.1...
#: (``G10 L2 P1 X1 G92.1`` runs both; ``G92.1 G92.2`` is two codes of one group)
_G92_RESETS = frozenset((921, 922, 923))
#: grbl 1.1's codes that take each word only some codes use (for its unused-word message)
_GRBL_NEEDS = {"P": "G4 or G10", "L": "G10", "R": "G2 or G3", "I": "G2 or G3", "J": "G2 or G3",
               "K": "G2 or G3"}  # fmt: skip
#: the words that count as axis words there (rs274's axis_flag: polar @ and ^ too)
_AXIS_FLAGS = frozenset("XYZABCUVW@^")
#: Letters every block may carry (axes, feed, spindle speed, tool; a rotary axis at 0; N, a
#: line number read as a word by the dialects whose lexer does so, grbl and g2core).
_ANY_CODE = frozenset("XYZFSTN@^$" + ROTARY_AXES)


@dataclass(frozen=True)
class Words:
    """One block's evaluated words: G and M codes by modal group, other letters by letter.

    ``r_before_arc_code``: an R word came before any G2/G3 on the line (or the line has none).
    """

    line: int
    g: dict[str, int]
    m: dict[str, int]
    values: dict[str, float]
    settings: tuple[tuple[int | str, float], ...]
    r_before_arc_code: bool = False


def _code(value: float, tenths: bool) -> int | None:
    """The whole (or, ``tenths``, tenths) code of a G/M value; None when it is not one."""
    scaled = value * 10 if tenths else value
    if not -1e6 < scaled < 1e6:
        return None
    code = round(scaled)
    return code if abs(scaled - code) < 1e-6 else None


def _g_code(value: float, dialect: Dialect | None) -> int | None:
    """A G word's code in tenths (:func:`_code`), or, where the dialect reads the decimal
    part of some codes only (``Dialect.g_point_codes``), any other read as its whole number
    (g2core's ``switch ((uint8_t)value)``: G59.1 is G59, G1.5 is G1)."""
    points = None if dialect is None else dialect.g_point_codes
    if points is not None and 0.0 <= value < 256.0 and int(value) * 10 not in points:
        return int(value) * 10
    if (dialect or LINUXCNC).rs274_code_numbers and -1e6 < value < 1e6:
        # rs274's read_g: ten times the value, floored; within 0.001 above that or 0.001 below
        # the next it is that tenth (G0.0001 is G0), else "G-code out of range"
        tenths = 10.0 * value
        low = math.floor(tenths)
        if tenths - low > 0.999:
            return low + 1
        if tenths - low > 0.001:
            raise GcodeError(
                f"G code out of range: G{value:g}; a G number has one decimal at most (G1, "
                "G92.1), within 0.0001"
            )
        return low
    return _code(value, True)


def _has_none(dialect: Dialect | None, value: float) -> str:
    """ " (g2core has no M98)" where the dialect has M codes of its own, else "" (also for a
    decimal code, which may be one of the dialect's: g2core's M50.2 is refused, its M50.1
    not)."""
    if dialect is None or dialect.m_codes is None or value != int(value):
        return ""
    return f" ({dialect.name} has no M{value:g})"


def _m_list(dialect: Dialect | None) -> str:
    """The M codes ``dialect`` accepts, as a message says them."""
    if dialect is None or dialect.m_codes is None:
        return f"allowed: {m_allowed()}"
    return m_accepted(dialect.name, dialect.m_codes)


#: The largest tool number: rs274 reads T, H and M61's Q into a C int, so T2147483648 wraps to
#: a negative tool id and is refused ("Negative tool id", checked with LinuxCNC 2.9's rs274 -g,
#: 2026-12-02; T2147483647 is looked up in the tool table as any other).
MAX_TOOL_NUMBER = 2**31 - 1


def check_tool_number(letter: str, value: float, dialect: Dialect | None = None) -> None:
    """GcodeError when the tool number ``value`` of word ``letter`` (T, H, M61's Q) is beyond
    :data:`MAX_TOOL_NUMBER`, or the dialect's own largest (``Dialect.max_tool_number``)."""
    if dialect is not None and dialect.max_tool_number is not None:
        top = dialect.max_tool_number
        if value >= top + 1:
            raise GcodeError(
                f"{letter}{value:g}: {dialect.name} has tools 0 to {top} (its tool table's size)"
            )
    if value >= MAX_TOOL_NUMBER + 0.5:
        raise GcodeError(
            f"{letter}{value:.17g} is beyond the largest tool number: tool numbers are 0 to "
            f"{MAX_TOOL_NUMBER} (LinuxCNC's rs274 reads a larger one as a negative tool id and "
            "refuses it)"
        )


def whole_number(letter: str, value: float) -> float:
    """``value`` of an integer word (T, H, L in LinuxCNC) as rs274 reads it: the whole number
    within :data:`INTEGER_TOL` of it (T1.99995 is T2), else GcodeError (T1.5, L19.6)."""
    low = math.floor(value)
    if value - low > 1.0 - INTEGER_TOL:
        return float(low + 1)
    if value - low > INTEGER_TOL:
        raise GcodeError(
            f"{letter}{value:g} is not an integer; {letter} takes a whole number (within "
            f"{INTEGER_TOL:g} of one)"
        )
    return float(low)


def _number(tree: Tree, params: ParameterReader) -> float:
    """``evaluate(tree, params)``, with a plain number (most words) read at once."""
    kind = tree[0]
    if kind == "num":
        value = tree[1]
    elif kind == "neg" and tree[1][0] == "num":
        value = -tree[1][1]
    else:
        return evaluate(tree, params)
    if -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:
        return value
    return evaluate(tree, params)  # raises, saying why


def read_words(
    block: Block,
    params: ParameterReader,
    dialect: Dialect | None = None,
    create: Callable[[str], None] | None = None,
) -> Words:
    """Step 1: evaluate the block's values (with parameters as they were before the line);
    ``dialect``: whose M codes an unknown one's message lists and whose integer words are
    read as rs274 reads them (default LinuxCNC's). ``create``: called with the name of each
    ``#<name>=`` setting where the line's reading reaches it, before the words after it are
    read (rs274's add_named_param: the rest of the line reads a new name as 0)."""
    at = block.settings_at or (len(block.words),) * len(block.settings)
    settings: list[tuple[int | str, float]] = []
    done = 0  # settings read so far (the line is read in order: words and settings)
    g: dict[str, int] = {}
    m: dict[str, int] = {}
    values: dict[str, float] = {}
    r_before_arc_code = False
    last_wins = dialect is not None and dialect.last_word_wins
    for k, (letter, tree) in enumerate(block.words):
        while done < len(at) and at[done] <= k:
            settings.append(_setting(block.settings[done], params, create))
            done += 1
        value = _number(tree, params)
        if letter == "G":
            code = _g_code(value, dialect)
            group = None if code is None else G_GROUPS.get(code)
            if code in _G92_RESETS and (dialect or LINUXCNC).g92_resets_apart:
                group = "g92_reset"  # rs274 2.9: a group of their own, run after group 0's
            if code is None or group is None:
                raise GcodeError(f"unknown G code G{value:g}; see README 'Dialects' for the list")
            if group == "motion" and 800 in (code, g.get(group)) and not last_wins:
                # rs274: G80 beside another motion code is ignored ("G0 X1 G80" is a G0).
                g[group] = g.get(group, 800) if code == 800 else code
                continue
            if group in g and not last_wins:
                raise GcodeError(
                    f"two G codes from one modal group on a line ({g_name(g[group])} and "
                    f"{g_name(code)}); use one {group.replace('_', ' ')} code per line"
                )
            g[group] = code
        elif letter == "M":
            if (dialect or LINUXCNC).rs274_code_numbers:
                value = whole_number("M", value)  # rs274's read_integer_value: M5.0001 is M5
            if dialect is not None and dialect.m_whole_codes and 0.0 <= value < 256.0:
                whole = float(math.trunc(value))
                point = math.floor(10.0 * value + 0.5) - 10.0 * whole  # _point(): std::round
                if whole == 50.0 and point == 1:
                    continue  # M50.1: g2core's traverse override control, which it leaves unrun
                if whole != 50.0 or point == 0:
                    value = whole
            code = _code(value, False)
            group = None if code is None else M_GROUPS.get(code)
            if code is None or group is None:
                raise GcodeError(
                    f"unsupported M code M{value:g}{_has_none(dialect, value)}; {_m_list(dialect)}"
                )
            if group in m and not last_wins:
                raise GcodeError(
                    f"two M codes from one modal group on a line (M{m[group]} and M{code}); "
                    f"use one {group.replace('_', ' ')} code per line"
                )
            other = _SHARED_M_GROUP.get(group)
            if other in m and not last_wins:  # rs274's group 7 holds both
                raise GcodeError(
                    f"two M codes from one modal group on a line (M{m[other]} and M{code}); "
                    "M3-M5, M19 and M70-M73 are one group (rs274's group 7): one per line"
                )
            m[group] = code
        elif letter in values and not last_wins:
            raise GcodeError(f"multiple {letter} words on one line; give each letter once")
        else:
            if letter == "R" and g.get("motion") not in (20, 30):
                r_before_arc_code = True  # no G2/G3 earlier on the line (Laserdyne: "Repeat")
            if letter in (dialect or LINUXCNC).integer_words:
                value = whole_number(letter, value)
            values[letter] = value
    settings += [_setting(x, params, create) for x in block.settings[done:]]
    return Words(block.line, g, m, values, tuple(settings), r_before_arc_code)


def _setting(
    setting: tuple[Tree, Tree], params: ParameterReader, create: Callable[[str], None] | None
) -> tuple[int | str, float]:
    """One ``#target=value`` of a line: (the parameter's number or name, the value)."""
    (kind, target), value_tree = setting
    if kind == "name":
        if create is not None:
            create(target)
        return target, evaluate(value_tree, params)
    index = parameter_index(evaluate(target, params))
    if index > MAX_SETTABLE_PARAMETER and index not in SETTABLE_SYSTEM:
        raise GcodeError(
            f"parameter #{index} is read-only (system parameters #{MAX_SETTABLE_PARAMETER + 1}.."
            f"#{MAX_PARAMETER}); set #1..#{MAX_SETTABLE_PARAMETER}"
        )
    return index, evaluate(value_tree, params)


def check_motion_axes(w: Words, dialect: Dialect) -> None:
    """A G5, G5.1, G33, G33.1, G38.x or canned-cycle code on a line with no axis word is refused
    before anything else of the block, as rs274's read step refuses it ("All axes missing with
    motion code"): a bare ``G81`` does not drill the last hole again (the linuxcnc dialect:
    its canned cycles are rs274's)."""
    code = w.g.get("motion")
    if dialect.canned_cycles and code in _NEED_AXES and _AXIS_FLAGS.isdisjoint(w.values):
        raise GcodeError(
            f"all axes missing with motion code {g_name(code)}: a line that names "
            f"{g_name(code)} needs an axis word (X, Y or Z) for it to act on"
        )


def check_words(w: Words, motion: int | None, dialect: Dialect) -> None:
    """Step 5b: every word has a code that uses it."""
    v = w.values
    for letter in v:
        # a rotary word that leaves its axis at 0 (the posts' "A0.") moves nothing: accepted
        if (
            letter in _OTHER_AXES
            and letter not in dialect.ignored_letters
            and not (letter in ROTARY_AXES and v[letter] == 0.0)
        ):
            raise GcodeError(f"{letter} axis word on a 3-axis machine; allowed axes: X, Y, Z")
    arc = motion in (20, 30)
    cycle = dialect.canned_cycles and motion in _CYCLES
    if cycle and any(a in v for a in ROTARY_AXES):
        a = next(a for a in ROTARY_AXES if a in v)
        raise GcodeError(f"cannot put an {a} in a canned cycle")
    if dialect.read_order != "grbl":  # grbl checks them last (check_unused_words)
        check_unused_words(w, motion, dialect)
    if w.m.get("spindle") == 19:
        _check_orient(v)
    if "$" in v:
        spindle_code = w.m.get("spindle") is not None or w.m.get("override") == 51
        if not (spindle_code or "S" in v or w.g.get("feed_mode") == 950 or "spindle_mode" in w.g):
            raise GcodeError(
                "$ (spindle selection) word with no M3, M4, M5, M19, M51, G33, G33.1, G76, G95, "
                "G96 or G97 to use it"
            )
        if round(v["$"]) not in (-1, 0):
            raise GcodeError(
                f"invalid spindle ($) number {v['$']:g}: this machine has one spindle ($0; $-1 "
                "selects all)"
            )
    if "S" not in dialect.ignored_letters and v.get("S", 0.0) < 0.0:
        raise GcodeError("negative S word; the spindle speed must be >= 0")
    if v.get("T", 0.0) < 0.0:
        raise GcodeError("negative T word; tool numbers are >= 0")
    if "T" not in dialect.ignored_letters:
        check_tool_number("T", v.get("T", 0.0), dialect)
    if "H" in v and dialect.max_tool_number is not None:  # rs274's H: tool_offsets._whole
        check_tool_number("H", v["H"], dialect)
    if w.m.get("tool_change") == 61 and v.get("Q", -1.0) < 0.0:
        raise GcodeError("M61 needs a Q word >= 0: the tool number now in the spindle")
    if w.m.get("tool_change") == 61:
        check_tool_number("Q", v["Q"])
    if w.m.get("io") in (62, 63, 64, 65) and "P" not in v:
        raise GcodeError(f"M{w.m['io']} needs a P word: the digital output number")
    if w.m.get("io") == 66:
        _check_wait_input(v)
    if w.g.get("spindle_mode") == 960 and "S" not in v:
        raise GcodeError("S word missing with G96: G96 sets the surface speed from S")
    if w.m.get("io") in (67, 68) and ("E" not in v or round(v["E"]) < 0):
        # rs274's convert_m: Q is optional (its value is then -1)
        raise GcodeError(
            f"invalid analog index with M{w.m['io']}: E (the analog output, >= 0) is required"
        )
    if w.g.get("nonmodal") == 40 and arc and dialect.arc_p_allowed:
        raise GcodeError("G4 (dwell) cannot share a line with G2 or G3: both use the P word")
    if w.g.get("nonmodal") == 40 and "P" not in v:  # a negative P waits no time (rs274)
        raise GcodeError("G4 (dwell) needs a P word: the dwell time in seconds")


def check_unused_words(w: Words, motion: int | None, dialect: Dialect) -> None:
    """Every word only some codes take (most lines have none: X Y Z F S T) has a code on the
    line that uses it; :func:`check_words` runs this, except for grbl, whose gcode.c checks
    for unused words last, after the feed, the motion and the arc (the interpreter runs it at
    the end of the block)."""
    v = w.values
    taken = [
        k
        for k in v
        if k not in _ANY_CODE
        and k not in dialect.ignored_letters
        and k not in dialect.unused_words_ignored
    ]
    uses = _letter_uses(w, motion, dialect) if taken else {}
    for letter in taken:
        if not uses.get(letter, False):
            need = _GRBL_NEEDS.get(letter) if dialect.read_order == "grbl" else None
            need = need or _RS274_NEEDS.get(letter, "G2, G3 or G87")
            raise GcodeError(f"{letter} word with no code that uses it; {letter} needs {need}")


def _check_orient(v: dict[str, float]) -> None:
    """M19's words, as rs274's check_other_codes and convert_m check them: R (the angle) within
    0..360 degrees, Q (the time out) above 0, P (the direction) within 0.001 of 0, 1 or 2."""
    if "R" in v and not 0.0 <= v["R"] <= 360.0:
        raise GcodeError("R value must be within 0..360 with M19 (the angle to orient to)")
    if "Q" in v and v["Q"] <= 0.0:
        raise GcodeError("Q word with M19 requires a value > 0 (the time out, in seconds)")
    if "P" in v:
        if abs(v["P"] - round(v["P"])) >= 0.001:
            raise GcodeError("P value not an integer with M19 (the direction to orient in)")
        if round(v["P"]) not in (0, 1, 2):
            raise GcodeError("P value must be 0, 1 or 2 with M19 (the direction to orient in)")


def _check_wait_input(v: dict[str, float]) -> None:
    """M66's words, as rs274's convert_m checks them: P (a digital input) or E (an analog
    one), not both; L (the wait type) above 0 needs a timeout Q > 0 and a digital input."""
    if "P" in v and "E" in v:
        raise GcodeError("M66 with both P and E: wait for a digital (P) or an analog (E) input")
    wait = round(v.get("L", 0.0))
    if wait > 0 and v.get("Q", -1.0) <= 0.0:
        raise GcodeError(
            f"M66 L{wait} with no timeout: a wait type other than L0 (immediate) needs Q > 0 "
            "(the timeout in seconds)"
        )
    if "E" in v and wait != 0:
        raise GcodeError("M66 E (an analog input) takes only L0 (immediate)")
    if ("P" not in v and "E" not in v) or round(v.get("P", v.get("E", 0.0))) < 0:
        raise GcodeError("M66 needs a P word (digital input) or an E word (analog input), >= 0")


def _letter_uses(w: Words, motion: int | None, dialect: Dialect) -> dict[str, bool]:
    """Whether a code of ``w`` (with ``motion``) takes each of the letters I J K R L P Q E H D."""
    arc = motion in (20, 30)
    cycle = dialect.canned_cycles and motion in _CYCLES
    spline = bool(dialect.splines) and motion in (50, 51, 52)
    g10 = w.g.get("nonmodal") == 100
    return {
        "I": arc or motion == 870 or (g10 and dialect.g10_rotation) or (spline and motion != 52),
        "J": arc or motion == 870 or (g10 and dialect.g10_rotation) or (spline and motion != 52),
        "K": arc or motion == 870,
        # grbl's G10 L2 reads R to refuse it (error 20: controller/gcode/coords.py g10); its
        # L20 leaves R unused
        "R": arc
        or (g10 and dialect.g10_rotation)
        or (g10 and dialect.g10_p_truncated and round(w.values.get("L", 0.0)) == 2)
        or cycle
        or w.m.get("spindle") == 19,
        "L": g10
        or (spline and motion == 52)
        or w.m.get("io") == 66
        or (cycle and motion != 740)  # rs274: not with G74
        or w.g.get("cutter_comp") in (411, 421),
        "P": (arc and dialect.arc_p_allowed)
        or (spline and motion in (50, 52))
        or g10
        or motion in (740, 820, 840, 860, 880, 890)
        or w.g.get("nonmodal") == 40
        or w.g.get("path_control") == 640
        or w.m.get("io") in (62, 63, 64, 65, 66)
        or w.m.get("override") in (50, 51, 52, 53)  # rs274: M50-M53 P (override on/off)
        or w.m.get("spindle") == 19
        or "user" in w.m,
        "Q": w.g.get("path_control") == 640
        or w.m.get("spindle") == 19
        or (g10 and dialect.g10_rotation)
        or motion in (730, 830)
        or (spline and motion == 50)
        or "user" in w.m
        or w.m.get("tool_change") == 61
        or w.m.get("io") in (66, 67, 68),
        "E": w.m.get("io") in (66, 67, 68),
        "H": w.g.get("tool_length") in (430, 432),
        "D": (dialect.cutter_comp and w.g.get("cutter_comp") in (410, 411, 420, 421))
        or w.g.get("spindle_mode") == 960,  # G96 D: the spindle's speed limit
    }
