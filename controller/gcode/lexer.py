"""G-code text -> blocks of words, one block per source line (1-based line numbers).

Follows rs274's reader: comments ``( ... )`` (no nesting) and ``;`` to end of line are dropped,
spaces and tabs outside comments are removed (so ``X 2 . 5`` is ``X2.5``), letters are
case-insensitive, a leading ``/`` (block delete) is accepted, an ``N`` line number may open the
line, and a line that is just ``%`` is a program delimiter. Word values are expression trees from
:mod:`gantry_sim.controller.gcode.expressions`, evaluated by the interpreter.

Line ends are ``\n``, ``\r\n`` and a bare ``\r`` (old Mac files; never merged into one line, a
documented difference from ``rs274 -g``, which reads a bare CR as a space). A UTF-8 byte order
mark at the start of the text is dropped. An O-word line (``o100 sub``, ``o<name> call [1]``)
carries its :class:`OWord` and nothing else. :class:`LexRules` holds what a firmware's reader
takes otherwise (grbl, g2core).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from gantry_sim.controller.errors import GcodeError, cut
from gantry_sim.controller.gcode.expressions import MAX_MAGNITUDE, Reader, Tree

#: what a comment leaves in a stripped line: words may not be split by it (rs274: ``X(c)1`` is an
#: error), but it separates words.
COMMENT = "("

#: letters rs274 reads as words (O-words are read separately, N only opens a line).
#: @ ^: polar radius and angle; $: LinuxCNC 2.8+'s spindle selection ($0; $-1 all spindles)
WORD_LETTERS = frozenset("ABCDEFGHIJKLMPQRSTUVWXYZ@^$")


class TextError(GcodeError):
    """A line's text refused as rs274's read_text refuses it (too long, a comment nested or left
    open): on every line it reads, also the lines it passes over (a branch not taken, a
    subroutine's body at its definition, the lines searched for a subroutine), where the
    line's words are never parsed."""


@dataclass(frozen=True)
class LexRules:
    """How a controller's line reader differs from rs274's (the defaults).

    Attributes:
        system_lines: a line opening with ``$`` is a system command (grbl): no words, except a
            ``$J=`` jog, whose words are lexed as a block with ``jog`` set.
        line_number_words: an ``N`` anywhere on the line is a word ``("N", value)`` (grbl's
            and g2core's parsers), not rs274's line number, which only opens a line and is
            dropped.
        o_words: an ``O`` is an O-word (program number, subroutine, control flow: rs274);
            False: the reader has none, and an ``O`` is refused where it stands (grbl reads
            it as a letter it does not support: error 20).
        symbol_words: ``@``, ``^`` and ``$`` are word letters (LinuxCNC's polar radius and
            angle, spindle selection); False: bad characters, as grbl's reader takes them
            (error 1: it reads letters A-Z only).
        percent_delimits: a ``%`` delimits a program (rs274: alone on a line, else an error
            saying so); False: a ``%`` among words is a bad character like any other (a line
            that is a ``%`` alone is nothing: the Runner's ``percent_delimits``).
    """

    system_lines: bool = False
    line_number_words: bool = False
    o_words: bool = True
    symbol_words: bool = True
    percent_delimits: bool = True


#: rs274's reader
RS274_LEX = LexRules()

#: O-word keywords, longest first so that ENDSUB is not read as END... or ELSEIF as ELSE.
# fmt: off
O_KEYWORDS = (
    "ENDREPEAT", "ENDWHILE", "CONTINUE", "ENDSUB", "ELSEIF", "REPEAT", "RETURN", "ENDIF",
    "WHILE", "BREAK", "ELSE", "CALL", "SUB", "DO", "IF",
)
# fmt: on
#: the [values] each O-word keyword takes at most (rs274's read_o: one condition or count, a
#: returned value; a call any number); the others take none ("Unexpected character after
#: O-word")
_O_VALUES_MAX = {"IF": 1, "ELSEIF": 1, "WHILE": 1, "REPEAT": 1, "RETURN": 1, "ENDSUB": 1}
#: what strip_line drops outside comments
_BLANKS = str.maketrans("", "", " \t\r")
#: grbl's realtime characters (status, cycle start, feed hold, reset) and every character
#: outside ASCII (grbl's serial layer drops each byte above 0x7F: its extended-ASCII realtime
#: commands and anything else), taken out of a line before it is parsed.
_REALTIME = re.compile("[?~!\x18]|[^\x00-\x7f]")  # [\x80-\U0010ffff] took 5 ms to compile
#: a stripped line of plain words only: an optional ``/`` and ``N`` number, then letters each
#: followed by a signed decimal number (most lines of CAM output); group 1 holds the words.
#: Such a line is lexed by two regular expressions (:func:`_plain_words`) into the blocks the
#: general reader makes of it, at two thirds of its cost (100,000 ``G1 X.. Y..`` lines: 0.42
#: s instead of 0.61). Every quantifier is possessive: a line that is not plain fails in time
#: linear in its length (with ``[0-9]+\.?[0-9]*`` a digit run splits as many ways as it has
#: digits, and a line of 30 such words ending in ``*``, a printer's checksum, took d^30 tries).
_PLAIN_LINE = re.compile(
    r"/?+(?:N[0-9]++(?:\.[0-9]++)?+)?+((?:[A-MP-Z@^$][+-]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++))*+)"
)
_PLAIN_WORD = re.compile(r"([A-MP-Z@^$])([+-]?)([0-9.]+)")


@dataclass(frozen=True)
class OWord:
    """An O-word: ``o<name> keyword [arguments]``.

    Attributes:
        name: the O number as digits without leading zeros (``"100"``) or the name, lower case
            ("" where ``number`` computes it).
        keyword: one of :data:`O_KEYWORDS`, lower case (``"sub"``, ``"call"``, ...).
        args: the bracketed values after the keyword (call arguments, a condition, a repeat
            count, a return value).
        number: the O number of a call computed when it runs (``o#<sub> call``,
            ``o[#2 * 10] call``: rs274 reads an O number as any integer value), or None.
    """

    name: str
    keyword: str
    args: tuple[Tree, ...]
    number: Tree | None = None


@dataclass(frozen=True)
class Block:
    """One source line, lexed.

    Attributes:
        line: 1-based source line.
        words: (letter, value tree) in source order; letters upper case.
        settings: ``#index=value`` and ``#<name>=value`` settings in source order; the target
            is ``("par", index tree)`` or ``("name", name)``.
        percent: the line is a ``%`` program delimiter.
        text: the source line, for messages.
        oword: the line's O-word, if it is one.
        jog: a grbl ``$J=`` jog: its words move as G1 without changing the modal state.
        home: a Marlin G28: the named axes (all when none) go to the work origin.
        limits: a Marlin M201/M203/M204/M205 line (a :class:`~gantry_sim.controller.moves.Limits`).
        extruder: a Marlin line that sets the extruder without moving it: ("relative", 1.0)
            for M83, ("relative", 0.0) for M82, ("position", E) for ``G92 E`` (E in the
            program's units).
        feed_percent: a Marlin M220 (:func:`~gantry_sim.controller.gcode.printer_codes.
            marlin_feed_percent`): (restore, back up, the new percentage or None).
        settings_at: per setting, how many of ``words`` come before it on the line (empty:
            every setting after the words).
        bare: a Marlin line of parameters with no command (``X10 Y5``, ``E5``), which
            GCODE_MOTION_MODES runs as the modal G0-G3 or G5: the letter it opens with (upper
            case; "" for any other line).
    """

    line: int
    words: tuple[tuple[str, Tree], ...]
    settings: tuple[tuple[Tree, Tree], ...]
    percent: bool
    text: str
    oword: OWord | None = None
    jog: bool = False
    home: bool = False
    limits: bool = False
    extruder: tuple[str, float] | None = None
    settings_at: tuple[int, ...] = ()
    feed_percent: tuple[bool, bool, int | None] | None = None
    bare: str = ""

    @property
    def empty(self) -> bool:
        """True when the line carries nothing to execute (blank or comment only)."""
        return (
            not self.words
            and not self.settings
            and not self.percent
            and self.oword is None
            and not self.home
            and not self.limits
            and self.extruder is None
            and self.feed_percent is None
        )


def strip_line(raw: str) -> str:
    """Replace comments by ``(``, drop whitespace outside them; upper-case the rest.

    Raises:
        GcodeError: nested ``(`` inside a comment, or a comment left open.
    """
    if "(" not in raw and ";" not in raw:  # most lines: no comment to find
        return raw.translate(_BLANKS).upper()
    out: list[str] = []
    in_comment = False
    for ch in raw:
        if in_comment:
            if ch == ")":
                in_comment = False
            elif ch == "(":
                raise TextError("nested comment found; a comment ( ... ) cannot contain '('")
            continue
        if ch == "(":
            in_comment = True
            out.append(COMMENT)
        elif ch == ";":
            break
        elif ch not in " \t\r":
            out.append(ch)
    if in_comment:
        raise TextError("unclosed comment found; close it with ')' on the same line")
    return "".join(out).upper()


def firmware_comments(raw: str, rules: str) -> str:
    """``raw`` with its comments as a firmware's line reader takes them, for :func:`strip_line`.

    ``rules``: ``"grbl"`` (grbl 1.1's serial layer, protocol.c), ``"g2core"`` (its
    ``_normalize_gcode_block``) or ``"marlin"`` (its reader drops them: :func:`_marlin_stream`).
    grbl and g2core read a ``(`` comment up to its first ``)`` or to the end of the line, a
    ``(`` inside it being text, and end the line at a ``;`` outside a comment (rs274 refuses a
    comment left open or holding a ``(``). g2core also ends the line at a ``%`` (so a ``%``
    line is an empty line, not a program delimiter), drops a ``)`` outside a comment (its
    normalizer keeps letters, digits, ``-`` and ``.`` only: ``G0 X1 (a (b) Y5) Y2`` is G0 X1
    Y2) and skips a line whose first character after blanks is ``/`` (controller.cpp strips
    the blanks; its block delete is always on: ``gc_gcode_parser`` returns before parsing
    such a line). The comment is returned closed, with no ``(`` inside (Marlin's is dropped).
    """
    if rules == "marlin":
        return _marlin_stream(raw) if "(" in raw or ")" in raw or "\\" in raw else raw
    if rules == "grbl":
        return grbl_line(raw)
    g2core = rules == "g2core"
    if g2core and raw.lstrip(" \t").startswith("/"):
        return ""
    if "(" not in raw and ";" not in raw and not (g2core and ("%" in raw or ")" in raw)):
        return raw
    kept = _FIRMWARE_LINE[rules].match(raw)
    closed = _OPEN_COMMENT.sub(_closed, kept.group() if kept else "")
    return _COMMENT_OR_PAREN.sub(_without_paren, closed) if g2core else closed


#: what a firmware reads of a line: words and comments, a comment running to its first ``)``
#: or the line's end, up to the first ``;`` (g2core: or ``%``) outside a comment
_FIRMWARE_LINE = {
    "grbl": re.compile(r"(?:[^(;]|\([^)]*\)?)*"),
    "g2core": re.compile(r"(?:[^(;%]|\([^)]*\)?)*"),
}
#: a comment, closed or left open at the line's end
_OPEN_COMMENT = re.compile(r"\(([^)]*)\)?")
#: a closed comment, or a ``)`` outside one (g2core's normalizer drops it)
_COMMENT_OR_PAREN = re.compile(r"\([^)]*\)|\)")


def _without_paren(m: re.Match[str]) -> str:
    return m.group() if m.group() != ")" else ""


#: what grbl's serial layer drops from a line besides its comments
_GRBL_DROPPED = re.compile(r"[\x00-\x20/]+")


def grbl_line(raw: str) -> str:
    """``raw`` as grbl's protocol.c passes it to gcode.c: without its comments (``(`` to the
    first ``)`` or the line's end, ``;`` to the line's end), ``/`` (no block delete), spaces
    and control characters, one run of characters (``X-(c)4`` is X-4, ``X/2`` X2)."""
    kept = _FIRMWARE_LINE["grbl"].match(raw)
    return _GRBL_DROPPED.sub("", _OPEN_COMMENT.sub("", kept.group() if kept else ""))


def _marlin_stream(raw: str) -> str:
    """``raw`` as Marlin's line reader passes it on (queue.cpp ``process_stream_char``, the
    PAREN_COMMENTS build): a ``(`` comment dropped up to its first ``)``, a ``(`` inside it
    being text (``(a (b) c)`` leaves `` c)``, which the parser reads on: its letters without a
    value are no parameter); a ``;`` outside a comment ends the line; a ``\\`` keeps the next
    character as it is, itself dropped. A ``)`` outside a comment, which the parser skips, is
    dropped too, unless it follows a letter (``E)`` leaves that E without a value, where
    ``E 5`` would be an E5)."""
    out: list[str] = []
    paren = escaped = False
    last = ""  # the last character kept that is not a space
    for ch in raw:
        if paren:
            paren = ch != ")"
            continue
        if escaped:
            escaped = False
        elif ch == "\\":
            escaped = True
            continue
        elif ch == ";":
            break
        elif ch == "(":
            paren = True
            continue
        elif ch == ")" and not last.isalpha():
            continue
        out.append(ch)
        if ch != " ":
            last = ch
    return "".join(out)


def _closed(comment: re.Match[str]) -> str:
    """A firmware's comment as rs274 reads one: closed, with no ``(`` inside."""
    return "(" + comment.group(1).replace("(", "") + ")"


def decode_program(data: bytes) -> str:
    """A program file's bytes as text: UTF-8, else each byte as its Latin-1 character (CAM
    posts write comments such as "(Fräser 8 mm)" in a one-byte code page; controllers read
    bytes and skip comments, and G-code words are ASCII, so such a character outside a comment
    is refused by the lexer as a bad character, on its line)."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def without_checksum(raw: str) -> str:
    """``raw`` as Marlin's parser reads it: cut at its first ``*`` outside a comment (the
    checksum a host adds to a numbered line, ``N12 G1 X5 Y2*97``: GCodeParser::parse
    "nullifies" the asterisk and what follows; a file printed from the SD card is read the
    same way and its checksums are not checked)."""
    in_comment = False
    for k, ch in enumerate(raw):
        if in_comment:
            in_comment = ch != ")"
        elif ch == "(":
            in_comment = True
        elif ch == ";":
            return raw
        elif ch == "*":
            return raw[:k]
    return raw


#: the characters that make a line no G-code line for g2core when they open it (after blanks):
#: single-character controls, JSON, text mode (controller.cpp ``_dispatch_kernel``)
_G2CORE_NOT_GCODE = "!~%{$?Hh\x04\x05\x18"


def g2core_checksum(raw: str, last: int) -> tuple[str, int]:
    """``raw`` as g2core's ``_verify_checksum`` (gcode_parser.cpp) leaves a G-code line, and the
    line number of the last line with a checksum (``last``: the one before). With a ``*``
    anywhere, even in a comment, the XOR of the characters before it (the line's leading
    blanks stripped, as controller.cpp does first) must equal the number after it, the line
    must open with ``N``, and that number must be ``last`` + 1 (canonical_machine.cpp
    ``cm_check_linenum``; 0 at power-on: the first is N1); the line then ends at the ``*``.
    GcodeError otherwise."""
    line = raw.lstrip(" \t")
    star = line.find("*")
    if star < 0 or line[:1] in _G2CORE_NOT_GCODE:
        return raw, last
    total = 0
    for byte in line[:star].encode("utf-8", "surrogateescape"):
        total ^= byte
    given = _strtol(line[star + 1 :])
    if given != total:
        raise GcodeError(
            f"checksum mismatch: the characters before the '*' XOR to {total}, the number after "
            f"it is {given}; g2core refuses the line (gcode_parser.cpp _verify_checksum: "
            "STAT_CHECKSUM_MATCH_FAILED; a '*' in a comment starts a checksum too)"
        )
    if not line.startswith("N"):
        raise GcodeError(
            "a checksum ('*') on a line that does not open with an N line number: g2core refuses "
            "it (gcode_parser.cpp _verify_checksum: STAT_MISSING_LINE_NUMBER_WITH_CHECKSUM)"
        )
    number = _strtol(re.sub(r"\s", "", line[1:star]))
    if number != last + 1:
        raise GcodeError(
            f"line number N{number} out of sequence: g2core takes a line with a checksum only "
            f"when its N is one more than the last such line's (N{last + 1} here; N1 first: "
            "canonical_machine.cpp cm_check_linenum, STAT_LINE_NUMBER_OUT_OF_SEQUENCE)"
        )
    return raw[: len(raw) - len(line) + star], number


def _strtol(text: str) -> int:
    """C's ``strtol(text, NULL, 10)``: blanks, a sign and the digits after them; 0 if none."""
    m = re.match(r"\s*([-+]?\d+)", text)
    return int(m.group(1)) if m else 0


