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
from typing import IO, Any, ParamSpec, TypeVar

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
from gantry_sim.sim.circular.summary import (  # noqa: E402
    polar_conditions_text,
    polar_figures_text,
    polar_scale,
)

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
    path: Path | IO[bytes], ccw: CircleAnalysis, cw: CircleAnalysis, summary: Mapping[str, Any]
) -> None:
    """polar.png: the radial deviation of the CCW and CW traces, magnified, on a stated scale.

    As ballbar software shows it: angle = position on the circle (0 deg along the plane's
    first axis, 90 deg along its second), radius = the traced radius minus the nominal radius
    about the nominal centre (the ballbar's pivot) [um], on rings :func:`gantry_sim.sim.circular.summary.polar_scale` um apart
    (the scale is printed as um/div), so an ellipse, a spike or a step is seen where it
    happens. The dashed circle is the nominal circle (0 um). A box states the test conditions
    (no date, so the same test gives the same PNG). See :func:`polar_figure`.

    Args:
        path: the PNG to write.
        ccw, cw: each direction's figures.
        summary: the ``gantry ballbar`` object (plane, radius, feed, G(b), ellipse, conditions).
    """
    polar_figure(ccw, cw, summary).savefig(path, dpi=DPI, metadata={"Software": None})


def polar_figure(ccw: CircleAnalysis, cw: CircleAnalysis, summary: Mapping[str, Any]) -> Figure:
    """The polar.png figure (see :func:`save_polar_plot`)."""
    s = summary
    traces = [(r, r.nominal.dev_um, np.degrees(r.nominal.theta_rad) % 360.0) for r in (ccw, cw)]
    devs = np.concatenate([d for _, d, _ in traces] + [np.zeros(1)])
    div, lo, hi = polar_scale(float(devs.min()), float(devs.max()))
    fig = _figure((8, 8.6))
    ax = fig.add_axes((0.14, 0.3, 0.72, 0.58), projection="polar")
    assert isinstance(ax, PolarAxes)  # for the type checker: the polar projection's class
    ring = np.linspace(0, 2 * np.pi, 721)
    nominal = f"nominal circle R {s['radius_mm']:g} mm (0 um)"
    ax.plot(ring, np.zeros_like(ring), "k--", lw=0.9, label=nominal)
    for (res, dev, deg), colour in zip(traces, ("tab:blue", "tab:red"), strict=True):
        order = np.argsort(deg)
        th, dv = np.radians(deg[order]), dev[order]
        label = f"{res.direction.upper()}  G = {res.circular_deviation_um:.2f} um"
        ax.plot(np.append(th, th[0]), np.append(dv, dv[0]), color=colour, lw=0.7, label=label)
    ax.set_rorigin(lo - 2 * div)
    ax.set_rlim(lo, hi)
    ax.set_rticks(np.arange(lo, hi + 0.5 * div, div))
    ax.yaxis.set_major_formatter(lambda v, _pos: f"{v:+g}" if abs(v) > 1e-12 else "0")
    a, b = s["plane"][0], s["plane"][1]
    ax.set_thetagrids([0, 90, 180, 270], [f"+{a}", f"+{b}", f"-{a}", f"-{b}"])
    ax.set_rlabel_position(67.5)
    ax.tick_params(axis="y", labelsize=7)
    fig.legend(loc="upper center", bbox_to_anchor=(0.5, 0.275), ncol=3, fontsize=8, frameon=False)
    title = f"Ballbar {s['plane']}  R {s['radius_mm']:g} mm  F {s['feed_mm_per_min']:g} mm/min"
    fig.text(0.5, 0.962, title, ha="center", fontsize=12)
    fig.text(
        0.5,
        0.935,
        f"scale {div:g} um/div; traced radius minus nominal radius about the nominal centre",
        ha="center",
        fontsize=9,
    )
    box: dict[str, Any] = {"boxstyle": "round", "facecolor": "white", "edgecolor": "0.6"}
    text: dict[str, Any] = {"va": "top", "fontsize": 8, "family": "monospace"}
    fig.text(0.05, 0.215, polar_conditions_text(s), bbox=box, **text)
    fig.text(0.58, 0.215, polar_figures_text(s), **text)
    return fig


# ---- gantry tune -----------------------------------------------------------------------------


# tune.png and the sweep plots: sim.search_plots.
