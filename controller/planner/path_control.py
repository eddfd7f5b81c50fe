"""The path control of a move (G61, G61.1, G64 P Q, else the machine file's ``[path]``), and
G64 Q's naive-CAM merge: consecutive straight feed moves at one feed whose end points lie within
Q of one line become that line (LinuxCNC's naive-CAM detector), before corners are blended
(:mod:`~gantry_sim.controller.planner.blend`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from gantry_sim.controller.config import PathSettings
from gantry_sim.controller.moves import Dwell, Linear, PathMove
from gantry_sim.controller.planner.blend_types import Blend

__all__ = [
    "EPS_MM",
    "MAX_MERGE_RUN",
    "Control",
    "Merge",
    "PathEntry",
    "control",
    "extends_run",
    "merge_runs",
    "starts_run",
]

#: Longest run of straight moves the naive-CAM merge considers at once (bounds its cost).
MAX_MERGE_RUN = 256
#: Lengths [mm] at or below this are nothing (zero-length moves, coincident points).
EPS_MM = 1e-9


@dataclass(frozen=True)
class Merge:
    """One G64 Q merge: the program line of the run's first move, the largest distance of the
    run's inner end points from the merged line [mm] (how far the path followed leaves the
    programmed one there), and the Q it was given [mm]."""

    line: int
    deviation_mm: float
    tolerance_mm: float


@dataclass(frozen=True)
class Control:
    """The path control of one move, resolved against the machine file."""

    mode: str
    tolerance_mm: float
    naive_cam_mm: float


def control(move: PathMove, settings: PathSettings) -> Control:
    """``move``'s path control (its own, else the machine file's ``settings``)."""
    pc = getattr(move, "path", None)
    if pc is None:
        return Control(settings.mode, settings.tolerance_mm, settings.naive_cam_tolerance_mm)
    tol = settings.tolerance_mm if pc.tolerance_mm is None else pc.tolerance_mm
    q = settings.naive_cam_tolerance_mm if pc.naive_cam_mm is None else pc.naive_cam_mm
    return Control(pc.mode, tol, q)


@dataclass
class PathEntry:
    """One move on its way into the planner's path (see
    :func:`~gantry_sim.controller.planner.path_stream.path_plan`).

    Attributes:
        move: the move.
        stop_after: an exact stop at the junction after it.
        holds: the dwells at the junction before it (empty: none).
        source: the first and last program move it comes from (indices among the program's
            motions, zero-length ones counted).
        fit: where the move is a piece of a G64 fit
            (:mod:`~gantry_sim.controller.planner.polyline_fit`), its record (its largest
            deviation from the moves it stands for); else None.
    """

    move: PathMove
    stop_after: bool
    holds: list[Dwell]
    source: tuple[int, int]
    fit: Blend | None = None


def merge_runs(
    entries: Iterable[PathEntry], settings: PathSettings, merges: list[Merge]
) -> Iterator[PathEntry]:
    """G64 Q: runs of straight moves whose end points lie within Q of one line, merged into
    that line, greedily from the first move on (LinuxCNC's naive-CAM detector), as the entries
    come: a run ends at a stop, a dwell, a move it cannot take, or :data:`MAX_MERGE_RUN` moves.
    Each merge is appended to ``merges``; a merged entry takes its run's first dwells, its last
    stop and both ends of their sources."""
    it = iter(entries)
    cur = next(it, None)
    while cur is not None:
        run, moves = [cur], [cur.move]
        nxt = next(it, None)
        if starts_run(cur.move, settings):
            while (
                nxt is not None
                and not run[-1].stop_after
                and not nxt.holds
                and extends_run(moves, nxt.move, settings)
            ):
                run.append(nxt)
                moves.append(nxt.move)
                nxt = next(it, None)
        m = cur.move
        if len(run) > 1 and isinstance(m, Linear):
            last = moves[-1]
            q = control(m, settings).naive_cam_mm
            merges.append(Merge(m.line, float(_offsets(moves).max()), q))
            m = replace(m, end=last.end, path=getattr(last, "path", None))
        yield PathEntry(
            m, run[-1].stop_after, cur.holds, (cur.source[0], run[-1].source[1]), cur.fit
        )
        cur = nxt


def starts_run(move: PathMove, settings: PathSettings, c: Control | None = None) -> bool:
    """True when a naive-CAM run may start at ``move``: a straight G64 move with Q > 0;
    ``c``: its :func:`control` under ``settings`` when the caller has it already."""
    if not isinstance(move, Linear):
        return False
    c = control(move, settings) if c is None else c
    return c.mode == "G64" and c.naive_cam_mm > 0


def extends_run(run: Sequence[PathMove], nxt: PathMove, settings: PathSettings) -> bool:
    """True when the naive-CAM run ``run`` (straight G64 moves, the first with Q > 0, not
    broken by a stop or dwell) takes ``nxt`` too: a straight G64 move at the run's feed, the
    run no longer than :data:`MAX_MERGE_RUN`, every end point within the first move's Q of the
    chord from the run's start to ``nxt``'s end. (With :func:`starts_run`, the rule of
    :func:`merge_runs`, which ``sim/duration_bound.py`` follows too.)"""
    first = run[0]
    return (
        len(run) < MAX_MERGE_RUN
        and isinstance(first, Linear)
        and isinstance(nxt, Linear)
        and nxt.feed_mm_per_min == first.feed_mm_per_min
        and control(nxt, settings).mode == "G64"
        and _within([*run, nxt], control(first, settings).naive_cam_mm)
    )


def _within(run: Sequence[PathMove], q_mm: float) -> bool:
    """True when every end point of ``run`` lies within ``q_mm`` of the run's chord."""
    off = _offsets(run)
    return off.size > 0 and bool(np.all(off <= q_mm))


def _offsets(run: Sequence[PathMove]) -> np.ndarray:
    """Distances [mm] of the inner end points of ``run`` from the chord from its start to its
    end (the segment); empty when the chord has no length."""
    a, b = np.asarray(run[0].start, float), np.asarray(run[-1].end, float)
    d = b - a
    n = float(np.linalg.norm(d))
    if n <= EPS_MM:
        return np.empty(0)
    pts = np.array([m.end for m in run[:-1]], dtype=float).reshape(-1, 3) - a
    t = np.clip(pts @ d / (n * n), 0.0, 1.0)
    return np.linalg.norm(pts - t[:, None] * d, axis=1)
