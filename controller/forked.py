"""Work split over forked child processes, with the parent's own sequential run as fallback.

:func:`fork_map` computes ``fn(part)`` for each part: the first here, the others each in a child
forked from this process (Linux only), which inherits everything ``fn`` reads without copying
or pickling it and sends back only its result (pickled through a pipe, read as it streams).
:func:`fork_runs` computes ``fn(run)`` for many runs, each taken by whichever process is free
next (this one too, after a job of its own), so no process waits while another still has a
queue of work. A child that fails in any way (an exception, a signal, a result that does not
arrive) is not trusted with an error of its own: its part (its runs) is computed again here,
so the caller sees exactly what a sequential run gives, the same exception with its message
and line included.

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
import select
import signal
import struct
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, Generic, TypeVar

__all__ = [
    "MAX_PROCESSES",
    "MAX_RUNS",
    "Background",
    "RunsAhead",
    "fork_map",
    "fork_runs",
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
#: Cores held by this process' :class:`RunsAhead` children still running.
_held = 0


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
    :func:`one_process` and where fork is not available (not Linux); less one for each
    :class:`RunsAhead` child still running (at least 1)."""
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
            _end(pid, fd)
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
            _end(*child)


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
#: Runs :func:`fork_runs` takes at once (their indices fill the claim pipe's 64 KiB buffer).
MAX_RUNS = 16_384
_INDEX = struct.Struct("<I")


def fork_runs(
    fn: Callable[[T], R],
    runs: Sequence[T],
    processes: int,
    before: Callable[[], object] | None = None,
) -> list[R]:
    """``[fn(r) for r in runs]``, each run computed by whichever of this process and
    ``processes - 1`` forked children is free next: the runs' indices wait in a pipe, and each
    process takes the next one (a read of 4 bytes, which a pipe gives whole to one reader)
    until none is left. This process first calls ``before()`` (a job of its own, whose result
    is dropped), then takes runs like the children. A child sends each run's result as soon as
    it is done, as far as its pipe takes it (it keeps the rest and goes on: it never waits for
    this process, busy with its own job, to read), and this process reads what has arrived
    between its own runs (reading is work too: shared this way, it is balanced like the
    runs). The runs of a child that failed are
    computed here. ``fn`` must not depend on side effects of other runs; at most
    :data:`MAX_RUNS` runs."""
    ahead = RunsAhead(fn, runs, processes, hold=False)
    try:
        if before is not None:
            before()
        return ahead.finish()
    finally:
        ahead.close()


#: A :class:`RunsAhead` child's frame index for what its ``then`` sends (not a run's result).
_EXTRA = -1


