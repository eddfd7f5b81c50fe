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


_ARENAS = """
import ctypes, sys, threading
from gantry_sim.controller.heap import one_arena

libc = ctypes.CDLL(None)
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
both = threading.Barrier(2)


def allocate():
    block = libc.malloc(1000)
    both.wait()  # both threads alive at once: neither can take the other's arena
    libc.free(block)


if sys.argv[1] == "bounded":
    print(one_arena())
threads = [threading.Thread(target=allocate) for _ in range(2)]
for t in threads:
    t.start()
for t in threads:
    t.join()
libc.malloc_stats()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt, malloc_stats")
@pytest.mark.parametrize(
    ("mode", "env_max", "bound", "arenas"),
    [("free", None, "", 3), ("bounded", None, "True", 1), ("bounded", "2", "False", 2)],
)
def test_threads_after_one_arena_use_the_main_heap(mode, env_max, bound, arenas):
    """glibc gives each thread that allocates an arena of its own (malloc_stats lists them);
    after one_arena they use the main one, unless MALLOC_ARENA_MAX chose otherwise."""
    import os
    import subprocess

    from gantry_sim.controller import heap

    if heap._libc_function("mallopt") is None:
        pytest.skip("this C library has no mallopt")
    env = {k: v for k, v in os.environ.items() if k != "MALLOC_ARENA_MAX"}
    if env_max is not None:
        env["MALLOC_ARENA_MAX"] = env_max
    done = subprocess.run(
        [sys.executable, "-c", _ARENAS, mode], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == bound
    assert done.stderr.count("Arena ") == arenas


def test_a_streamed_run_bounds_the_arenas_before_its_threads_start(monkeypatch):
    import threading

    from gantry_sim.controller import heap
    from gantry_sim.controller.config import load_machine_config
    from gantry_sim.models import DEFAULT_MACHINE
    from gantry_sim.sim import api

    threads_then = []
    monkeypatch.setattr(
        heap, "one_arena", lambda: threads_then.append(threading.active_count()) or True
    )
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    before = threading.active_count()
    result = api.run_program("G21 G1 X2 F600\nM2\n", machine=load_machine_config(DEFAULT_MACHINE))
    assert result.streamed and threads_then == [before]
