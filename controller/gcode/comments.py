"""LinuxCNC's active comments that change what a program does: ``(abort, message)``.

rs274 keeps the last ``( ... )`` comment of a line (``read_comment``; a ``;`` comment is not
one) and acts on it before anything else on the line (``convert_comment``): one that starts
``abort,`` (any case, after leading blanks) ends the program with an error whose text is the
rest of the comment, its parameters filled in (``convert_param_comment``: ``#n`` and
``#<name>`` as ``%f``, ``######`` for a name that is not set). ``(msg,`` ``(debug,`` and
``(print,`` only print, which a simulation has no use for.
"""

from __future__ import annotations

import re

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.expressions import ParameterReader

__all__ = ["abort_message", "last_comment"]

_PARAMETER = re.compile(r"#<([^>]*)>|#(\d+)")


def last_comment(raw: str) -> str | None:
    """The text of the last ``( ... )`` comment of the source line ``raw`` (None when it has
    none); a ``;`` outside a comment ends the line."""
    found = None
    at = 0
    semicolon = raw.find(";")  # looked for again only once passed (a line of 800,000
    while True:  # comments and no ";" took 26 s when each comment searched the rest of it)
        if 0 <= semicolon < at:
            semicolon = raw.find(";", at)
        start = raw.find("(", at)
        if start < 0 or 0 <= semicolon < start:
            return found
        end = raw.find(")", start + 1)
        if end < 0:
            return found  # an open comment: the lexer refuses the line
        found, at = raw[start + 1 : end], end + 1


def abort_message(raw: str, params: ParameterReader) -> str | None:
    """The message of the source line ``raw``'s ``(abort, ...)`` comment with its parameters
    filled in, or None when its last comment is no abort."""
    comment = last_comment(raw)
    if comment is None:
        return None
    text = comment.lstrip()
    if not text.lower().startswith("abort,"):
        return None

    def value(m: re.Match) -> str:
        name, number = m.group(1), m.group(2)
        if name is not None:
            key = name.lower()
            if not params.exists(key):
                return "######"
            return f"{params.named(key):f}"
        try:
            return f"{params.number(float(number)):f}"
        except GcodeError:
            return "######"

    return _PARAMETER.sub(value, text[len("abort,") :])
