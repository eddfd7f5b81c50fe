"""A plan's reference held as the planner made it, its phases laid out only where sampled.

The planner's chains are stretches of constant-jerk phases (:data:`~gantry_sim.controller.planner.cubic.Chunk`):
closed-form arc pieces are held as :class:`~gantry_sim.controller.planner.cubic.Jerk3Run`
(19 numbers per piece of three phases, where three laid-out phases on three axes take 45), Ruckig
pieces and straight moves as (5, n) arrays per axis. Laying the whole reference out as one
:class:`~gantry_sim.controller.planner.cubic.PiecewiseCubic` took 120 bytes a phase: about 1 GB
for a 100,000-block CAM program, held for the whole run. :class:`SegmentedCurve` keeps the
segments, grouped into blocks of about :data:`BLOCK_PHASES` phases, and lays out a block's phases
when a sample falls in it (the last :data:`CACHED_BLOCKS` blocks are kept, so a run that samples
range after range lays each block out about once). The segments themselves took about 3 KB an
arc (400 MB at 100,000 arcs, and as much again in the planner's forked children, which copied
the pages they touched): :class:`CurveBuilder` writes each full block to a temporary file as the
planner's windows add them (:mod:`~gantry_sim.controller.spill`), so memory holds
one block being built and the blocks laid out.

The numbers are those of the laid-out curve bit for bit: a phase's start time is the running sum
of the durations before it, added in the same order (each block's sum starts from the previous
block's last one: ``np.cumsum`` adds one term at a time), and a sample takes the phase and the
formula that :meth:`PiecewiseCubic.evaluate` takes (tests/test_segmented_curve.py checks).
"""

from __future__ import annotations

from array import array
from collections import OrderedDict
from collections.abc import Iterator
from itertools import pairwise

import numpy as np

from gantry_sim.controller.planner.cubic import Chunk, Jerk3Run, PiecewiseCubic, Segment
from gantry_sim.controller.planner.packed_block import PackedBlock, Phases
from gantry_sim.controller.spill import BlockFile

__all__ = ["BLOCK_PHASES", "CACHED_BLOCKS", "CurveBuilder", "SegmentedCurve"]

#: Phases (on the first axis) per block laid out at a time: 65,536 phases take 2.6 MB per axis.
BLOCK_PHASES = 65_536
#: Blocks kept laid out (a range of samples rarely spans more than two).
CACHED_BLOCKS = 3


def _phase_count(seg: Segment, axis: int) -> int:
    return 3 * seg.h.size if isinstance(seg, Jerk3Run) else seg[axis].shape[1]


class CurveBuilder:
    """A :class:`SegmentedCurve` made chunk by chunk: full blocks go to a :class:`BlockFile` as
    they fill (so a long program's reference is held on disk, not in memory, while it is
    planned and run), and the chunks added last can be taken back (:meth:`truncate`: a planning
    window sent back). The curve made is the same, bit for bit, as one made of the chunks kept,
    added at once."""

    __slots__ = ("_carry", "_chunk_at", "_counts", "_current", "_file", "_size", "_starts")

    def __init__(self) -> None:
        self._file: BlockFile[PackedBlock] = BlockFile()
        self._current: list[Segment] = []  # the open block's segments
        self._size = 0  # its phases on the first axis
        self._carry = np.zeros(3)  # per axis the open block's start time [s]
        self._counts: list[np.ndarray] = []  # per closed block: phases per axis
        self._starts: list[np.ndarray] = []  # per closed block: start time per axis [s]
        # per chunk, flattened: (block, segment) of its start (an array: one a move, for the
        # whole program, so no small object per chunk is left among the window's garbage)
        self._chunk_at = array("q")

    def __len__(self) -> int:
        """Chunks added (and not taken back)."""
        return len(self._chunk_at) // 2

    def extend(self, chunks: list[Chunk]) -> None:
        """Add ``chunks`` (stretches of phases in time order, after those added before); the
        list is emptied as it is read, so the segments are held once."""
        chunks.reverse()
        while chunks:
            self._chunk_at.extend((len(self._file), len(self._current)))
            for seg in chunks.pop():
                self._current.append(seg)
                self._size += _phase_count(seg, 0)
                if self._size >= BLOCK_PHASES:
                    self._close(spill=True)

    def truncate(self, count: int) -> None:
        """Keep the first ``count`` chunks only."""
        if count >= len(self):
            return
        b, s = self._chunk_at[2 * count], self._chunk_at[2 * count + 1]
        del self._chunk_at[2 * count :]
        if b < len(self._file):  # the chunk began in a closed block: open it again
            self._current = list(self._file[b].segments())
            self._file.truncate(b)
            self._carry = self._starts[b]
            del self._counts[b:], self._starts[b:]
        del self._current[s:]
        self._size = sum(_phase_count(seg, 0) for seg in self._current)

    def finish(self) -> SegmentedCurve:
        """The curve of the chunks added (the builder is left empty)."""
        curve = SegmentedCurve.__new__(SegmentedCurve)
        curve._setup(*self._take())
        return curve

    def _take(self) -> tuple[BlockFile[PackedBlock], np.ndarray, np.ndarray]:
        """The blocks, with their phase counts and start times [s] (3, blocks), handed over:
        the builder is left empty."""
        if self._current:
            self._close(spill=False)
        counts = np.array(self._counts, dtype=np.int64).reshape(-1, 3).T
        starts = np.array(self._starts, dtype=float).reshape(-1, 3).T
        blocks, self._file = self._file, BlockFile()
        self._counts, self._starts, self._chunk_at = [], [], array("q")
        self._carry = np.zeros(3)
        return blocks, counts, starts

    def _close(self, *, spill: bool) -> None:
        """Close the open block: its phase counts and start times, then into the file."""
        block = PackedBlock(self._current)
        counts = np.zeros(3, dtype=np.int64)
        carry = self._carry.copy()
        for i in range(3):
            dur = block.durations(i)
            counts[i] = dur.size
            if counts[i]:
                carry[i] = float(np.cumsum(np.concatenate(([carry[i]], dur)))[-1])
        self._counts.append(counts)
        self._starts.append(self._carry)
        self._carry = carry
        self._file.append(block, spill=spill)
        self._current, self._size = [], 0


