"""The streamed run's analysis of each range, in this process or in a worker process.

A streamed run (sim.stream) hands each simulated range to an analyser and takes its result back
one range later, in order. :class:`InlineAnalyser` analyses at once; :class:`ProcessAnalyser`
starts a worker process at the start of the run (``python -m gantry_sim.sim.analysis_worker``,
talking over its stdin and stdout), sends it each range's lines, traced points and reference
(about 90 bytes a tick each way) with the moves the range reaches (sim.range_rows: the worker
lays out their tables; every message to the worker with its arrays out of band:
:func:`send_out_of_band`), and returns the previous range's
result, so the analysis of range k runs on the second core while the servo loop simulates
range k + 1. The work is the same function on the same arrays: the figures are identical either
way (tests/test_stream.py runs both).

The worker is a fresh interpreter talked to over pipes (sim.worker_pipes says why); it ends
when its stdin closes: when the run ends, or its process dies, whatever the cause.

The worker is used where it can pay: a POSIX system, two or more cores, not inside
controller.forked.one_process (a sweep runs one point per core), and
``GANTRY_ANALYSIS_WORKER`` not set to 0. A failure in the worker is raised in the run as a
RuntimeError carrying the worker's traceback (exit status 3 from the CLI).
"""

from __future__ import annotations

import traceback
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import cast

import numpy as np

from gantry_sim.controller.pickled_slice import DecodedBlocks
from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.blend_parts import planning_distance_mm
from gantry_sim.sim.contour import ChunkAnalysis, analyse_chunk
from gantry_sim.sim.move_table import move_table
from gantry_sim.sim.range_rows import RangeTables
from gantry_sim.sim.worker_pipes import (
    EARLY_WORKER_CHARS,
    Pipes,
    recv_out_of_band,
    send_out_of_band,
    serve_stdio,
)
from gantry_sim.sim.worker_pipes import worker_wanted as worker_wanted_for


@dataclass(frozen=True)
class RangeJob:
    """One simulated range: ticks lo.. of the run; ``piece``: its reference; ``context_pos``:
    the reference positions around it (sim.contour.reference_context), piece.pos =
    context_pos[offset:offset+n] [mm]; ``pos``: the traced tool tip (n, 3) [mm];
    ``force``: the held forces (n, 3) [N]; ``overlap``: per tick, whether it lies in an
    overlapped stop (sim.blend_parts.in_overlaps; None: none does)."""

    lo: int
    piece: Trajectory
    context_pos: np.ndarray
    offset: int
    pos: np.ndarray
    force: np.ndarray
    overlap: np.ndarray | None = None


Result = tuple[RangeJob, ChunkAnalysis, float]


def analyse_range(
    tables: RangeTables,
    line: np.ndarray,
    source: np.ndarray | None,
    pos: np.ndarray,
    context_pos: np.ndarray,
    offset: int,
    overlap: np.ndarray | None = None,
    *,
    cache: DecodedBlocks | None = None,
) -> tuple[ChunkAnalysis, float]:
    """The contour analysis of ticks executing ``line`` (n,) and the program moves ``source``
    (n, 2) (Trajectory.source, or None) traced at ``pos`` (n, 3) [mm]
    (sim.contour.analyse_chunk), and the largest distance [mm] of their feed reference
    samples from the path the planner followed (sim.blend_parts.planning_distance_mm; not
    those where ``overlap`` (n,) is set: sim.blend_parts.in_overlaps), against the moves
    ``tables`` holds (sim.range_rows: the rows the range reaches, laid out here; their pickled
    blocks decoded through ``cache``)."""
    moves, path_moves = tables.listed(cache)
    tab = move_table(moves, tables.cum_len)
    if source is not None:
        source = np.where(source >= 0, source - tables.r0, source)
    part = analyse_chunk(tab, line, pos, context_pos, offset, source, tables.found)
    ref = context_pos[offset : offset + len(pos)]
    path_tab = move_table(path_moves)
    feed = part.feed if overlap is None else part.feed & ~overlap
    return part, planning_distance_mm(path_tab, line, ref, feed, tables.path_window)


def _job_args(job: RangeJob, tables: RangeTables) -> tuple:
    piece = job.piece
    return (tables, piece.line, piece.source, job.pos, job.context_pos, job.offset, job.overlap)


class InlineAnalyser:
    """Analyses each range when it is submitted."""

    def __init__(self) -> None:
        self._done: deque[Result] = deque()

    def submit(self, job: RangeJob, tables: RangeTables) -> None:
        """Analyse ``job`` against ``tables`` (the moves it reaches: sim.range_rows)."""
        self._done.append((job, *analyse_range(*_job_args(job, tables))))

    def ready(self, drain: bool = False) -> list[Result]:
        """The results of the ranges analysed so far, in order."""
        out = list(self._done)
        self._done.clear()
        return out

    def abort(self) -> None:
        """Nothing runs elsewhere."""

    def close(self) -> None:
        self._done.clear()


