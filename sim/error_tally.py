"""A run's whole-run contour-error figures from its ticks fed in order, in bounded memory.

:class:`ErrorTally` takes consecutive ranges of ticks (each tick's program line, contour error
[um] and feed flag) and gives, at the end, what report.json needs of them: the statistics over
the feed ticks (largest, rms, exact 95th percentile) and per feed block its largest and rms
error and its tick count, over the block's feed ticks (a canned cycle's line runs rapids too:
they count in neither). It holds per block a few numbers, the ticks of at most one tile, and
the feed ticks' errors for the percentile -- in memory for a run analysed at once, in an
anonymous temporary file for a streamed one (sim.percentile.ValueSpill: 8 bytes a feed tick on
disk, none in memory).

Sums of squares are taken tile by tile: TILE_TICKS ticks aligned to the run's first tick,
summed with numpy's pairwise sum (over the feed ticks of the tile, and over each block's ticks
of the tile in tick order), the tiles' sums then added in tile order: a run of one tile gets
exactly ``np.mean(err ** 2)``. The figures therefore depend on the
ticks only, never on how the run was cut into ranges: a streamed run gives the whole-run
analysis' numbers bit for bit (tests/test_stream.py).
"""

from __future__ import annotations

import numpy as np

from gantry_sim.sim.move_table import MoveTable, ProgramIndex
from gantry_sim.sim.percentile import ValueSpill, percentile_linear

#: ticks summed at once (aligned to the run's first tick)
TILE_TICKS = 65536
#: A block's ticks in a tile fewer than this are summed as columns (one numpy call per column
#: for every such block at once) rather than one ``np.add.reduce`` per block: numpy sums fewer
#: than 8 numbers in order from 0 (its pairwise sum starts at 8), so the columns give the same
#: number bit for bit (tests/test_error_tally.py). On polylines a block lasts a few ticks: the
#: per-block loop took 0.3 s of the range helper's CPU at 30,000 blocks.
SHORT_BLOCK_TICKS = 8


