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
    if not trim_heap():  # also: the heap's holes left by earlier tests are not resident now
        pytest.skip("this C library has no malloc_trim")
    base = _rss_bytes()
    junk, pins = [], []
    for _ in range(4000):
        junk.append(np.ones(8000))  # 64 KB: from the heap (below the mmap threshold)
        pins.append(np.ones(2000))  # 16 KB after it: no freed 64 KB lies at the heap's top
    del junk
    held = _rss_bytes()
    assert held - base > 200e6  # freed, still resident: free() gives back only the heap's top
    assert trim_heap()
    assert held - _rss_bytes() > 200e6  # the freed pages inside the heap come back
    assert sum(p.sum() for p in pins) == 4000 * 2000
