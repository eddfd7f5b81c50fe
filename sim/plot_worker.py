"""path.png and error.png (and ``gantry ballbar``'s polar.png) drawn by a worker process that
imports matplotlib while the run goes on.

Why: importing the plot modules (matplotlib) takes 0.7-0.9 s of CPU in a fresh interpreter, a
third to a half of a short ``gantry run``. In the run's own process a thread importing them
holds the interpreter lock against the run (sim.plot_prep: the bundled circle's analysis took
0.57 s instead of about 0.02), and imported after the run they are on its critical path.

Here ``python -m gantry_sim.sim.plot_worker`` is started when the run starts
(:func:`early_plot_worker`: ``gantry run`` starts it before its own imports, unless
``--no-plots``; sim.api.run_program(plots=True) when it is called). A program of
sim.worker_pipes.EARLY_WORKER_CHARS or more gets it after its parse instead: beside the
analysis worker starting there, it slowed the parse (10,000 polyline blocks parsed in 0.66-0.94
s instead of 0.38-0.46). The worker imports the plot modules in a thread at background
priority (controller.forked.lower_priority), on the second core while the run plans and
simulates, then waits. While the run simulates, it sends the worker its moves as the pickled
blocks they are kept in on disk (:class:`OutlineRequest`), and the worker computes path.png's
outline (sim.path_outline: 0.1 s of CPU at 30,000 polyline moves, 0.4-0.5 s at 30,000 mixed
ones) in its own process: in a thread of the run's, that work held the interpreter lock against
the run's range hand-overs (a streamed run of 30,000 polyline blocks simulated 0.17 s slower on
average, four alternating pairs). When the outputs are written (sim.plot_files), the run sends it a
:class:`PlotRequest` (the plotted trace, the figures, path.png's outline: about 60 bytes a
plotted tick) and writes trace.npz while the worker draws path.png, and error.png in a child it
forks (controller.forked.Background: matplotlib is imported already). The worker sends back the
PNG files' bytes, and the run writes them: only the run's process writes into its output folder
(sim.outdir), so a worker that outlives a run killed with ``kill -9`` writes nothing anywhere.

``gantry ballbar`` starts one too (:func:`started_plot_worker`) and sends it a
:class:`PolarRequest` while it writes its traces (sim.circular.ballbar.write_ballbar_outputs).

The files are byte for byte the ones the run's own process draws (tests/test_plot_worker.py).
If the worker fails in any way (it did not start, died, or a drawing raised), the run draws both
files itself, as it does without a worker, so an error in a plot is raised with its own
traceback. Used where a worker process pays (sim.worker_pipes.worker_wanted:
``GANTRY_PLOT_WORKER`` not set to 0, a POSIX system with two or more cores, not inside a sweep's
one-process-per-core workers). The worker ends when its stdin closes: after the outputs are
written, when the run fails, when the result is garbage collected unwritten, or when the run's
process ends, however.

This module imports nothing heavy at import (a run starts the worker before its own imports).
"""

from __future__ import annotations

import functools
import io
import os
import threading
import traceback
import weakref
from collections.abc import Callable
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Any

from gantry_sim.sim.worker_pipes import (
    EARLY_WORKER_CHARS,
    Pipes,
    recv_out_of_band,
    send_out_of_band,
    serve_stdio,
    worker_wanted,
)

if TYPE_CHECKING:
    from gantry_sim.controller.forked import Background
    from gantry_sim.controller.pickled_slice import PickledSlice
    from gantry_sim.sim.circular.figures import CircleAnalysis
    from gantry_sim.sim.contour import ContourStats
    from gantry_sim.sim.gates import Gates
    from gantry_sim.sim.path_outline import Outline
    from gantry_sim.sim.trace import Trace

__all__ = [
    "OutlineRequest",
    "PlotRequest",
    "PlotWorker",
    "PolarRequest",
    "early_plot_worker",
    "started_plot_worker",
]


