"""A slice of a list kept on disk (:class:`~gantry_sim.controller.spill.SpilledList`), carried as
the pickled blocks that hold it and decoded where it is used.

A streamed run hands every range's analysis the program moves and path moves it reaches
(sim.range_rows), thousands of them, to a worker process. Read from the list and sent as
objects, each move was unpickled from the list's file, pickled for the pipe and unpickled again
in the worker: 0.5-0.6 s of the range helper's CPU at 30,000 polyline blocks, on the core the
worker needs. As a :class:`PickledSlice` the helper reads the blocks' bytes and sends them as
they are, and the worker decodes each block once (:class:`DecodedBlocks` keeps the last few:
consecutive ranges share the blocks at their boundary).
"""

from __future__ import annotations

import pickle
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, overload

from gantry_sim.controller.gc_pause import gc_paused

__all__ = ["DecodedBlocks", "PickledSlice", "SliceView", "read_span"]


@dataclass(frozen=True)
class PickledSlice:
    """Items ``skip .. skip + count`` of the concatenated blocks ``blocks`` (each a pickled
    list of ``block_items`` items, the last maybe fewer), blocks ``first_block ..`` of the list
    identified by ``token``. ``closed``: how many of those blocks are closed (never changed
    again while the token stands), so a reader may keep them decoded by (token, block number);
    the others (the list's open last block) are decoded every time."""

    token: int
    first_block: int
    blocks: tuple[bytes, ...]
    closed: int
    skip: int
    count: int
    block_items: int

    def __len__(self) -> int:
        return self.count

    def items(self, cache: DecodedBlocks | None = None) -> list[Any]:
        """The items, decoded (blocks kept in ``cache`` are decoded once)."""
        return SliceView(self, cache)[:]


def read_span(block: Callable[[int], list[Any]], per: int, lo: int, hi: int) -> list[Any]:
    """Items ``lo`` .. ``hi`` - 1 of a list kept in blocks of ``per`` items, block b being
    ``block(b)`` (the last may be shorter; ``hi`` within the list)."""
    out: list[Any] = []
    while lo < hi:
        b, at = divmod(lo, per)
        items = block(b)
        take = min(hi - lo, len(items) - at)
        out.extend(items[at : at + take])
        lo += take
    return out


class SliceView(Sequence[Any]):
    """A :class:`PickledSlice`'s items read by index or slice, its blocks decoded as they are
    reached and kept in ``cache`` (default: the last two): a reader that goes through them in
    order, a block at a time, holds a block or two of objects, not the slice's."""

    def __init__(self, part: PickledSlice, cache: DecodedBlocks | None = None) -> None:
        self._part = part
        self._cache = DecodedBlocks(2) if cache is None else cache
        self._held: list[Any] | None = None  # the open block, decoded

    def __len__(self) -> int:
        return self._part.count

    @overload
    def __getitem__(self, index: int) -> Any: ...

    @overload
    def __getitem__(self, index: slice) -> list[Any]: ...

    def __getitem__(self, index: int | slice) -> Any:
        part, per = self._part, self._part.block_items
        if isinstance(index, slice):
            lo, hi, step = index.indices(part.count)
            if step != 1:
                return [self[i] for i in range(lo, hi, step)]
            return read_span(self._block, per, part.skip + lo, part.skip + max(hi, lo))
        i = index + part.count if index < 0 else index
        if not 0 <= i < part.count:
            raise IndexError(f"index {index} out of range for {part.count} items")
        k, at = divmod(part.skip + i, per)
        return self._block(k)[at]

    def _block(self, k: int) -> list[Any]:
        part = self._part
        key = (part.token, part.first_block + k) if k < part.closed else None
        return self._cache.get(key, part.blocks[k]) if key is not None else self._open(k)

    def _open(self, k: int) -> list[Any]:
        """The slice's open block (decoded once here: its key is not the list's to keep)."""
        if self._held is None:
            self._held = _decoded(self._part.blocks[k])
        return self._held


class DecodedBlocks:
    """The last ``size`` closed blocks decoded by :meth:`PickledSlice.items`, by (token, block
    number)."""

    def __init__(self, size: int = 6) -> None:
        self._size = size
        self._blocks: OrderedDict[tuple[int, int], list[Any]] = OrderedDict()

    def get(self, key: tuple[int, int] | None, data: bytes) -> list[Any]:
        """Block ``key`` decoded (from ``data`` when not kept; ``key`` None: never kept)."""
        if key is None:
            return _decoded(data)
        block = self._blocks.get(key)
        if block is None:
            block = _decoded(data)
            self._blocks[key] = block
            while len(self._blocks) > self._size:
                self._blocks.popitem(last=False)
        else:
            self._blocks.move_to_end(key)
        return block


def _decoded(data: bytes) -> list[Any]:
    with gc_paused():  # thousands of objects at once (see controller/spill.py)
        block: list[Any] = pickle.loads(data)
    return block