#: rs274 reads a line with ``fgets`` into LINELEN (255) bytes: a line of 253 characters or
#: more, its line end counted, is "Command too long" (measured: 252 pass)
LINUXCNC_MAX_LINE = 252
#: grbl 1.1's line buffer (LINE_BUFFER_SIZE 80, less its NUL) holds the characters it keeps:
#: not spaces, control characters, ``/`` or comments (protocol.c)
GRBL_MAX_LINE = 79


#: g2core's serial reader (xio.cpp ``readline``, RX_BUFFER_SIZE 512) passes on a line's first
#: 511 characters and skips the rest of it
G2CORE_MAX_LINE = 511


def line_too_long(raw: str, rule: str) -> str | None:
    """Why the controller of ``rule`` ("linuxcnc", "grbl"; "": no limit) refuses line ``raw``
    (without its line end; grbl's realtime characters already taken out) for its length, or
    None."""
    if rule == "linuxcnc" and len(raw) > LINUXCNC_MAX_LINE:
        return (
            f"line of {len(raw)} characters: LinuxCNC reads at most {LINUXCNC_MAX_LINE} "
            "('Command too long'); split it, or shorten its comment"
        )
    if rule == "grbl" and len(raw) > GRBL_MAX_LINE:  # grbl_line only drops characters
        kept = len(grbl_line(raw))
        if kept > GRBL_MAX_LINE:
            return (
                f"line of {kept} characters without spaces and comments: grbl's line buffer "
                f"holds {GRBL_MAX_LINE} (max characters per line exceeded)"
            )
    return None