@dataclass(frozen=True)
class PlotRequest:
    """Everything path.png and error.png draw.

    Attributes:
        trace: the plotted trace (a streamed run's decimated one; its reference and forces,
            which no plot draws, left out: sim.plot_files.drawn_fields).
        program: the program's name (path.png's title).
        contour: the run's contour error figures [um].
        drawing: path.png's commanded geometry (sim.path_outline; None: no moves).
        gates: drawn on error.png.
        kinds: {line: move kind} for the gates on a kind of move (sim.gates.Gates.line_kinds).
        outline_kept: ``drawing`` is the outline the worker computed from the run's
            :class:`OutlineRequest` (the request carries None).
    """

    trace: Trace
    program: str
    contour: ContourStats
    drawing: Outline | None
    gates: Gates | None
    kinds: dict[int, str]
    outline_kept: bool = False

    def render(self) -> tuple[bytes, bytes]:
        """The PNG files' bytes (path.png, error.png): :meth:`begin`, then :meth:`end`."""
        return self.end(self.begin())

    def begin(self) -> Background[bytes]:
        """error.png's bytes drawn in a forked child (controller.forked.Background; drawn by
        :meth:`end` where nothing is forked, or when the child failed). The plot module is
        imported here, before the fork: a module lock that another thread (sim.plot_prep's)
        held at the fork would stay held in the child, whose import would wait for ever."""
        from gantry_sim.controller.forked import Background
        from gantry_sim.sim.error_plot import save_error_plot

        r = self
        draw = functools.partial(_png, save_error_plot, r.trace, r.contour, r.gates, kinds=r.kinds)
        return Background(draw)

    def end(self, error_png: Background[bytes]) -> tuple[bytes, bytes]:
        """path.png drawn here while error.png's child (:meth:`begin`) draws: both files'
        bytes (path.png, error.png); the child is ended either way."""
        from gantry_sim.sim.path_plot import save_outline_plot

        try:
            path_png = _png(save_outline_plot, self.drawing, self.trace, self.program, self.contour)
            return path_png, error_png.result()
        finally:
            error_png.close()


@dataclass(frozen=True)
class PolarRequest:
    """``gantry ballbar``'s polar.png (sim.plots.save_polar_plot): the two directions' circle
    analyses and the summary (ballbar.json)."""

    ccw: CircleAnalysis
    cw: CircleAnalysis
    summary: dict[str, Any]

    def render(self) -> tuple[bytes]:
        """polar.png's bytes."""
        from gantry_sim.sim.plots import save_polar_plot

        return (_png(save_polar_plot, self.ccw, self.cw, self.summary),)


@dataclass(frozen=True)
class OutlineRequest:
    """path.png's outline of ``moves`` (the run's commanded moves, as the pickled blocks they
    are kept in: controller.pickled_slice), computed by the worker and kept for the
    :class:`PlotRequest` that says ``outline_kept``. No reply."""

    moves: PickledSlice

    def outline(self) -> Outline | None:
        """The moves' outline (None: no moves), their blocks decoded as the outline reaches
        them."""
        from gantry_sim.controller.pickled_slice import SliceView
        from gantry_sim.sim.path_outline import outline

        return outline(SliceView(self.moves)) if len(self.moves) else None


#: what a worker draws
Request = PlotRequest | PolarRequest


def _png(save: Callable[..., None], *args: Any, **kwargs: Any) -> bytes:
    """The bytes ``save(file, *args, **kwargs)`` writes (a plot module's ``save_*_plot``)."""
    out = io.BytesIO()
    save(out, *args, **kwargs)
    return out.getvalue()


class PlotWorker:
    """The run's side of the worker (see the module docstring): its process is started by
    :meth:`start`."""

    def __init__(self) -> None:
        self._pipes: Pipes | None = None
        self._stop: weakref.finalize | None = None
        self._asked = False
        self._outline: threading.Thread | None = None  # sending the OutlineRequest
        self._outline_sent = False

    def start(self) -> None:
        """Start the worker process, unless it was started or closed already. A process that
        cannot be started leaves the plots to be drawn by the run."""
        if self._pipes is not None or self._asked:
            return
        try:
            self._pipes = Pipes("gantry_sim.sim.plot_worker")
        except OSError:
            self._asked = True
            return
        # stopped when closed, or when garbage collected unused (an unwritten RunResult)
        self._stop = weakref.finalize(self, self._pipes.stop)

    def send_outline(self, moves: PickledSlice) -> bool:
        """Have the worker compute path.png's outline of ``moves`` (an :class:`OutlineRequest`,
        sent by a thread: the worker reads it once its imports are done). False when the worker
        cannot take it (not started, closed, or asked before)."""
        if not self._usable() or self._outline is not None:
            return False
        pipes = self._pipes
        assert pipes is not None

        def send() -> None:
            try:
                send_out_of_band(pipes.out, OutlineRequest(moves))
                self._outline_sent = True
            except OSError:  # the worker is gone: the request meets it too
                pass

        self._outline = threading.Thread(target=send, name="gantry-outline", daemon=True)
        self._outline.start()
        return True

    @property
    def outline_kept(self) -> bool:
        """The worker was sent the run's outline (:meth:`send_outline`; waits for the
        sending)."""
        if self._outline is not None:
            self._outline.join()
        return self._outline_sent

    def draw(self, request: Request) -> bool:
        """Send ``request`` (once, after the outline's); False when the worker cannot take it
        (not started, closed, gone, or asked before): then draw the plots here."""
        if not self._usable():
            return False
        if self._outline is not None:
            self._outline.join()
        self._asked = True
        assert self._pipes is not None
        try:
            send_out_of_band(self._pipes.out, request)
        except OSError:
            return False
        return True

    def _usable(self) -> bool:
        return not (
            self._asked or self._pipes is None or self._stop is None or not self._stop.alive
        )

    def wait(self) -> tuple[bytes, ...] | None:
        """The PNG files' bytes drawn for the request sent (``request.render()``; waits for
        them); None: the worker failed (draw them here; a drawing that raised there raises here
        too)."""
        if self._pipes is None:
            return None
        try:
            reply = self._pipes.inp.recv()
        except (EOFError, OSError):
            return None
        return reply if isinstance(reply, tuple) else None

    def close(self) -> None:
        """Stop the worker (idempotent); a worker never started is not started after."""
        self._asked = True
        if self._stop is not None:
            self._stop()


