"""Every figure gantry draws, one idiom: a ``matplotlib.figure.Figure`` on its own Agg canvas.

No pyplot, so no global figure registry and no backend switch: each function builds its
figure, saves the PNG and lets it go. Import this module only where a plot is drawn (it imports
matplotlib, which ``gantry`` must not load at start-up).

* ``gantry run``: sim.path_plot (path.png), sim.error_plot (error.png);
* ``gantry ballbar``: :func:`save_polar_plot` (polar.png);
* ``gantry tune`` and ``gantry sweep``: sim.search_plots (tune.png, the sweep plots).
"""

from __future__ import annotations

import functools
import logging
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

# No noise on stderr: matplotlib logs at WARNING when its config or cache folder is not writable
# or its font cache is rebuilt (at import), and warns on degenerate axes while drawing; neither
# is a finding of the run. Set before matplotlib is first imported (this module is the only
# place that imports it at module level; the other plot modules import it through here first).
logging.getLogger("matplotlib").setLevel(logging.ERROR)
warnings.filterwarnings("ignore", module=r"matplotlib(\..*)?$")

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.projections.polar import PolarAxes  # noqa: E402

from gantry_sim.sim.circular.figures import CircleAnalysis  # noqa: E402

P = ParamSpec("P")
R = TypeVar("R")

#: resolution of every saved PNG [dots per inch]
DPI = 110


def quiet(draw: Callable[P, R]) -> Callable[P, R]:
    """Run a plot-saving function with matplotlib's UserWarnings (attributed by matplotlib to
    the caller's line, e.g. "no artists with labels") silenced: a figure's cosmetics are no
    finding of the run and must not reach stderr."""

    @functools.wraps(draw)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return draw(*args, **kwargs)

    return wrapper


def _figure(figsize: tuple[float, float], dpi: float | None = None) -> Figure:
    """A figure drawn by its own Agg canvas (``dpi`` None: matplotlib's default, 100)."""
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


# ---- gantry run ------------------------------------------------------------------------------


# path.png and error.png: sim.path_plot, sim.error_plot.


# ---- gantry ballbar --------------------------------------------------------------------------


def save_polar_plot(
    path: Path, ccw: CircleAnalysis, cw: CircleAnalysis, summary: Mapping[str, Any]
) -> None:
    """polar.png: radial deviation about the LSQ centre, magnified, CCW and CW overlaid.

    As ballbar software shows it: angle = position on the circle (0 deg along the plane's
    first axis, 90 deg along its second), radius = deviation [um] on a scale whose zero is the
    dashed least-squares circle, so an ellipse, a spike or a step is seen where it happens.

    Args:
        path: the PNG to write.
        ccw, cw: each direction's figures.
        summary: the ``gantry ballbar`` contract object (plane, radius, feed, G(b), ellipse).
    """
    s = summary
    devs = np.concatenate([ccw.deviation_um, cw.deviation_um])
    lo, hi = float(devs.min()), float(devs.max())
    span = max(hi - lo, 1.0)
    fig = _figure((7, 8))
    ax = fig.add_subplot(projection="polar")
    assert isinstance(ax, PolarAxes)  # for the type checker: the polar projection's class
    for res, colour in ((ccw, "tab:blue"), (cw, "tab:red")):
        order = np.argsort(res.theta_deg)
        th = np.radians(res.theta_deg[order])
        label = f"{res.direction.upper()}  G = {res.circular_deviation_um:.2f} um"
        ax.plot(
            np.append(th, th[0]),
            np.append(res.deviation_um[order], res.deviation_um[order][0]),
            color=colour,
            lw=0.6,
            label=label,
        )
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.zeros_like(ring), "k--", lw=0.8, label="least-squares circle (0 um)")
    ax.set_rorigin(lo - 1.2 * span)
    ax.set_rlim(lo - 0.1 * span, hi + 0.1 * span)
    a, b = s["plane"][0], s["plane"][1]
    ax.set_thetagrids([0, 90, 180, 270], [f"+{a}", f"+{b}", f"-{a}", f"-{b}"])
    ax.set_rlabel_position(67.5)
    ax.tick_params(axis="y", labelsize=7)
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    e = s["ellipse"]
    fig.suptitle(
        f"Ballbar {s['plane']}  R {s['radius_mm']:g} mm  F {s['feed_mm_per_min']:g} mm/min\n"
        f"radial deviation about the LSQ centre [um], magnified; G(b) "
        f"{s['bidirectional_deviation_um']:.2f} um\nellipse {e['magnitude_um']:.2f} um at "
        f"{e['axis_deg']:.0f} deg (CCW), flips with direction: {e['flips_with_direction']}",
        fontsize=9,
    )
    fig.tight_layout(rect=(0, 0.04, 1, 0.93))
    fig.savefig(path, dpi=DPI)


# ---- gantry tune -----------------------------------------------------------------------------


# tune.png and the sweep plots: sim.search_plots.