class RunsAhead(Generic[R]):
    """:func:`fork_runs` started now and finished later: the children take runs from the
    moment it is made, while this process goes on with other work, and :meth:`finish` has
    this process take the runs still left, then gives every result (the runs of a child that
    failed computed here). Meanwhile (``hold``) its children hold their cores:
    :func:`process_count` counts them out. :meth:`close` stops children whose results are no
    longer wanted. With ``processes`` 1 (or no run), nothing is forked and :meth:`finish`
    computes every run.

    ``then``: work a child goes on with once no run is left, for as long as this process does
    not need it back: called as ``then(mine, send)`` with the results of the runs that child
    computed (by index) and a function sending one object (pickled) to :attr:`extras`. When
    :meth:`finish` has taken the runs left, it stops the children (``SIGUSR1``: a child in
    ``then`` leaves it at once, between two sends, and one still on a run skips ``then``),
    and :attr:`extras` gets what they sent, in order. Extras are optional results: a child
    that failed gives none, and an error in ``then`` only ends it."""

    def __init__(
        self,
        fn: Callable[[T], R],
        runs: Sequence[T],
        processes: int,
        *,
        hold: bool = True,
        then: Callable[[dict[int, R], Callable[[object], None]], object] | None = None,
    ) -> None:
        global _held
        if len(runs) > MAX_RUNS:
            raise ValueError(f"at most {MAX_RUNS} runs, got {len(runs)}")
        self._fn: Callable[[Any], R] = fn
        self._runs: Sequence[Any] = runs
        self._streams: list[_Results] = []
        self._read: int | None = None
        self._held = 0
        #: what the children's ``then`` sent (after :meth:`finish`)
        self.extras: list[object] = []
        self._stoppable = then is not None
        children = min(processes, len(runs) + 1) - 1  # no child without a run to take
        if children <= 0:
            return
        read, write = os.pipe()
        self._read = read
        try:
            os.write(write, b"".join(_INDEX.pack(i) for i in range(len(runs))))
        finally:
            os.close(write)  # the queue is all there: an empty pipe reads as its end

        def serve(out: int) -> None:  # in a child: each run's result as soon as it is done
            stop = _StopSignal.install() if then is not None else None
            sender = _Sender(out)  # a child never waits on the pipe before it is done
            mine: dict[int, R] = {}
            for i in self._claims():
                result = fn(runs[i])
                if stop is not None:
                    mine[i] = result
                sender.send((i, result))
            if stop is not None and then is not None:
                stop.run(lambda: then(mine, lambda extra: stop.sending(sender, (_EXTRA, extra))))
            sender.flush()

        if hold:  # before the forks: the children count themselves out too
            self._held = children
            _held += children
        try:
            with _blocked(signal.SIGUSR1) if self._stoppable else contextlib.nullcontext():
                for _ in range(children):
                    self._streams.append(_Results(*_fork(serve)))
        except BaseException:
            self.close()
            raise

    def _claims(self) -> Iterator[int]:
        read = self._read
        while read is not None and (claim := os.read(read, _INDEX.size)):
            yield _INDEX.unpack(claim)[0]

    def finish(self) -> list[R]:
        """Every run's result, in order: this process takes the runs left, then waits for the
        children's."""
        fn, runs = self._fn, self._runs
        results: dict[int, R] = {}
        try:
            for i in self._claims():
                results[i] = fn(runs[i])
                for stream in self._streams:
                    stream.poll()
            self._release()
            if self._stoppable:  # every run is taken: the children's ``then`` ends here
                for stream in self._streams:
                    stream.stop()
            for stream in self._streams:
                results.update(stream.finish())
                self.extras.extend(stream.extras)
        finally:
            self.close()
        return [results[i] if i in results else fn(r) for i, r in enumerate(runs)]

    def close(self) -> None:
        """Close the queue, and stop and reap the children still there."""
        self._release()
        if self._read is not None:
            os.close(self._read)
            self._read = None
        streams, self._streams = self._streams, []
        for stream in streams:
            stream.end()

    def _release(self) -> None:
        global _held
        _held -= self._held
        self._held = 0


_FRAME = struct.Struct("<Q")


class _Sender:
    """A child's frames (pickled, behind their length) to its result pipe: as far as the pipe
    takes them at each send, the rest kept and sent with the next, all of it by :meth:`flush`
    (which waits for the pipe)."""

    def __init__(self, out: int) -> None:
        self.out = out
        self.unsent = bytearray()
        os.set_blocking(out, False)

    def send(self, obj: object) -> None:
        data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
        self.unsent += _FRAME.pack(len(data))
        self.unsent += data
        with contextlib.suppress(BlockingIOError):
            while self.unsent:
                del self.unsent[: os.write(self.out, self.unsent)]

    def flush(self) -> None:
        os.set_blocking(self.out, True)
        while self.unsent:
            del self.unsent[: os.write(self.out, self.unsent)]


class _Stopped(BaseException):
    """Raised in a :class:`RunsAhead` child's ``then`` by the parent's stop (a BaseException:
    no ``except Exception`` of the work it interrupts takes it)."""


