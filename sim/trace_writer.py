"""trace.npz written range by range: one ``.npy`` file per array, appended to, zipped at the end.

A streamed run (sim/stream.py) hands each range's full-rate arrays to :class:`TraceWriter`, which
appends them to ``.npy`` files in a staging folder (the header written first for the run's known
length; plain writes rather than memory maps, whose touched pages would count as the process'
resident memory), and
:meth:`TraceWriter.finish` zips them into a ``.npz`` that ``numpy.load`` reads like one written by
``numpy.savez_compressed`` (same names, dtypes and values; tests/test_stream.py compares).
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.contour import ChunkAnalysis

#: trace.npz's arrays: name -> (shape per tick, dtype)
FIELDS: dict[str, tuple[tuple[int, ...], Any]] = {
    "t": ((), np.float64),
    "ref": ((3,), np.float64),
    "pos": ((3,), np.float64),
    "line": ((), np.int64),
    "err_um": ((), np.float64),
    "force_N": ((3,), np.float64),
}


class TraceWriter:
    """The trace of ``ticks`` servo ticks, written range by range into ``folder``."""

    def __init__(self, folder: Path, ticks: int) -> None:
        from numpy.lib import format as npy

        self.folder = Path(folder)
        self.ticks = ticks
        self.written = 0
        self.files = {}
        for name, (shape, dtype) in FIELDS.items():
            f = open(self.folder / f"{name}.npy", "wb")  # closed in finish()
            header = {"descr": npy.dtype_to_descr(np.dtype(dtype)), "fortran_order": False}
            npy.write_array_header_1_0(f, header | {"shape": (ticks, *shape)})
            self.files[name] = f

    def __call__(
        self, lo: int, piece: Trajectory, pos: np.ndarray, force: np.ndarray, part: ChunkAnalysis
    ) -> None:
        """Write ticks lo..lo+n-1 (the arguments of sim.stream's ``on_range``)."""
        if lo != self.written:
            raise ValueError(f"trace ranges out of order: got tick {lo}, expected {self.written}")
        rows = {"t": piece.t, "ref": piece.pos, "pos": pos, "line": piece.line}
        rows |= {"err_um": part.err_um, "force_N": force}
        for name, values in rows.items():
            dtype = FIELDS[name][1]
            self.files[name].write(np.ascontiguousarray(values, dtype=dtype).tobytes())
        self.written += pos.shape[0]

    def finish(self, npz: Path) -> Path:
        """Zip the arrays into ``npz`` (deflated, fast level) and remove the ``.npy`` files."""
        for f in self.files.values():
            f.close()
        self.files.clear()
        if self.written != self.ticks:
            raise ValueError(f"trace has {self.written} of {self.ticks} ticks")
        with zipfile.ZipFile(npz, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
            for name in FIELDS:
                path = self.folder / f"{name}.npy"
                z.write(path, arcname=f"{name}.npy")
                path.unlink()
        return npz
