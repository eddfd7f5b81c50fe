"""A run's path.png and error.png, drawn while its other output files are written: by the run's
plot worker (sim.plot_worker) when it has one, else here, the same drawing
(sim.plot_worker.PlotRequest: error.png in a forked child, path.png in the drawing process; the
two took 0.30 and 0.15 s one after the other at 10,000 polylines, on one of two cores); either
way their bytes are written here.

Import only where the plots are wanted.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import replace
from pathlib import Path

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.sim.contour import ContourStats
from gantry_sim.sim.gates import Gates
from gantry_sim.sim.path_outline import Outline, outline
from gantry_sim.sim.plot_worker import PlotRequest, PlotWorker
from gantry_sim.sim.trace import Trace

__all__ = ["Plots"]


class Plots:
    """path.png and error.png of a run in ``folder``, started when made; :meth:`finish` returns
    when both are written, :meth:`close` ends what is still drawing (call it in any case).

    Args:
        trace: the plotted trace (a streamed run's decimated one).
        program: the program's name (path.png's title).
        contour: the run's contour error figures [um].
        moves: the commanded geometry.
        drawing: path.png's outline computed during the run (sim.plot_prep), or None (by the
            worker, when it was sent the moves: PlotWorker.send_outline; else here).
        gates: drawn on error.png.
        worker: the run's plot worker, or None: drawn here.
    """

    def __init__(
        self,
        folder: Path,
        trace: Trace,
        program: str,
        contour: ContourStats,
        moves: Sequence[Move],
        drawing: Future[Outline | None] | None,
        gates: Gates | None,
        worker: PlotWorker | None,
    ) -> None:
        # the plots' thread (sim.plot_prep) has ended once its outline is there: nothing is
        # being imported when error.png's child is forked (a module lock held by another thread
        # at the fork would stay held in the child)
        kept = worker is not None and worker.outline_kept  # the worker has the outline
        done = drawing.result() if drawing is not None else None
        if done is None and len(moves) and not kept:
            done = outline(moves)
        self._moves = moves
        self._path_png, self._error_png_path = folder / "path.png", folder / "error.png"
        self._request = PlotRequest(
            trace=drawn_fields(trace),
            program=program,
            contour=contour,
            drawing=done,
            gates=gates,
            kinds=gates.line_kinds(moves) if gates is not None else {},
            outline_kept=kept,
        )
        self._worker = worker if worker is not None and worker.draw(self._request) else None
        # drawn here: error.png's child starts now, beside the writing of trace.npz
        self._error_png = None if self._worker is not None else self._here().begin()

    @property
    def elsewhere(self) -> bool:
        """The plot worker took the request: this process only waits in :meth:`finish`."""
        return self._worker is not None

    def finish(self, advance: Callable[[int], object]) -> None:
        """Wait until both files are written (drawn here if the worker failed: the same
        sim.plot_worker.PlotRequest drawing); ``advance(k)``: k more files written."""
        drawn = self._worker.wait() if self._worker is not None else None
        if drawn is None:
            if self._error_png is None:
                self._error_png = self._here().begin()
            drawn = self._here().end(self._error_png)
        self._path_png.write_bytes(drawn[0])
        self._error_png_path.write_bytes(drawn[1])
        advance(2)

    def _here(self) -> PlotRequest:
        """The request as drawn in this process: with the outline computed here if the worker
        was to compute it."""
        if self._request.outline_kept:
            moves = self._moves
            drawing = outline(moves) if len(moves) else None
            self._request = replace(self._request, drawing=drawing, outline_kept=False)
        return self._request

    def close(self) -> None:
        """Stop error.png's child here, if any, and reap it: nothing writes into the folder
        after (the worker writes nowhere)."""
        if self._error_png is not None:
            self._error_png.close()


def drawn_fields(trace: Trace) -> Trace:
    """``trace`` with only what the plots draw: its reference and drive forces, which neither
    plot reads, zero-length (0, 3), so that the request sent to the plot worker does not carry
    them (48 bytes a tick: 9.6 MB of a streamed run's 200,000 plotted ticks)."""
    none = np.empty((0, 3))
    return replace(trace, ref=none, force_N=none)