def started_plot_worker() -> PlotWorker | None:
    """A :class:`PlotWorker` started now where one pays (see the module docstring), else
    None."""
    if not worker_wanted("GANTRY_PLOT_WORKER"):
        return None
    worker = PlotWorker()
    worker.start()
    return worker


def early_plot_worker(program: str | os.PathLike[str]) -> PlotWorker | None:
    """A :class:`PlotWorker` for the run of ``program`` (its text, or its file) where one pays
    (see the module docstring), else None; started now for a program of fewer than
    EARLY_WORKER_CHARS characters (its imports overlap the run's own), else by the run after its
    parse (:meth:`PlotWorker.start`)."""
    if not worker_wanted("GANTRY_PLOT_WORKER"):
        return None
    worker = PlotWorker()
    if _chars(program) < EARLY_WORKER_CHARS:
        worker.start()
    return worker


def _chars(program: str | os.PathLike[str]) -> int:
    """About the length of ``program`` in characters (a file's size in bytes; 0 when it cannot
    be read: the run says why)."""
    if isinstance(program, str):
        return len(program)
    try:
        return os.stat(program).st_size
    except (OSError, TypeError, ValueError):
        return 0


def _import_plot_modules() -> None:
    from gantry_sim.controller.forked import lower_priority

    lower_priority()
    try:
        import gantry_sim.sim.error_plot
        import gantry_sim.sim.path_plot  # noqa: F401
    except Exception:  # raised again by the drawing that needs it, and reported
        pass


def _serve(inp: Connection, out: Connection) -> None:
    """The worker: import the plot modules in a thread, then draw each request received until
    the input ends. The thread has ended before a request is read (unpickling it imports
    modules too) and before anything is drawn: a fork (error.png's child) must not happen while
    another thread holds an import lock."""
    imports = threading.Thread(target=_import_plot_modules, name="plot-imports", daemon=True)
    imports.start()
    kept: Outline | str | None = None  # the OutlineRequest's outline, or why it failed
    try:
        while True:
            inp.poll(None)  # a request, or the end of the input
            imports.join()
            request = recv_out_of_band(inp)
            if isinstance(request, OutlineRequest):
                try:
                    kept = request.outline()
                except Exception:
                    kept = traceback.format_exc(limit=-3).strip().replace("\n", " | ")
                continue
            reply: tuple[bytes, ...] | str
            try:
                if not isinstance(request, Request):
                    raise TypeError(f"not a plot request: {type(request).__name__}")
                if isinstance(request, PlotRequest) and request.outline_kept:
                    if isinstance(kept, str):
                        raise RuntimeError(f"the outline failed: {kept}")
                    request = replace(request, drawing=kept, outline_kept=False)
                reply = request.render()
            except Exception:
                reply = traceback.format_exc(limit=-3).strip().replace("\n", " | ")
            out.send(reply)
    except (EOFError, OSError, KeyboardInterrupt):
        pass  # the run ended, is gone or interrupted (OSError: a broken pipe): nobody to tell


if __name__ == "__main__":  # the worker process (see PlotWorker)
    # the module's own name, not __main__: the requests unpickle as its PlotRequest
    from gantry_sim.sim.plot_worker import _serve as serve

    serve(*serve_stdio())
