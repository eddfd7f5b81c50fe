"""Long sequences kept on disk in pickled blocks: memory bounded by a block, not the program.

A 100,000-block program is hundreds of megabytes as Python objects and arrays: its moves (about
0.4 KB each), the path the planner follows (1 KB a move), the chord vertices, the reference's
segments (about 3 KB an arc, :mod:`~gantry_sim.controller.planner.segmented_curve`), while every
stage uses a window of them at a time. Two containers keep them on disk:

* :class:`BlockFile`: blocks (any picklable object) appended in order, each written, pickled, to
  an anonymous temporary file in ``$TMPDIR`` (unlinked at once: the system frees it when the
  file is closed or the process ends, however it ends) and read back by index; the last ones
  can be taken back. Where no temporary file can be made or written (no writable folder, a full
  disk), the blocks stay in memory. Reads are ``os.pread`` (no shared file position), so
  threads and forked processes may read at once.
* :class:`SpilledList`: a list of items in blocks of :data:`BLOCK_ITEMS` on a :class:`BlockFile`
  (the last, open block in memory), read back by index, slice or in order, a few decoded blocks
  cached. The items read back are equal to those appended (pickled copies: identity is not kept
  across blocks).
  :meth:`SpilledList.pickled` hands a slice to another process as the pickled blocks that
  hold it, read from disk and not decoded (controller/pickled_slice.py).
"""

from __future__ import annotations

import itertools
import os
import pickle
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Iterable, Iterator, Sequence
from typing import IO, Any, Generic, TypeVar, overload

from gantry_sim.controller.gc_pause import gc_paused
from gantry_sim.controller.pickled_slice import PickledSlice, read_span

__all__ = ["BLOCK_ITEMS", "BlockFile", "SpilledList"]

#: Items per block of a :class:`SpilledList` (moves: about 0.4 MB pickled).
BLOCK_ITEMS = 4096
#: A SpilledList's identity for the readers of its :class:`PickledSlice` s (new at every
#: truncate: its blocks change)
_TOKENS = itertools.count(1)
#: Decoded blocks a :class:`SpilledList` keeps (the least recently read first to go): its
#: readers go in order, a window or a range at a time.
CACHED_BLOCKS = 2

T = TypeVar("T")


class BlockFile(Generic[T]):
    """Blocks appended in order, each written to disk (``spill=True``) or kept in memory; read
    back by index; the last ones can be taken back (:meth:`truncate`)."""

    __slots__ = ("_end", "_file", "_held", "_spans")

    def __init__(self) -> None:
        self._file: IO[bytes] | None = None
        self._spans: list[tuple[int, int]] = []  # per block on disk: offset, size [bytes]
        self._held: dict[int, T] = {}  # the blocks kept in memory, by index
        self._end = 0  # bytes of the file in use

    def __len__(self) -> int:
        return len(self._spans)

    def append(self, block: T, *, spill: bool = True) -> None:
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

    def __getitem__(self, b: int) -> T:
        """Block ``b`` (a fresh copy of it when it was written to disk)."""
        held = self._held.get(b)
        if held is not None:
            return held
        offset, size = self._spans[b]
        data = _read_all(self._fd(), size, offset)
        # thousands of new objects at once: with the cyclic collector running, its passes walk
        # the whole heap again and again meanwhile (a block of 4,096 moves decoded in 25 ms
        # instead of 6 in a 30,000-move run)
        with gc_paused():
            block: T = pickle.loads(data)
        return block

    def raw(self, b: int) -> bytes:
        """Block ``b`` pickled: the bytes on disk as they are (a block kept in memory is
        pickled now)."""
        held = self._held.get(b)
        if held is not None:
            return pickle.dumps(held, protocol=pickle.HIGHEST_PROTOCOL)
        offset, size = self._spans[b]
        return _read_all(self._fd(), size, offset)

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
                self._file = tempfile.TemporaryFile(prefix="gantry-")
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


