"""``gantry run``'s path.png: the commanded path and the traced one, its error magnified a fixed
1000 times, in the arcs' plane or as a three-view sheet; the worst point labelled with its line.
Drawn for 100,000-block programs too: the commanded geometry is two Line2D (NaN-separated) and
the traced path is decimated.

Import only where a plot is drawn (matplotlib).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.sim.contour import ContourStats
from gantry_sim.sim.path_outline import Outline, extent, outline
from gantry_sim.sim.plot_text import literal_text
from gantry_sim.sim.plots import DPI, _figure, quiet
from gantry_sim.sim.trace import Trace

if TYPE_CHECKING:  # matplotlib is imported through sim.plots first (it quiets its logging)
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: path.png draws the traced path's deviation from the commanded path x this, for every run:
#: 1 um of contour error is drawn as 1 mm, so the plot's mm grid reads as um of error.
ERROR_MAGNIFICATION = 1000.0
#: a single view only when the feed moves leave the arcs' plane by less than this fraction of
#: their in-plane extent; otherwise the three-view sheet (XY top, XZ front, YZ side)
OUT_OF_PLANE_FRACTION = 0.25
#: most traced points drawn on path.png (decimated beyond; the worst point is always kept)
MAX_TRACE_POINTS = 40_000
_AXES = "XYZ"
_VIEWS = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}


def choose_views(moves: Sequence[Move]) -> list[str]:
    """The plane(s) path.png draws: the arcs' plane when all arcs share one and the feed moves
    stay near it; else, without arcs, the plane of the two largest extents when the third is
    small; otherwise the three views ["XY", "XZ", "YZ"]."""
    return _views(*extent(moves)[:3]) if moves else ["XY"]


def _views(lo: np.ndarray, hi: np.ndarray, planes: set[str] | frozenset[str]) -> list[str]:
    """:func:`choose_views` from the feed moves' box (``lo``, ``hi`` [mm]) and arc planes."""
    span = hi - lo
    if len(planes) > 1:
        return list(_VIEWS)
    plane: str
    if planes:
        plane = next(iter(planes))
    else:  # the two axes of largest extent; XY unless Z clearly matters more
        i, j = sorted(np.argsort(span - np.array([0.0, 0.0, 1e-9]), kind="stable")[-2:])
        plane = _AXES[i] + _AXES[j]
    i, j = _VIEWS[plane]
    normal = 3 - i - j
    in_plane = max(span[i], span[j], 1e-9)
    return [plane] if span[normal] <= OUT_OF_PLANE_FRACTION * in_plane else list(_VIEWS)


