"""A program's moves on a machine, as ``gantry plan``, ``run`` and ``sweep`` interpret it.

The interpreter gets the machine file's tool table and initial offsets (``[tools]``, ``[work]``;
``--tool-table`` and ``--work-offset`` are laid over them by
:func:`gantry_sim.sim.commands.common.program_machine`), the folders searched for subroutine
files (the program's own first, then ``--subroutine-path``), and the bound on loops and calls.
A refused program stops at its first refused line, as before; when other lines are refused too,
the error says how many and that ``gantry parse --all-errors`` lists them all, so a user fixes a
program in one pass. :func:`read_program` reads a program file as text, for the commands and the
Python API alike. :func:`checked_placement` tries the work offset a travel error suggests before
the user is told to use it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal, overload

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import GantryError, GcodeError
from gantry_sim.controller.gcode.control import DEFAULT_MAX_ITERATIONS
from gantry_sim.controller.gcode.lexer import decode_program
from gantry_sim.controller.input_files import MB, input_chunks
from gantry_sim.controller.moves import Event, Move
from gantry_sim.controller.spill import SpilledList


@overload
def interpret_program(
    text: str,
    *,
    dialect: str,
    file: str,
    machine: MachineConfig,
    search_path: Sequence[Path] = ...,
    max_iterations: int = ...,
    events: Literal[False] = ...,
    advance: Callable[[int], object] | None = ...,
    watch: Callable[[object, Sequence[object]], None] | None = ...,
) -> SpilledList[Move]: ...


@overload
def interpret_program(
    text: str,
    *,
    dialect: str,
    file: str,
    machine: MachineConfig,
    search_path: Sequence[Path] = ...,
    max_iterations: int = ...,
    events: Literal[True],
    advance: Callable[[int], object] | None = ...,
    watch: Callable[[object, Sequence[object]], None] | None = ...,
) -> SpilledList[Move | Event]: ...


def interpret_program(
    text: str,
    *,
    dialect: str,
    file: str,
    machine: MachineConfig,
    search_path: Sequence[Path] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    events: bool = False,
    advance: Callable[[int], object] | None = None,
    watch: Callable[[object, Sequence[object]], None] | None = None,
) -> SpilledList[Move] | SpilledList[Move | Event]:
    """The program's moves (and, with ``events``, its dwells, stops and limit changes), in a
    list kept on disk in blocks (:class:`~gantry_sim.controller.spill.SpilledList`: a long
    program's moves take no memory).

    Args:
        text: the program.
        dialect: the G-code dialect.
        file: the program's name for error messages.
        machine: its ``work`` gives the tool table and the starting offsets [mm].
        search_path: folders searched for ``NAME.ngc`` subroutine files, in order.
        max_iterations: bound on O-word loop repetitions and subroutine calls.
        events: include the program's events among the moves.
        advance: called with the source lines read since its last call, as the moves come (a
            progress bar's update).
        watch: called with each item as it comes and the items so far (sim.budget.ParseBound);
            what it raises stops the reading.

    Raises:
        GcodeError: the first refused line (file, line), its message ending with the count of
            the other refused lines when there are any.
    """
    from gantry_sim.controller.gcode.interpreter import interpret, interpret_events

    kwargs: dict[str, Any] = {
        "search_path": tuple(search_path),
        "max_iterations": max_iterations,
        "tools": machine.work.tool_table(),
        "parameters": machine.work.parameters(),
    }
    try:
        made = (interpret_events if events else interpret)(text, dialect, file, **kwargs)
        items = made if advance is None else _advancing(made, advance)
        if watch is None:
            return SpilledList(items)
        out: SpilledList = SpilledList()
        for item in items:
            out.append(item)
            watch(item, out)
        return out
    except GcodeError as exc:
        if "--max-iterations" in exc.message:
            raise  # the loop bound: a second pass would repeat the runaway loop's work
        others, whole = _other_refused_lines(text, dialect, file, kwargs)
        if others:
            at_least = "" if whole else "at least "
            exc.message += (
                f" ({at_least}{others} more line(s) refused; `gantry parse --all-errors` with "
                "the same options lists them all)"
            )
        raise


def checked_placement(
    exc: GantryError,
    text: str,
    *,
    dialect: str,
    machine: MachineConfig,
    search_path: Sequence[Path] = (),
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
) -> GantryError:
    """``exc``, where it suggests a work offset that would not place the program, with the
    suggestion replaced by why. The program is read again with the offset added to G54's
    origin and its moves checked against the travel: a program that sets its origin from where
    the tool stands (G92, G10 L20, g2core's G28.3; the tool starts at the work origin) or
    moves in machine coordinates (G53) does not move with G54."""
    from gantry_sim.controller.planner.travel import TravelError, check_travel

    if not isinstance(exc, TravelError) or exc.offset_mm is None:
        return exc
    shift = exc.offset_mm
    g54 = machine.work.systems_mm[0]
    work = machine.work.placed((g54[0] + shift[0], g54[1] + shift[1], g54[2] + shift[2]))
    placed = replace(machine, work=work)
    try:
        moves = interpret_program(
            text,
            dialect=dialect,
            file="<program>",
            machine=placed,
            search_path=search_path,
            max_iterations=max_iterations,
        )
        check_travel(moves, machine.travel)
        return exc  # placed so, it fits
    except GantryError:
        pass
    exc.offset_does_not_place()
    return exc


#: O-word loop repetitions and calls the count of further refused lines may make: past a
#: refused line its parameter settings are not made, so a loop whose counter depended on one
#: may never end (a program reading an unset ``#<_td>``: 1,000,000 repetitions, minutes of
#: work, to count two lines the loop's runaway itself refuses)
COUNT_MAX_ITERATIONS = 10_000


def _other_refused_lines(
    text: str, dialect: str, file: str, kwargs: dict[str, Any]
) -> tuple[int, bool]:
    """How many lines besides the first are refused (the whole program, refused lines
    skipped), and whether that is all of them: the count stops at
    :data:`~gantry_sim.controller.gcode.control.MAX_ERRORS` refused
    lines and at :data:`COUNT_MAX_ITERATIONS` loop repetitions."""
    from gantry_sim.controller.gcode.interpreter import interpret

    errors: list[GcodeError] = []
    bounded = dict(kwargs)
    bounded["max_iterations"] = min(
        kwargs.get("max_iterations", DEFAULT_MAX_ITERATIONS), COUNT_MAX_ITERATIONS
    )
    try:
        for _ in interpret(text, dialect, file, errors=errors, **bounded):
            pass
    except GantryError:
        return max(len(errors) - 1, 0), False  # the bound on errors or on loops: so far
    for k, exc in enumerate(errors):
        if "--max-iterations" in exc.message:  # what follows a loop stopped is its debris
            return max(k - 1, 0), False
    return max(len(errors) - 1, 0), True


#: the largest program read [bytes]: 500 MB, some 17 million lines of CAM output (an
#: hour-long program of 100,000 lines is 3 MB; a slicer's longest prints are a few hundred
#: MB). Read and split into lines, a program takes about 5 times its size in memory (9 times
#: for lines of one character, as ``yes`` writes them): 2 GiB, the cap before, let such a
#: stream take 19 GB. A stream that never ends is refused when it passes the cap.
MAX_PROGRAM_BYTES = 500 * MB
#: a stream (a pipe, ``/dev/stdin``) is read this many bytes at a time, each checked
READ_CHUNK_BYTES = 1 << 20


def read_program(path: Path) -> str:
    """Read a G-code program as text (UTF-8, else Latin-1): a file, or a stream such as
    ``/dev/stdin`` read a chunk at a time. Unreadable files, files with NUL bytes and programs
    of more than :data:`MAX_PROGRAM_BYTES` are a GcodeError."""
    chunks = input_chunks(
        path, "program", MAX_PROGRAM_BYTES, GcodeError, READ_CHUNK_BYTES, "the most read; split it"
    )
    return decode_program(_read_checked(chunks, path))


#: the byte-order marks of UTF-16 text (little- and big-endian), as Windows tools write it
_UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")


def _read_checked(read: Iterable[bytes], path: Path) -> bytes:
    """The program's bytes from its chunks ``read`` (capped by the reader at
    :data:`MAX_PROGRAM_BYTES`), without the NUL bytes that may pad its end (a file copied in
    blocks, a TinyG sample with two after its closing ``%``): refused at a byte after a NUL
    (naming the NUL's line) or past :data:`MAX_NUL_PADDING_BYTES` of padding (``/dev/zero``:
    at the first chunk), before the rest is read."""
    chunks: list[bytes] = []
    size = 0
    padding = 0  # NUL bytes since the first one
    for chunk in read:
        if padding:
            if chunk.count(0) != len(chunk):
                raise _nul_error(b"".join(chunks), path)
            padding += len(chunk)
        elif (nul := chunk.find(0)) >= 0:
            if not size and chunk[:2] in _UTF16_BOMS:
                raise GcodeError(
                    "the program is UTF-16 text (it starts with a UTF-16 byte-order mark); "
                    "G-code is read as ASCII, UTF-8 or Latin-1: save it as UTF-8",
                    file=str(path),
                )
            tail = chunk[nul:]
            if tail.count(0) != len(tail):
                raise _nul_error(b"".join([*chunks, chunk[:nul]]), path)
            chunks.append(chunk[:nul])
            size += nul
            padding = len(tail)
        else:
            size += len(chunk)
            chunks.append(chunk)
        if padding > MAX_NUL_PADDING_BYTES:
            raise GcodeError("not a G-code text file (it contains NUL bytes)", file=str(path))
    return b"".join(chunks)


#: NUL bytes accepted as padding after a program's last character
MAX_NUL_PADDING_BYTES = 64 << 10


def _nul_error(before: bytes, path: Path) -> GcodeError:
    """A NUL byte with text after it: the file is not G-code text; the line of the first NUL."""
    return GcodeError(
        "not a G-code text file (it contains NUL bytes; only padding after the program's "
        "last character is ignored)",
        file=str(path),
        line=before.count(b"\n") + 1,
    )


def _advancing(items: Iterable, advance: Callable[[int], object]) -> Iterator:
    """``items`` (the interpreter's moves and events), calling ``advance`` with the source
    lines passed as each one comes."""
    done = 0
    for item in items:
        line = getattr(item, "line", 0)
        if isinstance(line, int) and line > done:
            advance(line - done)
            done = line
        yield item
