"""``gantry plan --out``: the reference sampled every servo period, written range by range.

The samples of a long program did not fit in memory well: 7,000 s of one slow move held
1.1 GB of arrays (96 bytes a sample) before the file was written. They are now taken
:data:`RANGE_SAMPLES` at a time (``Plan.sample_range``: the same numbers as ``Plan.sample``,
bit for bit), each array's bytes spooled to an anonymous temporary file, and the .npz written
from the spools at the end, as ``numpy.savez`` writes one: one stored (uncompressed) ``.npy``
member per array, in the same order, so ``numpy.load`` gives the same arrays
(tests/test_plan_cli.py). Memory is one range; the disk holds the spools and the file while it
is written (a temporary folder that is full or unwritable is an error naming it, exit 2).
"""

from __future__ import annotations

import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import IO, Any

import numpy as np

from gantry_sim.sim.outdir import atomic_file, os_error

#: samples taken and written at a time (about 25 MB of arrays)
RANGE_SAMPLES = 262_144


def write_samples_npz(path: Path, plan: Any, period_s: float) -> None:
    """Write ``plan``'s reference sampled every ``period_s`` [s] to ``path`` atomically
    (:func:`gantry_sim.sim.outdir.atomic_file`): the arrays t, pos, vel, acc, line and, where
    the samples have source moves, feed_mm_per_min (``Plan.feeds_mm_per_min``)."""
    n = plan.sample_count(period_s)
    spools: dict[str, tuple[IO[bytes], np.dtype, tuple[int, ...]]] = {}
    try:
        try:
            for k0 in range(0, n, RANGE_SAMPLES):
                tr = plan.sample_range(period_s, k0, k0 + RANGE_SAMPLES)
                arrays = tr.to_npz_dict()
                if tr.source is not None:
                    arrays["feed_mm_per_min"] = plan.feeds_mm_per_min(tr.source)
                for name, a in arrays.items():
                    if name not in spools:
                        spools[name] = (tempfile.TemporaryFile(), a.dtype, a.shape[1:])
                    spools[name][0].write(np.ascontiguousarray(a).tobytes())
        except OSError as exc:  # the temporary folder ($TMPDIR) full or unwritable
            raise os_error(exc, tempfile.gettempdir(), "cannot spool the samples") from None
        with (
            atomic_file(path, "wb") as fh,
            zipfile.ZipFile(fh, "w", zipfile.ZIP_STORED, allowZip64=True) as zf,
        ):
            for name, (spool, dtype, rest) in spools.items():
                header = {
                    "descr": np.lib.format.dtype_to_descr(dtype),
                    "fortran_order": False,
                    "shape": (n, *rest),
                }
                with zf.open(f"{name}.npy", "w", force_zip64=True) as member:
                    np.lib.format.write_array_header_1_0(member, header)
                    spool.seek(0)
                    shutil.copyfileobj(spool, member, 1 << 20)
    finally:
        for spool, _, _ in spools.values():
            spool.close()