def _decimate(n: int, keep: int, limit: int = MAX_TRACE_POINTS) -> np.ndarray:
    idx = np.arange(0, n, max(1, -(-n // limit)))
    return np.union1d(idx, [keep, n - 1]) if n else idx


def _draw_view(
    ax: Axes,
    plane: str,
    feed: np.ndarray,
    rapid: np.ndarray,
    traced: np.ndarray,
    worst: tuple[np.ndarray, np.ndarray, int, float] | None,
) -> None:
    i, j = _VIEWS[plane]
    ax.plot(rapid[:, i], rapid[:, j], color="0.6", ls="--", lw=0.8)
    ax.plot(feed[:, i], feed[:, j], color="k", lw=1.0)
    ax.plot(traced[:, i], traced[:, j], color="tab:red", lw=0.9)
    if worst is not None:
        drawn, _, line, err = worst
        ax.plot(drawn[i], drawn[j], "o", mfc="none", mec="tab:blue", ms=10, mew=1.5)
        ax.annotate(
            f"max {err:.2f} um\nline {line}",
            (drawn[i], drawn[j]),
            textcoords="offset points",
            xytext=(16, 16),
            fontsize=8,
            color="tab:blue",
            bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "tab:blue", "lw": 0.6},
            arrowprops={"arrowstyle": "-", "color": "tab:blue", "lw": 0.8},
        )
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{_AXES[i]} [mm]")
    ax.set_ylabel(f"{_AXES[j]} [mm]")
    ax.grid(alpha=0.25)


@quiet
def save_path_plot(
    path: Path,
    moves: Sequence[Move],
    trace: Trace,
    program: str,
    contour: ContourStats,
    drawing: Outline | None = None,
) -> None:
    """Write :func:`path_figure` to ``path`` (path.png)."""
    path_figure(moves, trace, program, contour, drawing).savefig(path)


@quiet
def save_outline_plot(
    path: Path | IO[bytes],
    drawing: Outline | None,
    trace: Trace,
    program: str,
    contour: ContourStats,
) -> None:
    """Write :func:`outline_figure` to ``path`` (path.png): the same file as
    :func:`save_path_plot` of the moves ``drawing`` outlines (None: no moves)."""
    outline_figure(drawing, trace, program, contour).savefig(path)


def path_figure(
    moves: Sequence[Move],
    trace: Trace,
    program: str,
    contour: ContourStats,
    drawing: Outline | None = None,
) -> Figure:
    """path.png of ``moves`` (:func:`outline_figure`); ``drawing``: their outline when
    already computed (sim.path_outline)."""
    if len(moves) and drawing is None:
        drawing = outline(moves)
    return outline_figure(drawing if len(moves) else None, trace, program, contour)


def outline_figure(
    drawing: Outline | None, trace: Trace, program: str, contour: ContourStats
) -> Figure:
    """path.png: the commanded geometry ``drawing`` (black feed moves, grey dashed rapids; None:
    no moves) and the traced path (red) whose deviation from the nearest commanded point is
    magnified :data:`ERROR_MAGNIFICATION` times, in the arcs' plane or as a three-view sheet
    (:func:`choose_views`); the worst feed point is circled and labelled with its line."""
    tr = trace
    if drawing is not None:
        views = _views(drawing.lo, drawing.hi, drawing.planes)
        feed, rapid = drawing.feed, drawing.rapid
    else:
        views, feed, rapid = ["XY"], np.empty((0, 3)), np.empty((0, 3))
    drawn = tr.nearest + ERROR_MAGNIFICATION * (tr.pos - tr.nearest)
    drawn = np.where(tr.feed[:, None], drawn, np.nan)
    worst = None
    k = 0
    if tr.feed.any():
        k = int(np.flatnonzero(tr.feed)[np.argmax(tr.err_um[tr.feed])])
        worst = (drawn[k], tr.pos[k], int(tr.line[k]), float(tr.err_um[k]))
    traced = drawn[_decimate(len(drawn), k)]
    gain = f"traced path, error x {ERROR_MAGNIFICATION:g} (1 um drawn as 1 mm)"
    title = f"{literal_text(program)}: max {contour.max_um:.2f} um, rms {contour.rms_um:.2f} um"
    if len(views) == 1:
        fig = _figure((7, 7), dpi=DPI)
        ax = fig.add_subplot()
        _draw_view(ax, views[0], feed, rapid, traced, worst)
        ax.set_title(f"{title}\n{views[0]} plane; red: {gain}", fontsize=10)
    else:
        fig = _figure((11, 10), dpi=DPI)
        grid = fig.subplots(2, 2)
        for ax, plane in zip((grid[0, 0], grid[1, 0], grid[1, 1]), views, strict=True):
            _draw_view(ax, plane, feed, rapid, traced, worst)
            ax.set_title(f"{plane}", fontsize=10)
        info = grid[0, 1]
        info.axis("off")
        info.text(
            0.02,
            0.95,
            f"{title}\n\nthree views (third angle): XY top, XZ front, YZ side\n\n"
            f"black: commanded feed moves\ngrey dashed: rapids (G0)\nred: {gain}\n"
            "blue circle: the worst point",
            va="top",
            fontsize=10,
        )
    return fig