def without_realtime(raw: str) -> str:
    """``raw`` as grbl's parser receives it: realtime characters taken out of the stream."""
    return _REALTIME.sub("", raw)


def lex_line(raw: str, line: int, rules: LexRules = RS274_LEX) -> Block:
    """Lex one source line into a :class:`Block` (GcodeError carries ``line``), read by
    ``rules``."""
    try:
        if rules.system_lines and raw.lstrip().startswith("$"):
            text = strip_line(raw)
            if text.startswith("$J="):
                block = _lex(raw[raw.index("=") + 1 :], line, rules)
                return Block(line, block.words, block.settings, False, raw, None, True)
            return Block(line, (), (), False, raw)
        return _lex(raw, line, rules)
    except GcodeError as exc:
        if exc.line is None:
            exc.line = line
        raise


def _lex(raw: str, line: int, rules: LexRules = RS274_LEX) -> Block:
    text = strip_line(raw)
    plain = None if rules.line_number_words and "N" in text else _PLAIN_LINE.fullmatch(text)
    if plain is not None:
        words = _plain_words(plain.group(1))
        if words is not None:
            return Block(line, words, (), False, raw)
    return _lex_text(text, raw, line, rules)


def _plain_words(text: str) -> tuple[tuple[str, Tree], ...] | None:
    """The words of ``text``, a run of plain words (:data:`_PLAIN_LINE`'s group 1), as the
    general reader makes them: ``("num", value)``, under ``("neg", ...)`` after a minus; None
    where a value is too large (the general reader says why)."""
    words = []
    for letter, sign, digits in _PLAIN_WORD.findall(text):
        value = float(digits)
        if value > MAX_MAGNITUDE:
            return None
        words.append((letter, ("neg", ("num", value)) if sign == "-" else ("num", value)))
    return tuple(words)


