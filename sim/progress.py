"""Progress of a run's stages on stderr: one tqdm bar per stage (parse, plan, simulate, analyse,
write), with the rate and the ETA where the stage knows its size.

Shown only when asked (``gantry run --progress``) or, by default, when stderr is a terminal;
never on stdout (the summary or the ``--json`` object stays clean), so tests and pipes are quiet
unless they ask. A bar appears only once its stage has run for PROGRESS_DELAY_S (short stages
and short runs print nothing) and is erased when the stage ends (the terminal keeps the summary).
Planning reports its progress in large steps (a long program's windows of 5,000 moves, a print's
batches of parts): its bar is redrawn every second between them, so its elapsed time moves.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

#: a stage's bar appears after it has run this long [s wall] (quick stages stay silent)
PROGRESS_DELAY_S = 0.5

#: the update of a stage's bar: ``advance(n)`` adds n units done
Advance = Callable[[int], object]


def wanted(progress: bool | None) -> bool:
    """Whether to draw bars: ``progress`` when given, else whether stderr is a terminal."""
    if progress is not None:
        return bool(progress)
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a replaced or closed stderr
        return False


def _nothing(n: int = 1) -> None:
    return None


@contextmanager
def stage(
    name: str,
    total: float | None,
    unit: str,
    enabled: bool,
    known_size: bool = True,
    ticking: bool = False,
) -> Iterator[Advance]:
    """A bar for stage ``name`` of ``total`` ``unit``s while the block runs; yields its
    ``advance``. ``known_size`` False: the stage cannot report its progress (only the elapsed
    time is shown, and the bar completes at the end). ``ticking``: the bar is redrawn every
    :attr:`_Ticker.TICK_S` even without updates (a stage whose updates come seconds apart)."""
    if not enabled:
        yield _nothing
        return
    from tqdm import tqdm

    fmt = None if known_size else "{desc}: {elapsed} elapsed{postfix}"
    bar = tqdm(
        total=total,
        desc=name,
        unit=unit,
        file=sys.stderr,
        delay=PROGRESS_DELAY_S,
        leave=False,  # a bar is erased when its stage ends: the terminal keeps the summary
        dynamic_ncols=True,
        bar_format=fmt,
        unit_scale=unit == "tick",
    )
    ticker = _Ticker(bar) if ticking or not known_size else None
    try:
        yield bar.update
        if not known_size:
            bar.update((total or 0) - bar.n)
    finally:
        if ticker is not None:
            ticker.stop()
        bar.close()


class _Ticker:
    """Redraws a bar that gets no updates (a stage that cannot report its progress) once it is
    PROGRESS_DELAY_S old and every TICK_S after, so its elapsed time shows."""

    TICK_S = 1.0

    def __init__(self, bar: Any) -> None:
        self.bar = bar
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, name="gantry-progress", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        wait = PROGRESS_DELAY_S
        while not self.done.wait(wait):
            self.bar.refresh()
            wait = self.TICK_S

    def stop(self) -> None:
        self.done.set()
        self.thread.join()
