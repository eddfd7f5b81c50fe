"""The streamed run's work around the servo loop, done by one helper thread while it steps.

Per range, besides simulating it, the run samples the plan over the range (Plan.sample_range)
and hands the simulated range to the analysis: the moves it reaches laid out as tables
(sim.range_rows), sent to the analysis worker (which first returns the previous range's
result), and the results taken into the running figures. At 30,000 short G1 moves that was
1.6 s of Python on the servo loop's thread, between its ranges. The compiled servo ticks run
with the GIL released (sim.pd_ticks), so a :class:`RangeHelper` thread does it meanwhile, in
submission order: while range k is simulated, it hands over range k-1 and samples range k+1.

The calls are the same and made in the same order as without the thread, so the figures are
the same bit for bit (tests/test_stream.py). With one core (no analysis worker), calls are made
at once on the caller's thread (:class:`InlineHelper`): a second thread would only take turns
with the loop.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Protocol, TypeVar

__all__ = ["Helper", "InlineHelper", "RangeHelper"]

R = TypeVar("R")


class Helper(Protocol):
    """Calls made in submission order, their results as futures."""

    def submit(self, fn: Callable[..., R], /, *args: object) -> Future[R]: ...

    def stop(self) -> None:
        """Drop the calls not started; wait for the one running."""


class RangeHelper:
    """One daemon thread making the submitted calls in order."""

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gantry-range")

    def submit(self, fn: Callable[..., R], /, *args: object) -> Future[R]:
        return self._pool.submit(fn, *args)

    def stop(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


class InlineHelper:
    """The calls made at once, on the caller's thread."""

    def submit(self, fn: Callable[..., R], /, *args: object) -> Future[R]:
        future: Future[R] = Future()
        try:
            future.set_result(fn(*args))
        except BaseException as exc:  # raised by future.result(), as from a thread
            future.set_exception(exc)
        return future

    def stop(self) -> None:
        pass
