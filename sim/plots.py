"""Every figure gantry draws, one idiom: a ``matplotlib.figure.Figure`` on its own Agg canvas.

No pyplot, so no global figure registry and no backend switch: each function builds its
figure, saves the PNG and lets it go. Import this module only where a plot is drawn (it imports
matplotlib, which ``gantry`` must not load at start-up).

* ``gantry run``: :func:`save_path_plot` (path.png), :func:`save_error_plot` (error.png);
* ``gantry ballbar``: :func:`save_polar_plot` (polar.png);
* ``gantry tune``: :func:`save_tune_plot` (tune.png);
* ``gantry sweep``: :func:`save_sweep_plots` (sweep_error_vs_feed.png, sweep_cycle_vs_error.png).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.projections.polar import PolarAxes

from gantry_sim.controller.arcs import arc_points
from gantry_sim.controller.moves import Arc, Move
from gantry_sim.sim.circular.figures import CircleAnalysis
from gantry_sim.sim.circular.summary import polar_conditions_text, polar_figures_text, polar_scale
from gantry_sim.sim.contour import ContourStats
from gantry_sim.sim.trace import Trace

#: resolution of every saved PNG [dots per inch]
DPI = 110


def _figure(figsize: tuple[float, float], dpi: float | None = None) -> Figure:
    """A figure drawn by its own Agg canvas (``dpi`` None: matplotlib's default, 100)."""
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


# ---- gantry run ------------------------------------------------------------------------------


def _geometry_polyline(move: Move) -> np.ndarray:
    """Points (n, 3) [mm] along a move: its end points, or about one per degree of an arc."""
    if isinstance(move, Arc):
        n = max(16, int(np.ceil(move.angle / (2 * np.pi) * 360)))
        return arc_points(move, np.linspace(0.0, 1.0, n + 1))
    return np.array([move.start, move.end], dtype=float)


def _nice(x: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above x (>= 1)."""
    if x <= 1:
        return 1.0
    e = 10 ** np.floor(np.log10(x))
    return float(max(m * e for m in (1, 2, 5) if m * e <= x))


def save_path_plot(
    path: Path, moves: Sequence[Move], trace: Trace, program: str, contour: ContourStats
) -> None:
    """path.png: the commanded geometry, and the traced path with its error magnified, in the
    plane of largest extent.

    Args:
        path: the PNG to write.
        moves: the commanded moves (work coordinates [mm]).
        trace: the run's per-tick arrays.
        program: the program's name (title).
        contour: the run's contour error statistics (title).
    """
    tr = trace
    polys = [(_geometry_polyline(mv), mv.kind) for mv in moves]
    cut = [p for p, kind in polys if kind != "rapid"] or [p for p, _ in polys] or [tr.ref]
    allpts = np.vstack(cut)
    span = allpts.max(axis=0) - allpts.min(axis=0)
    # the two axes of largest extent of the feed moves; XY unless Z clearly matters more
    i, j = sorted(np.argsort(span - np.array([0.0, 0.0, 1e-9]), kind="stable")[-2:])
    extent = float(max(span[i], span[j], 1e-6))
    feed = tr.feed
    emax = float(tr.err_um[feed].max()) / 1000.0 if feed.any() else 0.0
    gain = _nice(0.03 * extent / emax) if emax > 0 else 1.0
    traced = tr.nearest + gain * (tr.pos - tr.nearest)
    traced = np.where(feed[:, None], traced, np.nan)

    fig = _figure((7, 7), dpi=DPI)
    ax = fig.add_subplot()
    labelled: set[str] = set()
    for p, kind in polys:
        rapid = kind == "rapid"
        style: dict[str, Any] = (
            dict(color="0.6", ls="--", lw=0.8) if rapid else dict(color="k", lw=1.0)
        )
        label = "commanded rapid (G0)" if rapid else "commanded feed move"
        ax.plot(p[:, i], p[:, j], **style, label=None if label in labelled else label)
        labelled.add(label)
    ax.plot(traced[:, i], traced[:, j], color="tab:red", lw=0.9, label=f"traced, error x {gain:g}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{'XYZ'[i]} [mm]")
    ax.set_ylabel(f"{'XYZ'[j]} [mm]")
    ce = contour
    ax.set_title(f"{program}: max {ce.max_um:.2f} um, rms {ce.rms_um:.2f} um")
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path)


def save_error_plot(path: Path, trace: Trace, contour: ContourStats) -> None:
    """error.png: contour error along the program (feed moves) and the line being executed.

    Args:
        path: the PNG to write.
        trace: the run's per-tick arrays.
        contour: the run's contour error statistics (title, max line).
    """
    tr = trace
    err = np.where(tr.feed, tr.err_um, np.nan)
    fig = _figure((9, 5), dpi=DPI)
    ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    ax1.plot(tr.t, err, color="tab:red", lw=0.8)
    ax1.set_ylabel("contour error [um]")
    ce = contour
    ax1.axhline(ce.max_um, color="0.5", lw=0.6, ls=":")
    ax1.set_title(f"max {ce.max_um:.2f} um, p95 {ce.p95_um:.2f} um, rms {ce.rms_um:.2f} um")
    ax2.step(tr.t, tr.line, where="post", color="k", lw=0.8)
    ax2.set_ylabel("line")
    ax2.set_xlabel("time [s]")
    fig.savefig(path)


# ---- gantry ballbar --------------------------------------------------------------------------


def save_polar_plot(
    path: Path, ccw: CircleAnalysis, cw: CircleAnalysis, summary: Mapping[str, Any]
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


class TunedRadius(Protocol):
    """What the tune plot reads of one radius's answer (sim.circular.tune.TuneRow has it; named
    structurally so that this module does not import the tune search, which runs simulations)."""

    @property
    def radius_mm(self) -> float: ...
    @property
    def max_feed_mm_per_min(self) -> float | None: ...
    @property
    def tried(self) -> tuple[tuple[float, float], ...]: ...


def save_tune_plot(
    path: Path, rows: Sequence[TunedRadius], tolerance_um: float, plane: str
) -> None:
    """tune.png: max feed against radius (left); each simulated (feed, error) per radius (right).

    Args:
        path: the PNG to write.
        rows: one answer per radius.
        tolerance_um: the contour tolerance searched for [um].
        plane: the circles' plane ("XY", "XZ" or "YZ").
    """
    fig = _figure((11, 4.5))
    ax1, ax2 = fig.subplots(1, 2)
    ok = [r for r in rows if r.max_feed_mm_per_min is not None]
    ax1.plot([r.radius_mm for r in ok], [r.max_feed_mm_per_min for r in ok], "o-")
    for r in ok:
        ax1.annotate(
            f"{r.max_feed_mm_per_min:.0f}",
            (r.radius_mm, r.max_feed_mm_per_min),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=8,
        )
    ax1.set_xlabel("circle radius [mm]")
    ax1.set_ylabel("max feed [mm/min]")
    ax1.set_title(f"highest feed within {tolerance_um:g} um ({plane})")
    ax1.grid(alpha=0.3)
    for r in rows:
        pts = sorted(r.tried)
        ax2.plot(
            [p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=f"R {r.radius_mm:g} mm"
        )
    ax2.axhline(tolerance_um, color="k", ls="--", lw=0.8, label="tolerance")
    ax2.set_xlabel("programmed feed [mm/min]")
    ax2.set_ylabel("circle max contour error [um]")
    ax2.set_title("every simulation of the search")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)


# ---- gantry sweep ----------------------------------------------------------------------------


def save_sweep_plots(rows: Sequence[Mapping[str, Any]], out_dir: Path) -> None:
    """sweep_error_vs_feed.png and sweep_cycle_vs_error.png in ``out_dir``, one series per
    (accel, jerk) pair, from the sweep.csv rows whose status is "ok"."""
    ok = [r for r in rows if r["status"] == "ok"]
    combos = sorted(
        {(r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) for r in ok},
        key=lambda c: (c[0] or 0.0, c[1] or 0.0),
    )

    def label(c: tuple[float | None, float | None]) -> str:
        a = "machine file" if c[0] is None else f"{c[0]:g} mm/s^2"
        j = "machine file" if c[1] is None else f"{c[1]:g} mm/s^3"
        return f"accel {a}, jerk {j}"

    fig = _figure((7, 4.5))
    ax = fig.add_subplot()
    for c in combos:
        pts = sorted(
            (r["feed_override_pct"], r["max_error_um"])
            for r in ok
            if (r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) == c
        )
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", ms=4, label=label(c))
    ax.set_xlabel("feed override [%]")
    ax.set_ylabel("max contour error [um]")
    ax.set_title("contour error against feed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "sweep_error_vs_feed.png", dpi=DPI)

    fig = _figure((7, 4.5))
    ax = fig.add_subplot()
    for c in combos:
        sel = [r for r in ok if (r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"]) == c]
        ax.scatter(
            [r["max_error_um"] for r in sel], [r["cycle_time_s"] for r in sel], s=18, label=label(c)
        )
        for r in sel:
            ax.annotate(
                f"{r['feed_override_pct']:g}%",
                (r["max_error_um"], r["cycle_time_s"]),
                textcoords="offset points",
                xytext=(3, 3),
                fontsize=7,
            )
    ax.set_xlabel("max contour error [um]")
    ax.set_ylabel("cycle time [s]")
    ax.set_title("cycle time against contour error (lower left is better)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "sweep_cycle_vs_error.png", dpi=DPI)