_DIGITS = re.compile(r"[0-9]*")


def _digits_end(text: str, pos: int) -> int:
    """Where the run of ASCII digits from ``pos`` ends (``str.isdigit`` takes other scripts'
    digits and superscripts too)."""
    found = _DIGITS.match(text, pos)
    assert found is not None  # [0-9]* matches everywhere
    return found.end()


def lex_passed_oword(raw: str, line: int, rules: LexRules = RS274_LEX) -> Block:
    """An O-word line passed over (in a branch not taken, a loop left, a subroutine's body at
    its definition) read as rs274 reads a line it skips: its O number or name and its keyword,
    not what follows (``o1 if [<#_v> EQ 1]`` in a subroutine never called is no error; it is
    where it runs). The arguments of the Block's O-word are empty."""
    try:
        return _lex_text(strip_line(raw), raw, line, rules, oword_head=True)
    except GcodeError as exc:
        if exc.line is None:
            exc.line = line
        raise


def _lex_text(
    text: str, raw: str, line: int, rules: LexRules = RS274_LEX, oword_head: bool = False
) -> Block:
    """The general reader: any stripped line ``text`` (of source line ``raw``), read by
    ``rules``; ``oword_head``: an O-word's name and keyword only (:func:`lex_passed_oword`)."""
    if text == "%":
        return Block(line, (), (), True, raw)
    reader = Reader(text)
    if reader.peek() == "/":
        reader.pos += 1
    if reader.peek() == "N" and not rules.line_number_words:
        # rs274: digits, and a decimal part of one digit or more
        reader.pos += 1
        start = reader.pos
        reader.pos = _digits_end(text, reader.pos)
        if reader.pos == start:
            raise GcodeError("N must be followed by a line number")
        if reader.peek() == ".":
            after = _digits_end(text, reader.pos + 1)
            if after == reader.pos + 1:
                raise GcodeError(
                    "bad line number: N takes digits and, after a '.', at least one more "
                    "(N10, N10.5)"
                )
            reader.pos = after
    words: list[tuple[str, Tree]] = []
    settings: list[tuple[Tree, Tree]] = []
    settings_at: list[int] = []
    while reader.pos < len(text):
        ch = reader.peek()
        if ch == COMMENT:
            reader.pos += 1
            continue
        if ch == "#":
            reader.pos += 1
            target = (
                ("name", reader.name()) if reader.peek() == "<" else ("par", reader.real_value())
            )
            if reader.peek() != "=":
                raise GcodeError("expected '=' after #n at the start of a parameter setting")
            reader.pos += 1
            settings.append((target, reader.real_value()))
            settings_at.append(len(words))
            continue
        if ch == "O" and not rules.o_words:
            reader.pos += 1
            reader.real_value()  # a value must follow, as after any letter
            raise GcodeError(
                "an O word is not supported: O-words (program numbers, subroutines, loops) "
                "belong to LinuxCNC's language; this dialect has none"
            )
        if ch == "O":
            if words or settings:
                raise GcodeError("an O-word must open its line (after an optional N number)")
            return Block(line, (), (), False, raw, _oword(reader, oword_head))
        if ch == "%" and rules.percent_delimits:
            raise GcodeError("'%' is only allowed alone on a line, opening and closing a program")
        if ch == "N" and rules.line_number_words:
            reader.pos += 1
            words.append((ch, reader.real_value()))
            continue
        if ch not in WORD_LETTERS or (not rules.symbol_words and not ch.isalpha()):
            what = "N (line numbers must open the line)" if ch == "N" else repr(ch)
            realtime = (
                " ('!', '~' and '?' are grbl's and g2core's real-time commands: feed hold, "
                "resume and status, which a sender issues; they are not G-code)"
                if ch in "!~?"
                else ""
            )
            raise GcodeError(
                f"bad character {what}; a line holds words: a letter A-Z followed by a value"
                + realtime
            )
        reader.pos += 1
        words.append((ch, _word_value(reader, ch)))
    return Block(line, tuple(words), tuple(settings), False, raw, settings_at=tuple(settings_at))


