"""Typed errors a user can cause: bad G-code, bad machine files, impossible programs.

Every error carries the file it came from and, for programs, the 1-based source line, so the CLI
can print ``FILE:LINE: error: MESSAGE`` (or ``FILE: error: MESSAGE``) and exit 2 without a traceback.
Anything that is not a :class:`GantryError` is a bug in gantry-sim.
"""

from __future__ import annotations


class GantryError(Exception):
    """Base of all user-caused errors.

    Args:
        message: What is wrong and what is allowed instead.
        file: The input file the error is about (program or machine file), if known.
        line: 1-based line in ``file``, if the error belongs to a line.
    """

    def __init__(self, message: str, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line

    def located(self, file: str) -> GantryError:
        """Return this error with ``file`` filled in when it had none."""
        if self.file is None:
            self.file = file
        return self

    def __str__(self) -> str:
        where = self.file or "<input>"
        if self.line is not None:
            where = f"{where}:{self.line}"
        return one_line(f"{where}: error: {self.message}")  # names in it may hold a newline


class GcodeError(GantryError):
    """The program text is invalid for the chosen dialect."""


class ConfigError(GantryError):
    """A machine file (TOML) or a command-line option is invalid."""


class PlanningError(GantryError):
    """A valid program cannot be run on this machine (for example, it leaves the travel)."""


class SimulationError(GantryError):
    """The simulation diverged or produced non-finite values; ``move``: the index of the
    program move being executed, where known (its ``file`` names a subroutine file's line)."""

    def __init__(
        self,
        message: str,
        file: str | None = None,
        line: int | None = None,
        move: int | None = None,
    ) -> None:
        super().__init__(message, file, line)
        self.move = move


class PlannerFailure(RuntimeError):
    """The planner could not plan a move of a valid program within the machine's limits.

    Not a GantryError: the program and the machine file are fine, so this is a limitation of
    gantry-sim's planner, reported as an internal error (exit 3, "please report") rather than
    blamed on the user's input (exit 2).
    """

    def __init__(self, message: str, line: int) -> None:
        super().__init__(f"line {line}: {message}")
        self.line = line


#: Control characters (C0 but the tab, and DEL) as the escapes :func:`one_line` writes.
_CONTROLS = {c: repr(chr(c))[1:-1] for c in (*range(9), *range(10, 32), 127)}


def one_line(name: str) -> str:
    """An error line's text with its control characters escaped (``\\n``...): a file name
    holding a newline keeps ``FILE:LINE: error: MESSAGE`` on one line."""
    return name.translate(_CONTROLS)


#: Characters of a value's repr a message quotes at most (:func:`shown`).
SHOWN_CHARS = 40


def shown(value: object, limit: int = SHOWN_CHARS) -> str:
    """``repr(value)`` for an error message, cut to ``limit`` characters with ``...`` (a
    hostile file's value may be a megabyte long)."""
    return cut(repr(value), limit)


def cut(text: str, limit: int = SHOWN_CHARS) -> str:
    """``text`` (a name, a word) for an error message, cut to ``limit`` characters with
    ``...``."""
    return text if len(text) <= limit else text[: limit - 3] + "..."
