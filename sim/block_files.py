"""Feed blocks told apart by file: a subroutine file's line 3 is not the program's line 3.

A program that calls subroutines kept in files of their own (``o<name> call`` of NAME.ngc on the
subroutine path, an M98 subprogram found in a file) runs moves from several files, each
numbering its lines from 1. The per-block figures (sim.error_tally) group ticks by a block KEY:
a move's line in the program's own file, its line plus its file's number times 2**32 in a
subroutine file (files numbered from 1 in the order their first move comes). A program without subroutine files has
keys equal to its lines, and its figures are the same numbers as before, bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy imported where keys are made: gates and compare only need place()
    import numpy as np

__all__ = ["FILE_SHIFT", "block_keys", "place", "split_key", "tick_keys"]

#: a key's file number sits above its line's 32 bits (a program's lines stay below 2**32: the
#: largest program read is 500 MB)
FILE_SHIFT = 32
_LINE_MASK = (1 << FILE_SHIFT) - 1


def block_keys(
    lines: np.ndarray, files: Sequence[str | None]
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Per move its block key (int64; its line where ``files`` is None), from its line (m,)
    and its file (the move's ``file``: None in the program's own file); and the subroutine
    files' names, file number k being names[k - 1]."""
    import numpy as np

    lines = np.asarray(lines, dtype=np.int64)
    if all(f is None for f in files):
        return lines, ()
    names: dict[str, int] = {}
    number = np.array(
        [0 if f is None else names.setdefault(f, len(names) + 1) for f in files], dtype=np.int64
    )
    return lines + (number << FILE_SHIFT), tuple(names)


def tick_keys(
    line: np.ndarray, source: np.ndarray | None, keys: np.ndarray, files: tuple[str, ...]
) -> np.ndarray:
    """Per tick its block key: the key of the move it executes (``source`` (n, 2), program
    move indices as Trajectory.source gives them, its first column) where known, else its
    line; ``line`` itself when no move is in a subroutine file (``files`` empty)."""
    import numpy as np

    if not files or source is None:
        return np.asarray(line)
    first = np.asarray(source).reshape(-1, 2)[:, 0]
    known = (first >= 0) & (first < len(keys))
    return np.where(known, keys[np.where(known, first, 0)], line)


def place(line: int, file: str | None) -> str:
    """A block's place as messages say it: "line N", and "of FILE" for a subroutine file's."""
    return f"line {line}" + ("" if file is None else f" of {file}")


def split_key(key: int, files: tuple[str, ...]) -> tuple[int, str | None]:
    """(line, file) of a block key (file None: the program's own)."""
    number = key >> FILE_SHIFT
    return key & _LINE_MASK, files[number - 1] if number else None
