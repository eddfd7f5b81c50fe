"""Many runs of work, each taken by whichever process is free next: this one or a forked child.

:func:`fork_runs` computes ``fn(run)`` for many runs: the runs' indices wait in a pipe, and each
process takes the next one until none is left, so no process waits while another still has a
queue of work. :class:`RunsAhead` starts the children now and lets this process finish later
(the next window's first round planned while this one settles); a child may go on with work
of its own once the queue is empty (``then``), until this process stops it. A child sends each
run's result as a frame (its length, then the pickle) as soon as it is done; one that fails in
any way has its runs computed again here (see :mod:`~gantry_sim.controller.forked`, whose
children these are: Linux only, dying with this process, silent).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import select
import signal
import struct
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Generic, TypeVar

from gantry_sim.controller.forked import end_child, fork_child, give_back_cores, hold_cores

__all__ = ["MAX_RUNS", "RunsAhead", "fork_runs"]

T = TypeVar("T")
R = TypeVar("R")

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
            hold_cores(children)
        try:
            with _blocked(signal.SIGUSR1) if self._stoppable else contextlib.nullcontext():
                for _ in range(children):
                    self._streams.append(_Results(*fork_child(serve)))
        except BaseException:
            self.close()
            raise

    def _claims(self) -> Iterator[int]:
        read = self._read
        while read is not None and (claim := os.read(read, _INDEX.size)):
            yield _INDEX.unpack(claim)[0]

    def finish(self, meanwhile: Callable[[], object] | None = None) -> list[R]:
        """Every run's result, in order: this process takes the runs left, then waits for the
        children's. ``meanwhile``: called once every run is taken, the children stopped and
        their cores given back, before their results are read (work for the cores they
        leave, started while they send their last results)."""
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
            if meanwhile is not None:
                meanwhile()
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
        give_back_cores(self._held)
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
            end_child(self.pid, self.fd)

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
