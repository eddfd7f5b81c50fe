"""G-code text -> blocks of words, one block per source line (1-based line numbers).

Follows rs274's reader: comments ``( ... )`` (no nesting) and ``;`` to end of line are dropped,
spaces and tabs outside comments are removed (so ``X 2 . 5`` is ``X2.5``), letters are
case-insensitive, a leading ``/`` (block delete) is accepted, an ``N`` line number may open the
line, and a line that is just ``%`` is a program delimiter. Word values are expression trees from
:mod:`gantry_sim.controller.gcode.expressions`, evaluated by the interpreter.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.expressions import NAMED_PARAMETERS, Reader, Tree

#: what a comment leaves in a stripped line: words may not be split by it (rs274: ``X(c)1`` is an
#: error), but it separates words.
COMMENT = "("

#: letters rs274 reads as words (O-words are refused separately, N only opens a line).
WORD_LETTERS = frozenset("ABCDEFGHIJKLMPQRSTUVWXYZ")


@dataclass(frozen=True)
class Block:
    """One source line, lexed.

    Attributes:
        line: 1-based source line.
        words: (letter, value tree) in source order; letters upper case.
        settings: ``#index=value`` parameter settings, in source order.
        percent: the line is a ``%`` program delimiter.
        text: the source line, for messages.
    """

    line: int
    words: tuple[tuple[str, Tree], ...]
    settings: tuple[tuple[Tree, Tree], ...]
    percent: bool
    text: str

    @property
    def empty(self) -> bool:
        """True when the line carries nothing to execute (blank or comment only)."""
        return not self.words and not self.settings and not self.percent


def strip_line(raw: str) -> str:
    """Replace comments by ``(``, drop whitespace outside them; upper-case the rest.

    Raises:
        GcodeError: nested ``(`` inside a comment, or a comment left open.
    """
    out: list[str] = []
    in_comment = False
    for ch in raw:
        if in_comment:
            if ch == ")":
                in_comment = False
            elif ch == "(":
                raise GcodeError("nested comment found; a comment ( ... ) cannot contain '('")
            continue
        if ch == "(":
            in_comment = True
            out.append(COMMENT)
        elif ch == ";":
            break
        elif ch not in " \t\r":
            out.append(ch)
    if in_comment:
        raise GcodeError("unclosed comment found; close it with ')' on the same line")
    return "".join(out).upper()


def lex_line(raw: str, line: int) -> Block:
    """Lex one source line into a :class:`Block` (GcodeError carries ``line``)."""
    try:
        return _lex(raw, line)
    except GcodeError as exc:
        if exc.line is None:
            exc.line = line
        raise


def _lex(raw: str, line: int) -> Block:
    text = strip_line(raw)
    if text == "%":
        return Block(line, (), (), True, raw)
    reader = Reader(text)
    if reader.peek() == "/":
        reader.pos += 1
    if reader.peek() == "N":
        reader.pos += 1
        start = reader.pos
        while reader.peek() and reader.peek() in "0123456789.":
            reader.pos += 1
        if reader.pos == start:
            raise GcodeError("N must be followed by a line number")
    words: list[tuple[str, Tree]] = []
    settings: list[tuple[Tree, Tree]] = []
    while reader.pos < len(text):
        ch = reader.peek()
        if ch == COMMENT:
            reader.pos += 1
            continue
        if ch == "#":
            reader.pos += 1
            if reader.peek() == "<":
                raise GcodeError(NAMED_PARAMETERS)
            index = reader.real_value()
            if reader.peek() != "=":
                raise GcodeError("expected '=' after #n at the start of a parameter setting")
            reader.pos += 1
            settings.append((index, reader.real_value()))
            continue
        if ch == "O":
            raise GcodeError("O-words (subroutines, loops, conditionals) are not supported")
        if ch == "%":
            raise GcodeError("'%' is only allowed alone on a line, opening and closing a program")
        if ch not in WORD_LETTERS:
            what = "N (line numbers must open the line)" if ch == "N" else repr(ch)
            raise GcodeError(
                f"bad character {what}; a line holds words: a letter A-Z followed by a value"
            )
        reader.pos += 1
        words.append((ch, reader.real_value()))
    return Block(line, tuple(words), tuple(settings), False, raw)


def lex(text: str) -> Iterator[Block]:
    """Yield one :class:`Block` per source line, lazily, in order."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    for number, raw in enumerate(lines, start=1):
        yield lex_line(raw, number)
