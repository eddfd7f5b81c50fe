"""What the tests of forked processes share: which children this process has, a fixture that
fails a test leaving one behind, and small functions to run in them."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork: Linux only")


def children() -> set[str]:
    """This process' children, zombies included (Linux)."""
    return {
        pid for f in Path("/proc/self/task").glob("*/children") for pid in f.read_text().split()
    }


@pytest.fixture(autouse=True)
def no_child_left_behind() -> object:
    """Autouse where imported: the test leaves no child of this process behind."""
    before = children() if sys.platform.startswith("linux") else set()
    yield
    if sys.platform.startswith("linux"):
        assert children() <= before


def square_and_pid(x: int) -> tuple[int, int]:
    return x * x, os.getpid()


def slow_square_and_pid(x: int) -> tuple[int, int]:
    time.sleep(0.01)  # long enough that every process gets runs
    return x * x, os.getpid()
