"""trim_heap (controller/heap.py) gives freed C-heap pages back to the system where glibc can."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from gantry_sim.controller.heap import trim_heap


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim, /proc")
def test_freed_small_arrays_go_back_to_the_system():
    if not trim_heap():
        pytest.skip("this C library has no malloc_trim")
    keep = []
    junk = [np.ones(8000) for _ in range(12000)]  # 64 KB each: from the heap, not mmap
    keep.append(np.ones(10))  # allocated last: the heap's top stays in use
    del junk
    before = _rss_bytes()  # glibc gave back what lay at the heap's top, not the rest
    assert before > 250e6 and trim_heap()
    assert _rss_bytes() < before / 2  # the freed pages inside the heap come back too
    assert keep[0].sum() == 10
