"""Chains sent between processes as a few arrays.

A forked child plans a run of chains and sends them to the planning process pickled
(:mod:`~gantry_sim.controller.forked_runs`). Pickled one by one, a chain of a polyline (a
line or a blend arc: a segment or two, its start times and its speeds inside) took about 1 kB
and 20 us to pickle and as long again to unpickle, an array at a time: about a tenth of
planning it. :class:`ChainBatch` is the dict of chains a run gives, and pickles as one flat
array of all their segments' numbers and one array for each of their other numbers;
unpickled, it is the same chains, bit for bit, each segment a view of that array. Kept in the
process that planned them, it is a plain dict: nothing is packed. It sorts segments as
:class:`~gantry_sim.controller.planner.packed_block.PackedBlock` does
(:func:`~gantry_sim.controller.planner.cubic.segment_kind`) but does not pack them with it:
that gives each segment back as a fresh array, and a pickled round trip of 3,000 polyline chains
took 24.7 us a chain with it against 11.0 us here.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Generic, TypeVar

import numpy as np

from gantry_sim.controller.planner.chains import Chain
from gantry_sim.controller.planner.cubic import (
    SEGMENT_PER_AXIS,
    SEGMENT_RUN,
    Jerk3Run,
    Segment,
    segment_kind,
)

__all__ = ["ChainBatch"]

K = TypeVar("K", bound=Hashable)


class ChainBatch(dict[K, Chain], Generic[K]):
    """Chains by key (a dict), pickled packed (see the module docstring)."""

    def __reduce__(self) -> tuple[object, tuple[object, ...]]:
        return (_unpack, (*_pack(list(self.values())), list(self.keys())))


def _pack(chains: list[Chain]) -> tuple[object, ...]:
    """The chains' numbers: every closed-form run's rows and every (3, 5, n) segment's phases
    one after another in one flat array (per segment its kind and size), the rare per-axis
    segments as they are, and per chain its segments, duration [s], Ruckig pieces, move
    starts [s], speeds inside [mm/s] and bad junctions."""
    segments = [seg for c in chains for seg in c.chunk]
    kinds = np.array([segment_kind(seg) for seg in segments], dtype=np.int8)
    flat = [
        seg.rows.ravel() if isinstance(seg, Jerk3Run) else seg.ravel()
        for seg in segments
        if not isinstance(seg, tuple)
    ]
    sizes = np.array([x.size for x in flat], dtype=np.int64)
    values = np.concatenate(flat) if flat else np.empty(0)
    per_axis = [seg for seg in segments if isinstance(seg, tuple)]
    starts = [c.starts_s for c in chains]
    inner = [np.asarray(c.inner_speeds, dtype=float) for c in chains]
    return (
        kinds,
        sizes,
        values,
        per_axis,
        np.array([len(c.chunk) for c in chains], dtype=np.int64),
        np.array([c.duration_s for c in chains], dtype=float),
        np.array([c.ruckig_pieces for c in chains], dtype=np.int64),
        np.array([len(s) for s in starts], dtype=np.int64),
        np.array([t for s in starts for t in s], dtype=float),
        np.array([x.size for x in inner], dtype=np.int64),
        np.concatenate(inner) if inner else np.empty(0),
        {i: tuple(sorted(c.bad)) for i, c in enumerate(chains) if c.bad},
    )


def _unpack(
    kinds: np.ndarray,
    sizes: np.ndarray,
    values: np.ndarray,
    per_axis: list[Segment],
    counts: np.ndarray,
    durations: np.ndarray,
    ruckig: np.ndarray,
    starts_at: np.ndarray,
    starts_s: np.ndarray,
    inner_at: np.ndarray,
    inner_mm_per_s: np.ndarray,
    bad: dict[int, tuple[int, ...]],
    keys: list,
) -> ChainBatch:
    """The chains :func:`_pack` packed, by ``keys``: each segment a view of ``values`` (in
    the same shape, C-contiguous: the same numbers)."""
    segments: list[Segment] = []
    ends = np.cumsum(sizes).tolist()
    axis_segments = iter(per_axis)
    at = k = 0
    for kind in kinds.tolist():
        if kind == SEGMENT_PER_AXIS:
            segments.append(next(axis_segments))
            continue
        end = ends[k]
        part = values[at:end]
        if kind == SEGMENT_RUN:
            run = Jerk3Run.__new__(Jerk3Run)
            run.rows = part.reshape(-1, 19)
            segments.append(run)
        else:
            segments.append(part.reshape(3, 5, -1))
        at, k = end, k + 1
    out: ChainBatch = ChainBatch()
    seg_end = np.cumsum(counts).tolist()
    start_end = np.cumsum(starts_at).tolist()
    inner_end = np.cumsum(inner_at).tolist()
    times = starts_s.tolist()
    empty: frozenset[int] = frozenset()
    s0 = t0 = i0 = 0
    for n, (key, s1, t1, i1, dur, rk) in enumerate(
        zip(keys, seg_end, start_end, inner_end, durations.tolist(), ruckig.tolist(), strict=True)
    ):
        out[key] = Chain(
            tuple(segments[s0:s1]),
            dur,
            tuple(times[t0:t1]),
            frozenset(bad[n]) if n in bad else empty,
            rk,
            inner_mm_per_s[i0:i1],
        )
        s0, t0, i0 = s1, t1, i1
    return out
