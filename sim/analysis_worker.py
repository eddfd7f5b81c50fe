"""The streamed run's analysis of each range, in this process or in a forked worker process.

A streamed run (sim.stream) hands each simulated range to an analyser and takes its result back
one range later, in order. :class:`InlineAnalyser` analyses at once; :class:`ForkedAnalyser`
sends the range to a worker process forked at the start of the run (it inherits the move
tables, so nothing but the range's arrays crosses the pipe: about 90 bytes a tick each way) and
returns the previous range's result, so the analysis of range k runs on the second core while
the servo loop simulates range k + 1. The work is the same function on the same arrays: the
figures are identical either way (tests/test_stream.py runs both).

The worker is used where it can pay: a fork start method (Linux, macOS with fork), two or more
cores, and ``GANTRY_ANALYSIS_WORKER`` not set to 0. A failure in the worker is raised in the
run as a RuntimeError carrying the worker's traceback (exit status 3 from the CLI).
"""

from __future__ import annotations

import multiprocessing
import os
import traceback
from collections import deque
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.trajectory import Trajectory
from gantry_sim.sim.blend_parts import planning_distance_mm
from gantry_sim.sim.contour import ChunkAnalysis, analyse_chunk
from gantry_sim.sim.move_table import MoveTable


@dataclass(frozen=True)
class RangeJob:
    """One simulated range: ticks lo.. of the run; ``piece``: its reference; ``context_pos``:
    the reference positions around it (sim.contour.reference_context), piece.pos =
    context_pos[offset:offset+n] [mm]; ``pos``: the traced tool tip (n, 3) [mm];
    ``force``: the held forces (n, 3) [N]."""

    lo: int
    piece: Trajectory
    context_pos: np.ndarray
    offset: int
    pos: np.ndarray
    force: np.ndarray


Result = tuple[RangeJob, ChunkAnalysis, float]


def analyse_range(
    tab: MoveTable,
    path_tab: MoveTable,
    line: np.ndarray,
    pos: np.ndarray,
    context_pos: np.ndarray,
    offset: int,
) -> tuple[ChunkAnalysis, float]:
    """The contour analysis of ticks executing ``line`` (n,) traced at ``pos`` (n, 3) [mm]
    (sim.contour.analyse_chunk), and the largest distance [mm] of their feed reference
    samples from the path the planner followed (sim.blend_parts.planning_distance_mm)."""
    part = analyse_chunk(tab, line, pos, context_pos, offset)
    ref = context_pos[offset : offset + len(pos)]
    return part, planning_distance_mm(path_tab, line, ref, part.feed)


class InlineAnalyser:
    """Analyses each range when it is submitted."""

    def __init__(self, tab: MoveTable, path_tab: MoveTable) -> None:
        self.tab, self.path_tab = tab, path_tab
        self._done: deque[Result] = deque()

    def submit(self, job: RangeJob) -> None:
        args = (job.piece.line, job.pos, job.context_pos, job.offset)
        self._done.append((job, *analyse_range(self.tab, self.path_tab, *args)))

    def ready(self, drain: bool = False) -> list[Result]:
        """The results of the ranges analysed so far, in order."""
        out = list(self._done)
        self._done.clear()
        return out

    def close(self) -> None:
        self._done.clear()


class ForkedAnalyser:
    """Analyses the ranges in a forked worker process, one range behind the simulation."""

    def __init__(self, tab: MoveTable, path_tab: MoveTable) -> None:
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(
            target=_serve, args=(child, self._conn, tab, path_tab), daemon=True
        )
        self._proc.start()
        child.close()
        self._sent: deque[RangeJob] = deque()
        self._done: deque[Result] = deque()

    def submit(self, job: RangeJob) -> None:
        """Take the previous range's result (waiting for it), then send this range (its lines,
        traced points and reference positions). One range at a time is in the pipe: the
        worker's reply and the next range are each larger than the pipe's buffer, so sending
        both ways at once would block both processes."""
        self._take_replies()
        try:
            self._conn.send((job.piece.line, job.pos, job.context_pos, job.offset))
        except OSError:  # the worker is gone: say why
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
            reply = self._conn.recv()
        except (EOFError, OSError):
            raise RuntimeError(
                f"analysis worker exited (status {self._proc.exitcode}) without its results"
            ) from None
        if isinstance(reply, str):
            raise RuntimeError(f"analysis worker failed: {reply}")
        return reply

    def close(self) -> None:
        """Stop the worker: at the end of the run, asked to (it waits for a range, so the
        message goes through); when the run stopped with a range still out, terminated."""
        if not self._sent and self._proc.is_alive():
            try:
                self._conn.send(None)
            except OSError:
                pass
            self._proc.join(timeout=5)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join()
        self._sent.clear()
        self._conn.close()


def _serve(conn, parent_end, tab: MoveTable, path_tab: MoveTable) -> None:
    """The worker: analyse every range received until None, or until the run's process is gone
    (its end of the pipe, inherited by the fork, is closed here first, so that the run's exit
    -- even a kill -- ends this loop with an EOFError)."""
    parent_end.close()
    try:
        while (msg := conn.recv()) is not None:
            conn.send(analyse_range(tab, path_tab, *msg))
    except (EOFError, OSError, KeyboardInterrupt):
        pass  # the run is gone or interrupted (OSError: a broken pipe): nobody to tell
    except Exception:  # reported to the run, which raises it
        try:
            conn.send(traceback.format_exc(limit=-3).strip().replace("\n", " | "))
        except OSError:
            pass
    finally:
        conn.close()


def make_analyser(tab: MoveTable, path_tab: MoveTable) -> InlineAnalyser | ForkedAnalyser:
    """A :class:`ForkedAnalyser` where it can pay (see the module docstring), else inline."""
    forked = (
        os.environ.get("GANTRY_ANALYSIS_WORKER", "1") != "0"
        and "fork" in multiprocessing.get_all_start_methods()
        and (os.cpu_count() or 1) >= 2
    )
    return ForkedAnalyser(tab, path_tab) if forked else InlineAnalyser(tab, path_tab)
