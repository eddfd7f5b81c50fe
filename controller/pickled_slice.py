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
from dataclasses import dataclass
from typing import Any

from gantry_sim.controller.gc_pause import gc_paused

__all__ = ["DecodedBlocks", "PickledSlice"]


@dataclass(frozen=True)
class PickledSlice:
    """Items ``skip .. skip + count`` of the concatenated blocks ``blocks`` (each a pickled
    list), blocks ``first_block ..`` of the list identified by ``token``. ``closed``: how many
    of those blocks are closed (never changed again while the token stands), so a reader may
    keep them decoded by (token, block number); the others (the list's open last block) are
    decoded every time."""

    token: int
    first_block: int
    blocks: tuple[bytes, ...]
    closed: int
    skip: int
    count: int

    def __len__(self) -> int:
        return self.count

    def items(self, cache: DecodedBlocks | None = None) -> list[Any]:
        """The items, decoded (blocks kept in ``cache`` are decoded once)."""
        out: list[Any] = []
        lo, hi = self.skip, self.skip + self.count
        start = 0  # the first item's index of the block at hand, in the slice's blocks
        for k, data in enumerate(self.blocks):
            if start >= hi:
                break
            key = (self.token, self.first_block + k) if k < self.closed else None
            block = cache.get(key, data) if cache is not None else _decoded(data)
            out.extend(block[max(lo - start, 0) : hi - start])
            start += len(block)
        return out


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
