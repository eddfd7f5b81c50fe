"""``gantry run``'s error.png: the contour error along the program as a per-bin band (readable
and quick at 100,000 blocks), the worst blocks labelled with their line, every gate drawn.

Import only where a plot is drawn (matplotlib).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.sim.contour import ContourStats
from gantry_sim.sim.gates import Gates
from gantry_sim.sim.plots import DPI, _figure, quiet
from gantry_sim.sim.trace import Trace

if TYPE_CHECKING:  # matplotlib is imported through sim.plots first (it quiets its logging)
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: time bins of error.png's envelope
ENVELOPE_BINS = 1500
#: worst blocks labelled on error.png
WORST_LABELLED = 5


def _envelope(
    t: np.ndarray, v: np.ndarray, bins: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per time bin: (bin centre [s], min, max, root mean square) of ``v``, NaN where the bin
    holds no value."""
    edges = np.linspace(t[0], t[-1] if t[-1] > t[0] else t[0] + 1.0, bins + 1)
    idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, bins - 1)
    lo = np.full(bins, np.inf)
    hi = np.full(bins, -np.inf)
    ok = np.isfinite(v)
    np.minimum.at(lo, idx[ok], v[ok])
    np.maximum.at(hi, idx[ok], v[ok])
    count = np.bincount(idx[ok], minlength=bins)
    sq = np.bincount(idx[ok], weights=v[ok] ** 2, minlength=bins)
    empty = count == 0
    lo[empty] = np.nan
    hi[empty] = np.nan
    rms = np.sqrt(sq / np.maximum(count, 1))
    rms[empty] = np.nan
    return 0.5 * (edges[:-1] + edges[1:]), lo, hi, rms


def _draw_gates(ax: Axes, gates: Gates, tr: Trace, kinds: Mapping[int, str]) -> None:
    for lim in gates.errors:
        if lim.lines is None and lim.kind is None:
            ax.axhline(lim.limit_um, color="tab:red", ls="--", lw=1.0, label=lim.label())
            continue
        on = tr.feed.copy()
        if lim.lines is not None:
            on &= (tr.line >= lim.lines[0]) & (tr.line <= lim.lines[1])
        if lim.kind is not None:
            uniq, inv = np.unique(tr.line, return_inverse=True)
            on &= np.array([kinds.get(int(v)) == lim.kind for v in uniq], dtype=bool)[inv]
        tc, _, hi, _ = _envelope(tr.t, np.where(on, lim.limit_um, np.nan), ENVELOPE_BINS)
        ax.plot(tc, hi, ls="--", lw=1.2, label=lim.label())


@quiet
def save_error_plot(
    path: Path | IO[bytes],
    trace: Trace,
    contour: ContourStats,
    gates: Gates | None = None,
    moves: Sequence[Move] = (),
    kinds: Mapping[int, str] | None = None,
) -> None:
    """Write :func:`error_figure` to ``path`` (error.png)."""
    error_figure(trace, contour, gates, moves, kinds).savefig(path)


def error_figure(
    trace: Trace,
    contour: ContourStats,
    gates: Gates | None = None,
    moves: Sequence[Move] = (),
    kinds: Mapping[int, str] | None = None,
) -> Figure:
    """error.png: the contour error along the program as a per-bin min..max band and the RMS
    per bin (feed moves), the worst blocks labelled with their line, every error gate drawn; below, the
    program line executed (its envelope). A gate on a kind of move reads the kinds of the lines
    from ``kinds`` ({line: kind}, sim.gates.Gates.line_kinds), or from ``moves`` when None."""
    tr = trace
    err = np.where(tr.feed, tr.err_um, np.nan)
    fig = _figure((12, 5.5), dpi=DPI)
    ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    fig.subplots_adjust(left=0.07, right=0.76)
    if tr.t.size:
        tc, lo, hi, rms = _envelope(tr.t, err, ENVELOPE_BINS)
        ax1.fill_between(
            tc,
            lo,
            hi,
            color="tab:red",
            alpha=0.35,
            lw=0,
            step="mid",
            label="contour error, min..max",
        )
        ax1.step(tc, hi, where="mid", color="tab:red", lw=0.7)
        ax1.step(tc, rms, where="mid", color="darkred", lw=0.8, label="rms per bin")
        _label_worst(ax1, tr)
        tc, lo, hi, _ = _envelope(tr.t, tr.line.astype(float), ENVELOPE_BINS)
        ax2.fill_between(tc, lo, hi, color="k", step="mid", lw=0.8)
    if gates is not None:
        _draw_gates(ax1, gates, tr, gates.line_kinds(moves) if kinds is None else kinds)
    ax1.set_ylim(0, max(ax1.get_ylim()[1], 1e-3) * 1.12)  # room for the labels
    ax1.set_ylabel("contour error [um]")
    ax1.grid(alpha=0.25)
    ax1.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ce = contour
    ax1.set_title(
        f"max {ce.max_um:.2f} um, p95 {ce.p95_um:.2f} um, rms {ce.rms_um:.2f} um "
        f"(feed moves; per-bin min..max over {ENVELOPE_BINS} time bins)",
        fontsize=10,
    )
    from matplotlib.ticker import MaxNLocator

    ax2.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax2.set_ylabel("line")
    ax2.set_xlabel("time [s]")
    return fig


def _label_worst(ax: Axes, tr: Trace) -> None:
    """Label the :data:`WORST_LABELLED` blocks with the largest max error at their peaks."""
    feed = np.flatnonzero(tr.feed)
    if feed.size == 0:
        return
    lines = tr.line[feed]
    err = tr.err_um[feed]
    top = worst_lines(lines, err, WORST_LABELLED)
    top = top[np.argsort(tr.t[feed[top]], kind="stable")]  # in time order: neighbours stagger
    for rank, k in enumerate(top):
        x, y = float(tr.t[feed[k]]), float(err[k])
        ax.plot(x, y, "v", color="tab:blue", ms=5)
        ax.annotate(
            f"line {int(lines[k])}",
            (x, y),
            textcoords="offset points",
            xytext=(-3 if rank % 2 else 3, 6 + 10 * (rank % 3)),
            ha="right" if rank % 2 else "left",
            fontsize=7,
            color="tab:blue",
        )


def worst_lines(lines: np.ndarray, err: np.ndarray, count: int) -> np.ndarray:
    """Indices of the samples that peak the ``count`` lines with the largest error: per line its
    largest ``err`` (the earliest sample of equal ones), the lines by that peak (the lower line
    first among equal peaks), the largest first.

    Only the samples near the top are sorted: the ``m`` largest errors (``np.argpartition``,
    m = 64, 256, ... until enough lines peak above the m-th largest, so that no sample left out
    can change the answer); sorting every sample by line took 0.06 s of error.png's 0.25 s at
    348,317 ticks. NaN errors (none in a run) take the full sort."""
    n = err.size
    if n == 0 or count <= 0:
        return np.zeros(0, dtype=np.intp)
    if np.isnan(err).any():
        m = n
    else:
        m = min(n, 64)
    while True:
        cand = np.arange(n) if m >= n else np.argpartition(-err, m - 1)[:m]
        order = cand[np.lexsort((cand, lines[cand], -err[cand]))]  # by error, line, sample
        _, first = np.unique(lines[order], return_index=True)  # each line's first: its peak
        picked = order[np.sort(first)[:count]]
        if m >= n or (picked.size == count and err[picked[-1]] > err[cand].min()):
            return picked
        m *= 4
