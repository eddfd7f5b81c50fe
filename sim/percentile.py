"""The exact percentile of a large set of non-negative values, in memory or spilled to disk.

:func:`percentile_linear` is numpy's default (``method="linear"``) percentile computed from the
two order statistics it interpolates between, by the same float operations
(tests/test_percentile.py compares with ``np.percentile`` bit for bit). The order statistics
come from a :class:`ValueSpill`: the values kept in memory, or appended to an anonymous
temporary file (deleted by the system when closed, even after a crash) and selected in passes
over it with bounded memory: a radix select on the values' bit patterns (for floats >= 0 the
order of the bit patterns read as unsigned integers is the order of the values), 16 bits a pass,
until the candidates fit in memory.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterator

import numpy as np

#: values read from the spill file at a time (8 MB; a pass holds about twice that)
READ_VALUES = 1 << 20
#: candidates gathered into memory for the final selection at most
GATHER_VALUES = 1 << 21


def percentile_linear(select, n: int, q_pct: float) -> float:
    """The ``q_pct`` percentile of n values by linear interpolation between order statistics,
    numpy's default method; ``select(k)`` gives the k-th smallest value (k from 0)."""
    if n == 0:
        raise ValueError("percentile of no values")
    q = q_pct / 100
    virtual = (n - 1) * q
    below = min(max(math.floor(virtual), 0), n - 1)
    above = min(below + 1, n - 1)
    gamma = virtual - below
    a, b = select(below), select(above) if above != below else None
    if b is None:
        return float(a)
    # numpy's _lerp: a + (b - a) t, or b - (b - a)(1 - t) from t = 0.5 on
    diff = b - a
    return float(b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma)


class ValueSpill:
    """Non-negative float64 values added in chunks, for exact order statistics at the end.

    ``on_disk``: append them to a temporary file (8 bytes a value on disk, bounded memory);
    otherwise keep them in memory. Close it (or use it as a context manager) when done."""

    def __init__(self, on_disk: bool) -> None:
        self.count = 0
        self._file = tempfile.TemporaryFile(prefix="gantry-values-") if on_disk else None
        self._chunks: list[np.ndarray] = []
        self._joined: np.ndarray | None = None

    def add(self, values: np.ndarray) -> None:
        values = np.ascontiguousarray(values, dtype=np.float64)
        if values.size and not values.min() >= 0:
            raise ValueError("ValueSpill holds values >= 0 only")
        self.count += values.size
        if self._file is not None:
            self._file.write(values.tobytes())
        else:
            self._chunks.append(values.copy())
            self._joined = None

    def kth(self, k: int) -> float:
        """The k-th smallest value (k from 0)."""
        if not 0 <= k < self.count:
            raise IndexError(f"order statistic {k} of {self.count} values")
        if self._file is None:
            if self._joined is None:
                self._joined = np.concatenate(self._chunks)
                self._chunks = [self._joined]
            return float(np.partition(self._joined, k)[k])
        return self._kth_on_disk(k)

    def _kth_on_disk(self, k: int) -> float:
        # candidates: the bit patterns whose bits above ``shift`` are ``prefix``; ``rank``: k's
        # rank among them
        prefix, shift, rank, matching = 0, 64, k, self.count
        while matching > GATHER_VALUES and shift > 0:
            counts = np.zeros(1 << 16, dtype=np.int64)
            for bits in self._matching_bits(prefix, shift):
                digits = bits >> np.uint64(shift - 16)  # one array a chunk, then in place
                digits &= np.uint64(0xFFFF)
                counts += np.bincount(digits.view(np.int64), minlength=1 << 16)
                del bits, digits  # before the next chunk is read
            cum = np.cumsum(counts)
            digit = int(np.searchsorted(cum, rank, side="right"))
            rank -= int(cum[digit - 1]) if digit else 0
            prefix, shift, matching = (prefix << 16) | digit, shift - 16, int(counts[digit])
        found = np.concatenate([b.view(np.float64) for b in self._matching_bits(prefix, shift)])
        return float(np.partition(found, rank)[rank])

    def _matching_bits(self, prefix: int, shift: int) -> Iterator[np.ndarray]:
        """The bit patterns (uint64) whose bits above ``shift`` equal ``prefix``, by chunk."""
        for chunk in self._read():
            bits = chunk.view(np.uint64)
            if shift < 64:
                bits = bits[(bits >> np.uint64(shift)) == np.uint64(prefix)]
            del chunk
            yield bits
            del bits  # before the next chunk is read

    def _read(self) -> Iterator[np.ndarray]:
        assert self._file is not None
        self._file.flush()
        self._file.seek(0)
        while True:
            chunk = np.fromfile(self._file, dtype=np.float64, count=READ_VALUES)
            if chunk.size == 0:
                return
            yield chunk
            del chunk  # before the next one is read

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
        self._chunks, self._joined = [], None

    def __enter__(self) -> ValueSpill:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