class SegmentedCurve:
    """The reference as constant-jerk phases per axis, held segment by segment (see the module
    docstring); :meth:`evaluate` and :attr:`axes` as :class:`PiecewiseCubic`'s."""

    __slots__ = ("_block_starts", "_blocks", "_cache", "_counts", "_first", "_starts")

    def __init__(self, chunks: list[Chunk]) -> None:
        """The curve of ``chunks`` (stretches of phases in time order), which is emptied as it
        is read: the segments are held once (in a temporary file past the first block)."""
        builder = CurveBuilder()
        builder.extend(chunks)
        self._setup(*builder._take())

    def _setup(
        self, blocks: BlockFile[PackedBlock], counts: np.ndarray, starts: np.ndarray
    ) -> None:
        """``blocks`` of segments with their phase counts and start times [s], (3, blocks)."""
        self._blocks = blocks
        self._counts = counts
        self._block_starts = starts  # (3, blocks) [s]
        # per axis: the start time [s] of each block with phases on that axis, and its index
        self._first = tuple(np.flatnonzero(counts[i]) for i in range(3))
        self._starts = tuple(starts[i, self._first[i]] for i in range(3))
        self._cache: OrderedDict[int, tuple[Phases, Phases, Phases]] = OrderedDict()

    @property
    def spilled_bytes(self) -> int:
        """Bytes of the curve's segments held in its temporary file."""
        return self._blocks.spilled_bytes

    @property
    def phase_counts(self) -> tuple[int, int, int]:
        """Phases per axis."""
        c = self._counts.sum(axis=1)
        return int(c[0]), int(c[1]), int(c[2])

    def blocks(self) -> Iterator[Chunk]:
        """The curve's segments, a block at a time in time order (each block's segments as one
        :data:`~gantry_sim.controller.planner.cubic.Chunk`, fresh arrays holding the same
        numbers): added to a :class:`CurveBuilder` one after the other, they make this curve
        again, after whatever it holds (the plans of a program's parts joined:
        :mod:`~gantry_sim.controller.planner.limit_events`)."""
        for b in range(len(self._blocks)):
            yield self._blocks[b].segments()

    def _block(self, axis: int, k: int) -> Phases:
        """Block ``self._first[axis][k]``'s phases on ``axis``: start time [s], p, v, a, j."""
        return self._layout(int(self._first[axis][k]))[axis]

    def _layout(self, b: int) -> tuple[Phases, Phases, Phases]:
        """Block ``b``'s phases on every axis (:meth:`PackedBlock.layout`)."""
        hit = self._cache.get(b)
        if hit is not None:
            self._cache.move_to_end(b)
            return hit
        laid_out = self._blocks[b].layout(self._block_starts[:, b])
        self._cache[b] = laid_out
        while len(self._cache) > CACHED_BLOCKS:
            self._cache.popitem(last=False)
        return laid_out

    @property
    def axes(self) -> tuple[tuple[np.ndarray, ...], ...]:
        """Every phase laid out: per axis (t0, p, v, a, j), as :class:`PiecewiseCubic` holds
        them (built on each call: the whole reference, 120 bytes a phase)."""
        out = []
        for i in range(3):
            parts = [self._block(i, k) for k in range(self._first[i].size)]
            cols = [
                np.concatenate([p[c] for p in parts]) if parts else np.empty(0) for c in range(5)
            ]
            out.append(tuple(cols))
        return tuple(out)

    def laid_out(self) -> PiecewiseCubic:
        """The same reference as one :class:`PiecewiseCubic`."""
        return PiecewiseCubic(self.axes)

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration (N, 3) at times ``t`` (N,) [s]: those of
        :meth:`PiecewiseCubic.evaluate` on the laid-out phases, bit for bit."""
        t = np.asarray(t, dtype=float)
        pos = np.zeros((t.size, 3))
        vel = np.zeros((t.size, 3))
        acc = np.zeros((t.size, 3))
        order = (
            None if t.size < 2 or bool(np.all(t[1:] >= t[:-1])) else np.argsort(t, kind="stable")
        )
        ts = t if order is None else t[order]
        for i in range(3):
            starts = self._starts[i]
            if starts.size == 0:
                continue
            blk = np.clip(np.searchsorted(starts, ts, side="right") - 1, 0, starts.size - 1)
            cuts = np.concatenate(([0], np.flatnonzero(np.diff(blk)) + 1, [ts.size]))
            for lo, hi in pairwise(cuts.tolist()):
                if hi <= lo:
                    continue
                t0, p, v, a, j = self._block(i, int(blk[lo]))
                tt = ts[lo:hi]
                k = np.clip(np.searchsorted(t0, tt, side="right") - 1, 0, t0.size - 1)
                dt = tt - t0[k]
                jk, ak = j[k], a[k]
                rows = slice(lo, hi) if order is None else order[lo:hi]
                pos[rows, i] = p[k] + dt * (v[k] + dt * (0.5 * ak + dt * jk / 6.0))
                vel[rows, i] = v[k] + dt * (ak + 0.5 * dt * jk)
                acc[rows, i] = ak + dt * jk
        return pos, vel, acc
