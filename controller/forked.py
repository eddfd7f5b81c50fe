"""Work split over forked child processes, with the parent's own sequential run as fallback.

:func:`fork_map` computes ``fn(part)`` for each part: the first here, the others each in a child
forked from this process (Linux only), which inherits everything ``fn`` reads without copying
or pickling it and sends back only its result (pickled through a pipe, read as it streams).
:class:`Background` computes one result in a child while this process goes on. Many runs taken
by whichever process is free next: :mod:`~gantry_sim.controller.forked_runs`. A child that
fails in any way (an exception, a signal, a result that does not arrive) is not trusted with an
error of its own: its part (its runs) is computed again here, so the caller sees exactly what a
sequential run gives, the same exception with its message and line included.

A child dies with this process (Linux ``PR_SET_PDEATHSIG``): a run killed with ``kill -9``
leaves no child computing its part for nobody.

The children write nothing to stdout or stderr (another thread of the parent may have held
their locks when it forked) and leave with ``os._exit``: no ``atexit`` handlers, no flushing
of buffers inherited from the parent.

How many processes: :func:`process_count`; ``GANTRY_PLAN_WORKERS=1`` (or 0) or
:func:`one_process` keep everything in this process (the sweep's workers, already one per
core, do).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import gc
import os
import pickle
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Generic, TypeVar

__all__ = [
    "MAX_PROCESSES",
    "Background",
    "end_child",
    "fork_child",
    "fork_map",
    "give_back_cores",
    "hold_cores",
    "in_one_process",
    "lower_priority",
    "one_process",
    "process_count",
]

T = TypeVar("T")
R = TypeVar("R")

#: Processes at most (this one included): each child holds its share of the work's arrays.
MAX_PROCESSES = 4

_ONE: ContextVar[bool] = ContextVar("gantry_one_process", default=False)
#: Cores held by this process' children still running
#: (:class:`~gantry_sim.controller.forked_runs.RunsAhead`).
_held = 0


def hold_cores(n: int) -> None:
    """Count ``n`` more cores as held by children still running (:func:`process_count` counts
    them out; call it before forking them, so that they count themselves out too)."""
    global _held
    _held += n


def give_back_cores(n: int) -> None:
    """The ``n`` cores of :func:`hold_cores` given back."""
    global _held
    _held -= n


@contextmanager
def one_process() -> Iterator[None]:
    """Inside, :func:`process_count` is 1 (for callers already running one process per core)."""
    token = _ONE.set(True)
    try:
        yield
    finally:
        _ONE.reset(token)


def in_one_process() -> bool:
    """Inside :func:`one_process`: the caller runs one process per core already."""
    return _ONE.get()


def process_count() -> int:
    """Processes :func:`fork_map` may use: the cores this process may run on (at most
    :data:`MAX_PROCESSES`), or ``GANTRY_PLAN_WORKERS`` when set to a whole number; 1 inside
    :func:`one_process` and where fork is not available (not Linux); less the cores held by
    children still running (:func:`hold_cores`; at least 1)."""
    if in_one_process() or not sys.platform.startswith("linux"):
        return 1
    env = os.environ.get("GANTRY_PLAN_WORKERS", "").strip()
    if env.isdigit():
        return max(1, int(env) - _held)
    return max(1, min(MAX_PROCESSES, len(os.sched_getaffinity(0))) - _held)


def fork_map(fn: Callable[[T], R], parts: Sequence[T]) -> list[R]:
    """``[fn(p) for p in parts]``, ``parts[1:]`` each computed in a forked child while this
    process computes ``parts[0]`` (see the module docstring). ``fn`` must not depend on side
    effects of the other parts, and its own side effects in a child are lost."""
    if len(parts) <= 1:
        return [fn(p) for p in parts]
    pending: list[tuple[int, int]] = []  # (pid, read end) of the children not collected yet
    try:
        for part in parts[1:]:
            pending.append(_start(fn, part))
        out = [fn(parts[0])]
        for part in parts[1:]:
            out.append(_collect(fn, part, pending.pop(0)))
    finally:
        for pid, fd in pending:  # the parent failed: stop and reap the children still there
            end_child(pid, fd)
    return out


#: The nice value :func:`lower_priority` gives: work off the run's critical path yields the
#: core to the servo loop (on 2 cores, the trace's deflating thread at nice 10 cut a 10,000-arc
#: run's simulation from 10.6 to 9.8 s).
BACKGROUND_NICE = 10


def lower_priority() -> None:
    """Give the calling thread (Linux: each thread has its own nice value) the priority of
    background work, :data:`BACKGROUND_NICE`, unless it runs at a lower one already (a run
    under ``nice -n 19`` keeps 19); elsewhere, or where it is refused, nothing."""
    if sys.platform.startswith("linux"):
        tid = threading.get_native_id()
        with contextlib.suppress(OSError):
            nice = max(os.getpriority(os.PRIO_PROCESS, tid), BACKGROUND_NICE)
            os.setpriority(os.PRIO_PROCESS, tid, nice)


class Background(Generic[R]):
    """``fn()`` computed in a forked child while this process goes on (see the module
    docstring); :meth:`result` waits for it, or computes it here when the child failed, or
    when :func:`process_count` is 1 (then nothing is forked: it is computed when asked for).
    :meth:`close` stops a child whose result is no longer wanted."""

    def __init__(self, fn: Callable[[], R]) -> None:
        self._fn = fn
        self._child = _start(_call_in_background, fn) if process_count() > 1 else None
        self._result: tuple[R] | None = None

    def result(self) -> R:
        """The result (waiting for the child)."""
        if self._result is None:
            child, self._child = self._child, None
            self._result = (self._fn() if child is None else _collect(_call, self._fn, child),)
        return self._result[0]

    def close(self) -> None:
        """Stop and reap the child if its result was not taken."""
        if self._child is not None:
            child, self._child = self._child, None
            end_child(*child)


def _call(fn: Callable[[], R]) -> R:
    return fn()


def _call_in_background(fn: Callable[[], R]) -> R:
    lower_priority()  # in the child, off the critical path (not in the parent redoing it)
    # no collection in the child: a full one writes to every tracked object of the parent's
    # heap, copying its pages (the chords' child: 125 -> 111 MB private at 30,000 arcs)
    gc.disable()
    return fn()


#: Bytes a child's result pipe holds, where the system allows (Linux: fs.pipe-max-size, 1 MiB
#: by default; else 64 KiB): a run's result of 32 chains of arcs pickles to 0.2-0.3 MB.
PIPE_BYTES = 1 << 20


def _start(fn: Callable[[T], R], part: T) -> tuple[int, int]:
    """A child computing ``fn(part)``; returns its pid and the read end of its result pipe."""

    def body(fd: int) -> None:
        with os.fdopen(fd, "wb", closefd=False) as out:
            pickle.dump(fn(part), out, protocol=pickle.HIGHEST_PROTOCOL)

    return fork_child(body)


def fork_child(body: Callable[[int], object]) -> tuple[int, int]:
    """A child calling ``body`` with the write end of a pipe, then leaving (see the module
    docstring); returns its pid and the read end. The pipe holds :data:`PIPE_BYTES` where the
    system allows (fewer system calls for a child sending results as they come)."""
    import fcntl  # here: the module is imported where there is no fcntl (fork is Linux only)

    read, write = os.pipe()
    with contextlib.suppress(OSError, AttributeError):
        fcntl.fcntl(write, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    parent = os.getpid()
    prctl = _prctl()  # looked up here: the child only calls it
    pid = os.fork()
    if pid == 0:  # the child
        status = 1
        try:
            if prctl is not None:
                prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL))
            if os.getppid() != parent:  # the parent died before that
                raise SystemExit
            os.close(read)
            warnings.simplefilter("ignore")  # nothing on stderr (see the module docstring)
            body(write)
            os.close(write)
            status = 0
        except BaseException:  # reported by the exit status: the parent redoes it
            pass
        finally:
            os._exit(status)
    os.close(write)
    return pid, read


#: prctl option: the signal this process gets when its parent dies
_PR_SET_PDEATHSIG = 1


@functools.cache
def _prctl() -> Callable[[int, int], int] | None:
    """libc's ``prctl`` (None where it cannot be found)."""
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _collect(fn: Callable[[T], R], part: T, child: tuple[int, int]) -> R:
    """The child's result, or ``fn(part)`` computed here when the child failed."""
    pid, fd = child
    result: R | None = None
    ok = False
    try:
        with os.fdopen(fd, "rb") as inp:
            result = pickle.load(inp)
            ok = True
    except Exception:  # a broken or short result: computed again below
        pass
    finally:
        _, status = os.waitpid(pid, 0)
    if ok and os.waitstatus_to_exitcode(status) == 0:
        return result  # type: ignore[return-value]
    return fn(part)


def end_child(pid: int, fd: int) -> None:
    """Kill and reap a child, closing its pipe."""
    try:
        os.kill(pid, 9)
    except ProcessLookupError:
        pass
    try:
        os.close(fd)
    except OSError:
        pass
    os.waitpid(pid, 0)
