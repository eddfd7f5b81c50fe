"""The plots' work that needs nothing from the simulation, done while it runs: path.png's
commanded geometry (sim.path_outline: 0.5 s at 30,000 moves) and, when no plot worker imports
them (sim.plot_worker), the plot modules' imports (matplotlib: 0.7-0.9 s of CPU), in a thread of
background priority (controller.forked.lower_priority). The compiled servo ticks run with the
GIL released (sim.pd_ticks), so the thread takes the second core instead of the outputs' time
after the run; its imports still hold the GIL against the run's Python parts, which the plot
worker's do not.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from concurrent.futures import Future

from gantry_sim.controller.forked import lower_priority
from gantry_sim.controller.moves import Move
from gantry_sim.sim import path_outline
from gantry_sim.sim.path_outline import Outline

__all__ = ["prepare_plots"]


def prepare_plots(moves: Sequence[Move], imports: bool = True) -> Future[Outline | None]:
    """Start a daemon thread, at background priority, that (``imports``) imports the plot
    modules (matplotlib: 0.7-0.9 s of CPU) and computes the :class:`Outline` of ``moves`` (None: no
    moves); return its future. A run with no plots wasted the thread's work. A failed import
    is met again, and raised, where the plots are drawn; an error in the outline is raised by
    ``future.result()``."""
    future: Future[Outline | None] = Future()

    def work() -> None:
        lower_priority()
        try:
            if imports:
                import gantry_sim.sim.error_plot
                import gantry_sim.sim.path_plot  # noqa: F401
        except Exception:  # raised again by the import that needs it
            pass
        try:
            future.set_result(path_outline.outline(moves) if len(moves) else None)
        except BaseException as exc:
            future.set_exception(exc)

    threading.Thread(target=work, name="gantry-plot-prep", daemon=True).start()
    return future