class ErrorTally:
    """Whole-run error figures of the ticks :meth:`add` ed in order (see the module docstring).

    ``tab``: the program's move table or index (which lines are feed blocks, and their kinds);
    ``keys``: per move of ``tab`` its block key (sim.block_files; default: its line), the
    ticks then :meth:`add` ed with their keys (sim.block_files.tick_keys); ``spill``: keep the
    feed ticks' errors on disk rather than in memory; ``tile_ticks``: default TILE_TICKS.
    """

    def __init__(
        self,
        tab: MoveTable | ProgramIndex,
        *,
        spill: bool,
        tile_ticks: int | None = None,
        keys: np.ndarray | None = None,
    ) -> None:
        feed_moves = np.flatnonzero(tab.feed)
        keys = tab.line if keys is None else keys
        lines, first = np.unique(keys[feed_moves], return_index=True)
        order = np.argsort(first, kind="stable")  # blocks in program order
        firsts = feed_moves[first[order]]
        self.block_lines = lines[order]
        self.block_kinds = np.where(
            tab.arc[firsts], "arc", np.where(tab.spline[firsts], "spline", "linear")
        )
        self._sorted_lines = lines  # sorted; block of lines[i] is _block_of[i]
        self._block_of = np.argsort(order, kind="stable")
        nb = lines.size
        self.block_max = np.zeros(nb)
        self.block_sq = np.zeros(nb)
        self.block_ticks = np.zeros(nb, dtype=np.int64)
        self.feed_max = 0.0
        self.feed_sq = 0.0
        self._tile = tile_ticks or TILE_TICKS
        self._pending: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._pending_n = 0
        self.values = ValueSpill(on_disk=spill)

    def add(self, line: np.ndarray, err_um: np.ndarray, feed: np.ndarray) -> None:
        """The next ticks: their program lines (n,) (their block keys where the tally was made
        with ``keys``), contour errors (n,) [um], feed flags (n,)."""
        line, err_um, feed = np.asarray(line), np.asarray(err_um, float), np.asarray(feed, bool)
        while line.size:
            take = min(line.size, self._tile - self._pending_n)
            self._pending.append((line[:take], err_um[:take], feed[:take]))
            self._pending_n += take
            line, err_um, feed = line[take:], err_um[take:], feed[take:]
            if self._pending_n == self._tile:
                self._reduce_tile()

    def _reduce_tile(self) -> None:
        if not self._pending:
            return
        if len(self._pending) == 1:
            line, err, feed = self._pending[0]
        else:
            line, err, feed = (np.concatenate(c) for c in zip(*self._pending, strict=True))
        self._pending, self._pending_n = [], 0
        fe = err[feed]
        if fe.size:
            self.feed_max = max(self.feed_max, float(fe.max()))
            self.feed_sq += float(np.add.reduce(fe * fe))
            self.values.add(fe)
        if not self._sorted_lines.size:
            return
        at = np.minimum(np.searchsorted(self._sorted_lines, line), self._sorted_lines.size - 1)
        mine = (self._sorted_lines[at] == line) & feed
        block, e = self._block_of[at[mine]], err[mine]
        if not block.size:
            return
        order = np.argsort(block, kind="stable")  # each block's ticks in tick order
        block, e = block[order], e[order]
        starts = np.flatnonzero(np.r_[True, block[1:] != block[:-1]])
        counts = np.diff(np.r_[starts, block.size])
        short = counts < SHORT_BLOCK_TICKS
        self._add_blocks(
            block[starts[short]], *_short_block_figures(e, starts[short], counts[short])
        )
        long = np.flatnonzero(~short)
        if long.size:
            add, biggest = np.add.reduce, np.maximum.reduce
            parts = [
                e[lo : lo + k]
                for lo, k in zip(starts[long].tolist(), counts[long].tolist(), strict=True)
            ]
            sums = np.array([float(add(part * part)) for part in parts])
            peaks = np.array([float(biggest(part)) for part in parts])
            self._add_blocks(block[starts[long]], sums, peaks, counts[long])

    def _add_blocks(
        self, blocks: np.ndarray, sums: np.ndarray, peaks: np.ndarray, counts: np.ndarray
    ) -> None:
        """Add one tile's figures of ``blocks`` (each once): sums of squares, largest errors
        (kept where not larger, as Python's ``max``), tick counts."""
        self.block_sq[blocks] += sums
        was = self.block_max[blocks]
        self.block_max[blocks] = np.where(peaks > was, peaks, was)
        self.block_ticks[blocks] += counts

    def finish(self) -> tuple[tuple[float, float, float], list[tuple[int, str, float, float, int]]]:
        """((max, rms, p95) over the feed ticks [um] (zeros when none), per feed block in program
        order (line, or block key, kind, max [um], rms [um], ticks)). Closes the spill."""
        self._reduce_tile()
        n = self.values.count
        try:
            if n:
                stats = (
                    self.feed_max,
                    float(np.sqrt(self.feed_sq / n)),
                    percentile_linear(self.values.kth, n, 95),
                )
            else:
                stats = (0.0, 0.0, 0.0)
        finally:
            self.values.close()
        ticks = self.block_ticks
        rms = np.sqrt(self.block_sq / np.maximum(ticks, 1))
        blocks = [
            (int(ln), str(kind), float(peak), float(r), int(t))
            for ln, kind, peak, r, t in zip(
                self.block_lines.tolist(),
                self.block_kinds.tolist(),
                self.block_max.tolist(),
                rms.tolist(),
                ticks.tolist(),
                strict=True,
            )
        ]
        return stats, blocks


def _short_block_figures(
    e: np.ndarray, starts: np.ndarray, counts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per block of fewer than SHORT_BLOCK_TICKS errors e[start:start + count] [um]: the sum of
    squares, taken in order from 0 (as ``np.add.reduce`` of so few numbers), the largest error,
    and the count."""
    width = SHORT_BLOCK_TICKS - 1
    col = np.arange(width)
    held = col[None, :] < counts[:, None]
    at = np.minimum(starts[:, None] + col[None, :], max(e.size - 1, 0))
    vals = e[at] if e.size else np.zeros(at.shape)
    sq = np.where(held, vals * vals, 0.0)  # + 0.0 after the last square changes no sum
    total = np.zeros(len(starts))
    for j in range(width):
        total = total + sq[:, j]
    return total, np.where(held, vals, -np.inf).max(axis=1, initial=-np.inf), counts