def _word_value(reader: Reader, letter: str) -> Tree:
    """The value of word ``letter``, whose letter ``reader`` has just passed; a value that
    cannot be read is refused naming the word (``(MSG, ...) Macro`` reads an M word whose
    value starts with 'A')."""
    try:
        return reader.real_value()
    except GcodeError as exc:
        if not isinstance(exc, TextError) and exc.message.startswith(
            ("bad value", "missing value")
        ):
            exc.message = f"{letter} word: {exc.message}"
        raise


def _oword(reader: Reader, head_only: bool = False) -> OWord | None:
    """``O`` at ``reader.pos``: the O number or name, the keyword, its bracketed arguments
    (``head_only``: those it can read, the rest of the line passed over, as rs274 reads a line
    it skips: an ``elseif`` reached so is evaluated with what it read)."""
    reader.pos += 1
    number = None
    if reader.peek() == "<":
        name = reader.name()
    elif reader.peek() in ("#", "["):
        name, number = "", reader.real_value()
    else:
        start = reader.pos
        while reader.peek().isdigit():
            reader.pos += 1
        if reader.pos == start:
            raise GcodeError("O must be followed by a number or a <name>, then a keyword")
        name = str(int(reader.text[start : reader.pos]))
    keyword = next((k for k in O_KEYWORDS if reader.text.startswith(k, reader.pos)), None)
    if keyword is None and reader.text[reader.pos :].strip(COMMENT) == "":
        return None  # a program number alone ("O1000"): rs274 ignores the line
    if keyword is None:
        shown = name if name.isdigit() else f"<{name}>"
        found = reader.text[reader.pos :].split(COMMENT, 1)[0].strip()
        raise GcodeError(
            f"unknown O-word keyword after o{cut(shown)}: found {cut(found)!r}; expected one "
            "of: "
            + ", ".join(k.lower() for k in sorted(O_KEYWORDS))
            + (f" (a call reads o{cut(shown)} call [...])" if found.startswith("[") else "")
        )
    if head_only:  # the bracketed values it can read, up to the first thing it cannot
        reader.pos += len(keyword)
        read: list[Tree] = []
        while reader.peek() == "[":
            try:
                read.append(reader.expression())
            except GcodeError:
                break
        return OWord(name, keyword.lower(), tuple(read), number)
    if number is not None and keyword != "CALL":
        raise GcodeError(
            "an O number given by a parameter or an [expression] is supported with call only; "
            "other O-word lines need the number or <name> itself"
        )
    reader.pos += len(keyword)
    args: list[Tree] = []
    while reader.pos < len(reader.text):
        if reader.peek() == COMMENT:
            reader.pos += 1
        elif reader.peek() == "[":
            args.append(reader.expression())
        else:
            raise GcodeError(
                f"unexpected {reader.peek()!r} after o{cut(name)} {keyword.lower()}; an O-word line "
                "holds only its keyword and [bracketed] values"
            )
    most = _O_VALUES_MAX.get(keyword, 0) if keyword != "CALL" else len(args)
    if len(args) > most:
        takes = "none" if most == 0 else "one at most"
        raise GcodeError(
            f"unexpected [value] after o{cut(name)} {keyword.lower()}: {keyword.lower()} takes "
            f"{takes} (rs274: Unexpected character after O-word)"
        )
    return OWord(name, keyword.lower(), tuple(args), number)


def split_lines(text: str) -> list[str]:
    """The source lines: a leading BOM dropped, split at LF, CRs then LF, or a bare CR.

    A line ends at LF, at CRs then LF (CR LF, and the CR CR LF of a file whose line ends were
    converted twice: LinuxCNC counts that as one line end, and so do editors and grep), or at
    a bare CR. Time linear in the text: each LF-ended piece drops its trailing CRs, then splits
    at the CRs left (the regular expression ``\\r*\\n|\\r`` scanned a run of n CRs with no LF
    again from each of them: 200,000 CRs took 18 s).
    """
    pieces = text.removeprefix("\ufeff").split("\n")
    last = pieces.pop()  # the text after the last LF (none ends it)
    lines: list[str] = []
    for piece in pieces:
        if "\r" in piece:
            lines.extend(piece.rstrip("\r").split("\r"))
        else:
            lines.append(piece)
    lines.extend(last.split("\r"))
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def lex(text: str) -> Iterator[Block]:
    """Yield one :class:`Block` per source line, lazily, in order."""
    for number, raw in enumerate(split_lines(text), start=1):
        yield lex_line(raw, number)
