"""Blocks of a plan's segments kept on disk until sampled: a long program's reference in bounded
memory.

A 100,000-block program's reference is hundreds of megabytes of segments (about 3 KB an arc,
:mod:`~gantry_sim.controller.planner.segmented_curve`), all of it held until the run ends when
kept in memory, while a run samples it one range of ticks at a time. :class:`BlockFile` writes
each full block, pickled, to an anonymous temporary file in ``$TMPDIR`` (unlinked at once: the
system frees it when the file is closed or the process ends, however it ends) and reads a block
back when it is laid out. Where no temporary file can be made or written (no writable folder, a
full disk), the blocks stay in memory.
Reads are ``os.pread`` (no shared file position), so threads may read at once.
"""

from __future__ import annotations

import os
import pickle
import tempfile
from typing import IO, Any

from gantry_sim.controller.planner.packed_block import PackedBlock

__all__ = ["Block", "BlockFile"]

#: A block: segments in time order, packed.
Block = PackedBlock


class BlockFile:
    """Blocks appended in order, each written to disk (``spill=True``) or kept in memory; read
    back by index; the last ones can be taken back (:meth:`truncate`)."""

    __slots__ = ("_end", "_file", "_held", "_spans")

    def __init__(self) -> None:
        self._file: IO[bytes] | None = None
        self._spans: list[tuple[int, int]] = []  # per block on disk: offset, size [bytes]
        self._held: dict[int, Block] = {}  # the blocks kept in memory, by index
        self._end = 0  # bytes of the file in use

    def __len__(self) -> int:
        return len(self._spans)

    def append(self, block: Block, *, spill: bool = True) -> None:
        """Add ``block`` after the others: on disk when ``spill`` (and a file can be made)."""
        data = b""
        if spill and self._open() is not None:
            data = pickle.dumps(block, protocol=pickle.HIGHEST_PROTOCOL)
            try:
                _write_all(self._fd(), data, self._end)
            except OSError:  # the disk is full (or gone): this block stays in memory
                data = b""
        if data:
            self._spans.append((self._end, len(data)))
            self._end += len(data)
        else:
            self._held[len(self._spans)] = block
            self._spans.append((self._end, 0))

    def __getitem__(self, b: int) -> Block:
        """Block ``b`` (a fresh copy of it when it was written to disk)."""
        held = self._held.get(b)
        if held is not None:
            return held
        offset, size = self._spans[b]
        block: Block = pickle.loads(_read_all(self._fd(), size, offset))
        return block

    def truncate(self, count: int) -> None:
        """Keep the first ``count`` blocks only."""
        if count >= len(self._spans):
            return
        self._end = self._spans[count][0]
        del self._spans[count:]
        for b in [b for b in self._held if b >= count]:
            del self._held[b]

    @property
    def spilled_bytes(self) -> int:
        """Bytes of the temporary file in use."""
        return self._end

    def close(self) -> None:
        """Free the temporary file (the blocks on it are lost)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def _open(self) -> IO[bytes] | None:
        if self._file is None:
            try:
                self._file = tempfile.TemporaryFile(prefix="gantry-plan-")
            except OSError:  # no writable temporary folder: keep the blocks in memory
                return None
        return self._file

    def _fd(self) -> int:
        if self._file is None:
            raise AssertionError("no block was written to disk")
        return self._file.fileno()

    def __getstate__(self) -> dict[str, Any]:
        """Pickled (a plan sent to another process), every block is carried in memory."""
        return {"held": {b: self[b] for b in range(len(self._spans))}}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._file, self._end = None, 0
        self._held = dict(state["held"])
        self._spans = [(0, 0)] * len(self._held)

    def __del__(self) -> None:
        self.close()


def _write_all(fd: int, data: bytes, offset: int) -> None:
    view = memoryview(data)
    while view:
        done = os.pwrite(fd, view, offset)
        view, offset = view[done:], offset + done


def _read_all(fd: int, size: int, offset: int) -> bytes:
    parts, left = [], size
    while left:
        got = os.pread(fd, left, offset)
        if not got:
            raise OSError(f"the plan's temporary file ended {left} bytes early")
        parts.append(got)
        left, offset = left - len(got), offset + len(got)
    return b"".join(parts)