class _StopSignal:
    """A child's stop (``SIGUSR1``, blocked in the parent around the fork so that it waits
    for this handler): noted while the child computes its runs, raised as :class:`_Stopped`
    inside :meth:`run`, except in the middle of a send (raised right after it)."""

    def __init__(self) -> None:
        self.stopped = False
        self._raise = False
        # raised where Python cannot pass it on (a __del__), the stop would be printed: the
        # child writes nothing to stderr, and stops at its next send instead
        sys.unraisablehook = lambda unraisable: None
        signal.signal(signal.SIGUSR1, self._on_signal)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGUSR1})

    @classmethod
    def install(cls) -> _StopSignal | None:
        """The handler, or None where it cannot be had (the signal then stays blocked, and
        the child skips ``then``)."""
        try:
            return cls()
        except (ValueError, OSError):  # e.g. not the main thread
            return None

    def _on_signal(self, signum: int, frame: object) -> None:
        self.stopped = True
        if self._raise:
            self._raise = False
            raise _Stopped

    def run(self, work: Callable[[], object]) -> None:
        """``work()`` until it returns, fails or the stop comes (none of which is raised)."""
        if self.stopped:
            return
        self._raise = True
        try:
            if self.stopped:  # (came between the check and the flag)
                raise _Stopped
            work()
        except (_Stopped, Exception):
            pass
        finally:
            self._raise = False

    def sending(self, sender: _Sender, obj: object) -> None:
        """``sender.send(obj)`` whole, the stop held back meanwhile."""
        self._raise = False
        try:
            sender.send(obj)
        finally:
            self._raise = True
        if self.stopped:
            raise _Stopped


@contextmanager
def _blocked(signum: int) -> Iterator[None]:
    """``signum`` blocked in this thread inside (a child forked meanwhile starts with it
    blocked: it unblocks it once it has its handler)."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signum})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class _Results:
    """The results a :func:`fork_runs` child sends: frames of (run index, result), each
    pickled behind its length."""

    def __init__(self, pid: int, fd: int) -> None:
        self.pid, self.fd = pid, fd
        self.buffer = bytearray()
        self.got: dict[int, object] = {}
        self.extras: list[object] = []
        self.open, self.broken, self.reaped = True, False, False

    def stop(self) -> None:
        """Ask the child to stop (:class:`RunsAhead`'s ``then``) and send what it has."""
        if not self.reaped:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGUSR1)

    def poll(self) -> None:
        """Take in what has arrived, without waiting."""
        while self.open and select.select([self.fd], [], [], 0.0)[0]:
            self._read()

    def finish(self) -> dict[int, Any]:
        """Everything the child sent, once it has ended ({} when it failed in any way)."""
        while self.open:
            self._read()
        os.close(self.fd)
        _, status = os.waitpid(self.pid, 0)
        self.reaped = True
        if self.broken or self.buffer or os.waitstatus_to_exitcode(status) != 0:
            self.extras = []
            return {}
        return self.got

    def end(self) -> None:
        """Kill and reap the child if :meth:`finish` did not."""
        if not self.reaped:
            self.reaped = True
            _end(self.pid, self.fd)

    def _read(self) -> None:
        chunk = os.read(self.fd, 1 << 20)
        if not chunk:
            self.open = False
            return
        buf = self.buffer
        buf += chunk
        while len(buf) >= _FRAME.size:
            (size,) = _FRAME.unpack_from(buf)
            if len(buf) < _FRAME.size + size:
                break
            try:
                i, result = pickle.loads(bytes(buf[_FRAME.size : _FRAME.size + size]))
                if i == _EXTRA:
                    self.extras.append(result)
                else:
                    self.got[i] = result
            except Exception:  # a broken result: its runs are computed again by the parent
                self.open, self.broken = False, True
                return
            del buf[: _FRAME.size + size]


def _start(fn: Callable[[T], R], part: T) -> tuple[int, int]:
    """A child computing ``fn(part)``; returns its pid and the read end of its result pipe."""

    def body(fd: int) -> None:
        with os.fdopen(fd, "wb", closefd=False) as out:
            pickle.dump(fn(part), out, protocol=pickle.HIGHEST_PROTOCOL)

    return _fork(body)


def _fork(body: Callable[[int], object]) -> tuple[int, int]:
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


def _end(pid: int, fd: int) -> None:
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
