"""``gantry tune`` and ``gantry sweep`` figures: every point simulated, failed or faulted ones
marked, on honest scales (value axes start at 0; the spread of the values is printed, so a
0.2 um spread is not drawn as if it filled the plot).

Import only where a plot is drawn (matplotlib).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from gantry_sim.sim.plots import DPI, _figure, quiet

if TYPE_CHECKING:  # matplotlib is imported through sim.plots first (it quiets its logging)
    from matplotlib.figure import Figure


class TunedRadius(Protocol):
    """What the tune plot reads of one radius's answer (sim.circular.tune.TuneRow has it; named
    structurally so that this module does not import the tune search, which runs simulations)."""

    @property
    def radius_mm(self) -> float: ...
    @property
    def max_feed_mm_per_min(self) -> float | None: ...
    @property
    def circle_feed_mm_per_min(self) -> float: ...
    @property
    def limited_by(self) -> str: ...
    @property
    def tried(self) -> tuple[tuple[float, float], ...]: ...
    @property
    def run_feeds(self) -> tuple[float, ...]: ...


def _spread(values: Sequence[float], unit: str) -> str:
    vals = [v for v in values if math.isfinite(v)]
    if not vals:
        return "no value"
    return f"{min(vals):.3g}..{max(vals):.3g} {unit} (spread {max(vals) - min(vals):.3g} {unit})"


@quiet
def save_tune_plot(
    path: Path, rows: Sequence[TunedRadius], tolerance_um: float, plane: str
) -> None:
    """Write :func:`tune_figure` to ``path`` (tune.png)."""
    tune_figure(rows, tolerance_um, plane).savefig(path, dpi=DPI)


def tune_figure(rows: Sequence[TunedRadius], tolerance_um: float, plane: str) -> Figure:
    """tune.png. Left: per radius, the feed the circle actually ran at (the planner's path
    speed) at the highest passing programmed feed, and that programmed feed; unreachable radii
    marked at 0. Right: every simulation of the search, (feed run, max error), passes filled,
    failures hollow, the tolerance dashed."""
    fig = _figure((12, 4.8))
    ax1, ax2 = fig.subplots(1, 2)
    ok = [r for r in rows if r.max_feed_mm_per_min is not None]
    bad = [r for r in rows if r.max_feed_mm_per_min is None]
    ax1.plot(
        [r.radius_mm for r in ok],
        [r.circle_feed_mm_per_min for r in ok],
        "o-",
        label="feed the circle ran at",
    )
    ax1.plot(
        [r.radius_mm for r in ok],
        [r.max_feed_mm_per_min for r in ok],
        "s--",
        mfc="none",
        color="0.5",
        label="programmed F (highest passing)",
    )
    for r in ok:
        note = " (machine limits)" if r.limited_by == "machine_limits" else ""
        ax1.annotate(
            f"{r.circle_feed_mm_per_min:.0f}{note}",
            (r.radius_mm, r.circle_feed_mm_per_min),
            textcoords="offset points",
            xytext=(4, -12),
            fontsize=8,
        )
    if bad:
        ax1.plot([r.radius_mm for r in bad], [0] * len(bad), "x", color="tab:red", ms=9, mew=2)
        for r in bad:
            ax1.annotate("unreachable", (r.radius_mm, 0), textcoords="offset points", xytext=(4, 6))
    ax1.set_ylim(bottom=0)
    ax1.set_xlabel("circle radius [mm]")
    ax1.set_ylabel("feed [mm/min]")
    ax1.set_title(f"highest feed within {tolerance_um:g} um ({plane})", fontsize=10)
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8)
    errors: list[float] = []
    for r in rows:
        feeds = list(r.run_feeds) if len(r.run_feeds) == len(r.tried) else [f for f, _ in r.tried]
        pts = sorted(zip(feeds, (e for _, e in r.tried), strict=True))
        errors += [e for _, e in pts]
        (ln,) = ax2.plot([p[0] for p in pts], [p[1] for p in pts], "-", lw=0.8)
        c = ln.get_color()
        passed = [p for p in pts if p[1] <= tolerance_um]
        failed = [p for p in pts if p[1] > tolerance_um]
        ax2.plot([p[0] for p in passed], [p[1] for p in passed], "o", color=c, ms=4)
        ax2.plot([p[0] for p in failed], [p[1] for p in failed], "o", mfc="none", color=c, ms=5)
        ln.set_label(f"R {r.radius_mm:g} mm")
    ax2.axhline(tolerance_um, color="k", ls="--", lw=0.8, label="tolerance")
    ax2.set_xlim(left=0, right=1.1 * max([f for r in rows for f in r.run_feeds] or [1.0]))
    _from_zero(ax2.set_ylim, [*errors, tolerance_um])
    ax2.set_xlabel("feed the circle ran at [mm/min]")
    ax2.set_ylabel("circle max contour error [um]")
    ax2.set_title(
        f"every simulation (filled: passed, hollow: failed)\nerror {_spread(errors, 'um')}",
        fontsize=9,
    )
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _from_zero(set_lim: Any, values: Sequence[float]) -> None:
    """An axis from 0 to 10 % above the largest value (so no point sits on the frame)."""
    vals = [v for v in values if math.isfinite(v)]
    set_lim(0, 1.1 * max(vals) if vals and max(vals) > 0 else 1.0)


def _combo(r: Mapping[str, Any]) -> tuple[float | None, float | None]:
    return (r["max_accel_mm_per_s2"], r["max_jerk_mm_per_s3"])


def _label(c: tuple[float | None, float | None]) -> str:
    a = "machine file" if c[0] is None else f"{c[0]:g} mm/s^2"
    j = "machine file" if c[1] is None else f"{c[1]:g} mm/s^3"
    return f"accel {a}, jerk {j}"


def _finish(fig: Figure, ax: Any, bottom: float) -> None:
    """Grid, legend (when something is labelled) and layout above the faulted-points note."""
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout(rect=(0, bottom, 1, 1))


def _faulted_note(fig: Figure, faulted: Sequence[Mapping[str, Any]]) -> float:
    """List the faulted points under the plot; returns the figure fraction it takes."""
    if not faulted:
        return 0.0
    lines = [
        f"{r['feed_override_pct']:g}%, {_label(_combo(r))}: {r['status']}"[:110]
        for r in faulted[:4]
    ]
    if len(faulted) > 4:
        lines.append(f"... {len(faulted) - 4} more (sweep.csv's status column)")
    text = f"faulted ({len(faulted)}), no result: " + "\n".join(lines)
    fig.text(0.01, 0.01, text, va="bottom", fontsize=7, color="tab:red")
    return 0.035 * (len(lines) + 1) + 0.01


def save_sweep_plots(rows: Sequence[Mapping[str, Any]], out_dir: Path) -> None:
    """Write :func:`sweep_figures` as sweep_error_vs_feed.png and sweep_cycle_vs_error.png."""
    by_feed, by_error = sweep_figures(rows)
    by_feed.savefig(out_dir / "sweep_error_vs_feed.png", dpi=DPI)
    by_error.savefig(out_dir / "sweep_cycle_vs_error.png", dpi=DPI)


def sweep_figures(rows: Sequence[Mapping[str, Any]]) -> tuple[Figure, Figure]:
    """(error against feed, cycle time against error): every sweep.csv
    row, one series per (accel, jerk) pair; faulted rows (status not "ok") as red x on the
    feed axis at 0 um and listed; both value axes start at 0 and the titles give the spread."""
    ok = [r for r in rows if r["status"] == "ok"]
    faulted = [r for r in rows if r["status"] != "ok"]
    combos = sorted({_combo(r) for r in rows}, key=lambda c: (c[0] or 0.0, c[1] or 0.0))
    errors = [r["max_error_um"] for r in ok]
    cycles = [r["cycle_time_s"] for r in ok]

    fig = _figure((7.5, 4.8))
    ax = fig.add_subplot()
    for c in combos:
        pts = sorted((r["feed_override_pct"], r["max_error_um"]) for r in ok if _combo(r) == c)
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", ms=4, label=_label(c))
    if faulted:
        ax.plot(
            [r["feed_override_pct"] for r in faulted],
            [0.0] * len(faulted),
            "x",
            color="tab:red",
            ms=9,
            mew=2,
            clip_on=False,
            label="faulted (no result)",
        )
    bottom = _faulted_note(fig, faulted)
    _from_zero(ax.set_ylim, errors)
    ax.set_xlabel("feed override [%]")
    ax.set_ylabel("max contour error [um]")
    ax.set_title(
        f"contour error against feed: {len(ok)} ok, {len(faulted)} faulted\n"
        f"error {_spread(errors, 'um')}",
        fontsize=9,
    )
    _finish(fig, ax, bottom)
    by_feed = fig

    fig = _figure((7.5, 4.8))
    ax = fig.add_subplot()
    for c in combos:
        sel = [r for r in ok if _combo(r) == c]
        if not sel:
            continue
        ax.scatter(
            [r["max_error_um"] for r in sel],
            [r["cycle_time_s"] for r in sel],
            s=18,
            label=_label(c),
        )
        for r in sel:
            ax.annotate(
                f"{r['feed_override_pct']:g}%",
                (r["max_error_um"], r["cycle_time_s"]),
                textcoords="offset points",
                xytext=(3, 3),
                fontsize=7,
            )
    bottom = _faulted_note(fig, faulted)
    _from_zero(ax.set_xlim, errors)
    _from_zero(ax.set_ylim, cycles)
    ax.set_xlabel("max contour error [um]")
    ax.set_ylabel("cycle time [s]")
    ax.set_title(
        f"cycle time against contour error (lower left is better); {len(faulted)} faulted\n"
        f"error {_spread(errors, 'um')}; cycle {_spread(cycles, 's')}",
        fontsize=9,
    )
    _finish(fig, ax, bottom)
    return by_feed, fig