class SpilledList(Sequence[T]):
    """A list kept on disk in blocks of ``block_items`` (see the module docstring): appended
    to, read by index, slice or in order, the last items taken back by :meth:`truncate`.

    ``spill=False`` keeps every block in memory (the same container, for short lists and
    tests). Pickled (sent to another process), the items are carried in memory.
    """

    __slots__ = ("_block_items", "_cache", "_file", "_lock", "_spill", "_tail", "_token")

    def __init__(
        self, items: Iterable[T] = (), *, block_items: int = BLOCK_ITEMS, spill: bool = True
    ) -> None:
        if block_items < 1:
            raise ValueError(f"block_items must be >= 1, got {block_items}")
        self._block_items = block_items
        self._spill = spill
        self._file: BlockFile[list[T]] = BlockFile()
        self._tail: list[T] = []  # the open block
        self._cache: OrderedDict[int, list[T]] = OrderedDict()
        self._lock = threading.Lock()
        self._token = next(_TOKENS)
        self.extend(items)

    def __len__(self) -> int:
        return len(self._file) * self._block_items + len(self._tail)

    def append(self, item: T) -> None:
        """Add ``item`` at the end."""
        self._tail.append(item)
        if len(self._tail) >= self._block_items:
            self._file.append(self._tail, spill=self._spill)
            self._tail = []

    def extend(self, items: Iterable[T]) -> None:
        """Add ``items`` at the end, in order."""
        for item in items:
            self.append(item)

    @overload
    def __getitem__(self, index: int) -> T: ...

    @overload
    def __getitem__(self, index: slice) -> list[T]: ...

    def __getitem__(self, index: int | slice) -> T | list[T]:
        n = len(self)
        if isinstance(index, slice):
            lo, hi, step = index.indices(n)
            if step != 1:
                return [self[i] for i in range(lo, hi, step)]
            return read_span(self._block, self._block_items, lo, hi)
        i = index + n if index < 0 else index
        if not 0 <= i < n:
            raise IndexError(f"index {index} out of range for {n} items")
        b, k = divmod(i, self._block_items)
        return self._block(b)[k]

    def pickled(self, lo: int, hi: int) -> PickledSlice:
        """Items ``lo`` .. ``hi`` - 1 (clipped as a slice) as the pickled blocks that hold them,
        read from disk without decoding (controller/pickled_slice.py)."""
        lo, hi, _ = slice(lo, hi).indices(len(self))
        hi = max(hi, lo)
        first, last = lo // self._block_items, (hi - 1) // self._block_items
        closed = len(self._file)
        blocks = [
            self._file.raw(b)
            if b < closed
            else pickle.dumps(self._tail, protocol=pickle.HIGHEST_PROTOCOL)
            for b in range(first, last + 1)
        ]
        return PickledSlice(
            token=self._token,
            first_block=first,
            blocks=tuple(blocks),
            closed=max(0, min(closed - first, len(blocks))),
            skip=lo - first * self._block_items,
            count=hi - lo,
            block_items=self._block_items,
        )

    def __iter__(self) -> Iterator[T]:
        for b in range(len(self._file)):
            yield from self._block(b)
        yield from list(self._tail)

    def __eq__(self, other: object) -> bool:
        """Equal to another SpilledList, or a list, with equal items in the same order (a list
        kept on disk: as a list is, it is not equal to a tuple)."""
        if not isinstance(other, SpilledList | list):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))

    __hash__ = None  # type: ignore[assignment]  # mutable, as a list

    def truncate(self, count: int) -> None:
        """Keep the first ``count`` items only."""
        if count >= len(self):
            return
        b, k = divmod(max(count, 0), self._block_items)
        if b < len(self._file):  # the cut lies in a closed block: it becomes the open one
            self._token = next(_TOKENS)  # its pickled slices' blocks are no longer these
            self._tail = list(self._block(b))
            self._file.truncate(b)
            with self._lock:
                for gone in [c for c in self._cache if c >= b]:
                    del self._cache[gone]
        del self._tail[k:]

    def close(self) -> None:
        """Free the temporary file (the items on it are lost)."""
        self._file.close()
        self._cache.clear()

    def _block(self, b: int) -> list[T]:
        """Closed block ``b`` (or the open one), decoded once while it stays cached."""
        if b == len(self._file):
            return self._tail
        with self._lock:
            block = self._cache.get(b)
            if block is not None:
                self._cache.move_to_end(b)
                return block
        block = self._file[b]
        with self._lock:
            self._cache[b] = block
            while len(self._cache) > CACHED_BLOCKS:
                self._cache.popitem(last=False)
        return block

    def __getstate__(self) -> dict[str, Any]:
        return {"items": list(self), "block_items": self._block_items}

    def __setstate__(self, state: dict[str, Any]) -> None:
        SpilledList.__init__(self, state["items"], block_items=state["block_items"], spill=False)

    def __repr__(self) -> str:
        return f"SpilledList({len(self)} items, {len(self._file)} closed blocks)"


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
