"""The memory a benchmarked process and its children hold, polled from /proc by a thread.

A run has two kinds of children: the analysis worker (a fresh interpreter, sim.analysis_worker)
and, while planning, forked copies of the planner (controller/forked.py). A forked child's
resident set counts every page it shares with its parent, so its VmHWM says nothing about what
it adds; what it adds is its private memory (Private_Clean + Private_Dirty of
/proc/PID/smaps_rollup: the pages it wrote, copied on write, and its own allocations). So:

* ``children``: the largest sum, over one poll, of the children's private memory [bytes];
* ``total``: the largest, over one poll, of this process' resident set plus that sum [bytes]:
  what the process tree held at once (a lower bound of its true peak between polls; compare
  it with getrusage's ru_maxrss of this process alone).

Linux only (0 elsewhere). Poll interval :data:`POLL_S`.
"""

from __future__ import annotations

import threading
from pathlib import Path

__all__ = ["POLL_S", "TreeMemory"]

POLL_S = 0.1


def _kb_fields(path: Path, names: tuple[str, ...]) -> int:
    """The sum of ``names`` (lines "Name:  N kB") in a /proc file [bytes]; 0 if unreadable."""
    try:
        text = path.read_text()
    except OSError:
        return 0
    total = 0
    for row in text.splitlines():
        name, _, rest = row.partition(":")
        if name in names:
            total += int(rest.split()[0]) * 1024
    return total


def _children() -> list[str]:
    """This process' children's pids (every thread's)."""
    pids: list[str] = []
    for f in Path("/proc/self/task").glob("*/children"):
        try:
            pids += f.read_text().split()
        except OSError:
            continue
    return pids


class TreeMemory:
    """Polls this process' tree every :data:`POLL_S` until :meth:`stop` (see the module
    docstring)."""

    def __init__(self) -> None:
        self.children = 0
        self.total = 0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()

    def _poll(self) -> None:
        while not self._done.wait(POLL_S):
            own = _kb_fields(Path("/proc/self/status"), ("VmRSS",))
            private = sum(
                _kb_fields(Path(f"/proc/{pid}/smaps_rollup"), ("Private_Clean", "Private_Dirty"))
                for pid in _children()
            )
            self.children = max(self.children, private)
            self.total = max(self.total, own + private)

    def stop(self) -> tuple[int, int]:
        """Stop polling; (children, total) [bytes]."""
        self._done.set()
        self._thread.join()
        return self.children, self.total
