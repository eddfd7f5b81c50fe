"""``gantry plan --out``: the reference sampled every servo period, written range by range.

The samples of a long program did not fit in memory well: 7,000 s of one slow move held
1.1 GB of arrays (96 bytes a sample) before the file was written. They are now taken
:data:`RANGE_SAMPLES` at a time (``Plan.sample_range``: the same numbers as ``Plan.sample``,
bit for bit), each array's bytes deflated as they come into its ``.npy`` member
(sim.deflate_zip: the members of a streamed run's trace.npz), and the .npz written around
them at the end, so ``numpy.load`` gives the arrays of ``numpy.savez``, in its order
(tests/test_plan_cli.py). Memory is one range; the disk holds the deflated members and the
file while it is written (a temporary folder that is full or unwritable is an error naming it,
exit 2).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from gantry_sim.sim.deflate_zip import DeflatedMember, npy_member, write_zip
from gantry_sim.sim.outdir import atomic_file, os_error

#: samples taken and written at a time (about 25 MB of arrays)
RANGE_SAMPLES = 262_144


def write_samples_npz(path: Path, plan: Any, period_s: float) -> None:
    """Write ``plan``'s reference sampled every ``period_s`` [s] to ``path`` atomically
    (:func:`gantry_sim.sim.outdir.atomic_file`): the arrays t, pos, vel, acc, line and
    feed_mm_per_min (``Plan.feeds_mm_per_min``; NaN where no feed bounds a sample, such as a
    program without moves)."""
    n = plan.sample_count(period_s)
    members: dict[str, DeflatedMember] = {}
    try:
        try:
            for k0 in range(0, n, RANGE_SAMPLES):
                tr = plan.sample_range(period_s, k0, k0 + RANGE_SAMPLES)
                arrays = tr.to_npz_dict()
                arrays["feed_mm_per_min"] = (
                    np.full(len(arrays["t"]), np.nan)  # no move: no feed bounds the samples
                    if tr.source is None
                    else plan.feeds_mm_per_min(tr.source)
                )
                for name, a in arrays.items():
                    if name not in members:
                        members[name] = npy_member(name, (n, *a.shape[1:]), a.dtype)
                    members[name].add(np.ascontiguousarray(a).data.cast("B"))
            for member in members.values():
                member.finish()  # its last deflated bytes spooled too
        except OSError as exc:  # the temporary folder ($TMPDIR) full or unwritable
            raise os_error(exc, tempfile.gettempdir(), "cannot spool the samples") from None
        with atomic_file(path, "wb") as fh:
            write_zip(list(members.values()), fh)
    finally:
        for member in members.values():
            member.release()