class ProcessAnalyser:
    """Analyses the ranges in a worker process, one range behind the simulation."""

    def __init__(self) -> None:
        self._pipes = Pipes("gantry_sim.sim.analysis_worker")
        self._out, self._in = self._pipes.out, self._pipes.inp
        self._sent: deque[RangeJob] = deque()
        self._done: deque[Result] = deque()
        self._send_error: OSError | None = None

    def _send(self, msg: object) -> None:
        try:
            send_out_of_band(self._out, msg)
        except OSError as exc:
            self._send_error = exc

    def submit(self, job: RangeJob, tables: RangeTables) -> None:
        """Take the previous range's result (waiting for it), then send this range (its lines,
        traced points and reference positions, and the moves it reaches: sim.range_rows). One
        range at a time is in the pipes: the worker's reply and the next range are each larger
        than a pipe's buffer, so sending both ways at once would block both processes."""
        self._take_replies()
        if self._send_error is None:
            self._send(_job_args(job, tables))
        if self._send_error is not None:  # the worker is gone: say why
            while True:
                self._recv()
        self._sent.append(job)

    def ready(self, drain: bool = False) -> list[Result]:
        """The results received so far, in order; with ``drain``, also the last range's (waits
        for it)."""
        if drain:
            self._take_replies()
        out = list(self._done)
        self._done.clear()
        return out

    def _take_replies(self) -> None:
        while self._sent:
            self._done.append((self._sent.popleft(), *self._recv()))

    def _recv(self) -> tuple[ChunkAnalysis, float]:
        try:
            reply = self._in.recv()
        except (EOFError, OSError):
            proc = self._pipes.proc
            proc.wait()
            raise RuntimeError(
                f"analysis worker exited (status {proc.returncode}) without its results"
            ) from None
        if isinstance(reply, str):
            raise RuntimeError(f"analysis worker failed: {reply}")
        return reply

    def abort(self) -> None:
        """Kill the worker (from any thread; the pipes stay open): a thread waiting for its
        reply hears that it exited. :meth:`close` still closes the pipes."""
        self._pipes.proc.kill()

    def close(self) -> None:
        """Stop the worker: its stdin closed, and killed (every result is in, so it has nothing
        left to do: waiting for its interpreter to tear down its heap took 0.05-0.07 s at the
        end of every run); when the run stopped with a range still out, it is terminated."""
        self._pipes.stop(kill=not self._sent)
        self._sent.clear()


def _serve(inp: Connection, out: Connection) -> None:
    """The worker: every range received until the input ends."""
    cache = DecodedBlocks()  # consecutive ranges share the blocks at their boundary
    try:
        while True:
            job = cast(tuple, recv_out_of_band(inp))
            out.send(analyse_range(*job, cache=cache))
    except (EOFError, OSError, KeyboardInterrupt):
        pass  # the run ended, is gone or interrupted (OSError: a broken pipe): nobody to tell
    except Exception:  # reported to the run, which raises it
        try:
            out.send(traceback.format_exc(limit=-3).strip().replace("\n", " | "))
        except OSError:
            pass


def worker_wanted() -> bool:
    """Whether a :class:`ProcessAnalyser` can pay here (see the module docstring)."""
    return worker_wanted_for("GANTRY_ANALYSIS_WORKER")


def make_analyser() -> InlineAnalyser | ProcessAnalyser:
    """A :class:`ProcessAnalyser` where it can pay (:func:`worker_wanted`), else inline."""
    return ProcessAnalyser() if worker_wanted() else InlineAnalyser()


def early_worker(program_chars: int) -> ProcessAnalyser | None:
    """A worker started before a program of ``program_chars`` characters
    (:data:`EARLY_WORKER_CHARS` or more) is parsed, for its run
    if it is streamed (sim.api.run_program closes it otherwise): the interpreter's start, about
    0.3-0.4 s of CPU, then runs on the second core while the program is parsed and planned,
    instead of beside the servo loop, where it took the loop's time (10,000 polyline blocks
    simulated 0.15-0.3 s faster, three alternating pairs). None for a shorter program (it
    would rarely be streamed: a run streams past sim.api.STREAM_ABOVE_TICKS ticks), or
    where no worker can pay."""
    if program_chars < EARLY_WORKER_CHARS or not worker_wanted():
        return None
    return ProcessAnalyser()


if __name__ == "__main__":  # the worker process (see ProcessAnalyser)
    _serve(*serve_stdio())
