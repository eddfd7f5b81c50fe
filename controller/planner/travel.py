"""Refuse programs that would leave the machine's travel, before anything is planned.

Straight moves stay within the box of their end points; an arc or helix additionally reaches the
quadrant points (theta = k * 90 degrees about its centre) its sweep crosses, evaluated exactly on
the arc (slight spirals included) by :func:`gantry_sim.controller.arcs.arc_points`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from gantry_sim.controller.arcs import arc_frame, arc_points
from gantry_sim.controller.config import Travel
from gantry_sim.controller.errors import PlanningError
from gantry_sim.controller.moves import Arc, Linear, Move, Rapid, Spline
from gantry_sim.controller.planes import AXES, PLANE_AXES, Vec3
from gantry_sim.controller.planner.magnitudes import check_magnitudes
from gantry_sim.controller.planner.spline_geometry import spline_extent_points
from gantry_sim.controller.spill import SpilledList

#: G54's origin when the machine file and the options leave it [mm]
_ORIGIN: Vec3 = (0.0, 0.0, 0.0)
#: Rounding allowance at the travel limits [mm].
SLACK_MM = 1e-9


class TravelError(PlanningError):
    """A move leaves the machine's travel. ``offset_mm``: the shift [mm] that would place the
    program within the travel were its moves to follow G54 (None: no shift is suggested);
    the message suggests G54's origin moved by it, ``g54_mm`` + ``offset_mm``, as the
    ``--work-offset`` to give (the option sets G54's origin, it adds to nothing)."""

    def __init__(
        self,
        where: str,
        extent: str,
        offset_mm: Vec3 | None,
        line: int,
        g54_mm: Vec3 = _ORIGIN,
        file: str | None = None,
    ) -> None:
        self._where_and_extent = f"{where}; {extent}"
        self.offset_mm = offset_mm
        message = self._where_and_extent + _suggestion(offset_mm, g54_mm)
        super().__init__(message, file=file, line=line)

    @property
    def where_and_extent(self) -> str:
        """The message without its ``--work-offset`` suggestion (for a generated program,
        placed by options of its own)."""
        return self._where_and_extent

    def offset_does_not_place(self) -> None:
        """The suggested offset was tried and leaves the program outside all the same (it
        sets its origin from where the tool stands, or moves in machine coordinates): the
        message says so instead of suggesting it."""
        self.offset_mm = None
        self.message = self._where_and_extent + (
            "; a work offset does not place it: moved by one, not all of its moves move (a G92, "
            "G10 L20 or G28.3 sets its origin from where the tool stands, which is the work "
            "origin when the program starts; G53 moves stay in machine coordinates)"
        )


def _suggestion(offset_mm: Vec3 | None, g54_mm: Vec3) -> str:
    if offset_mm is None:
        return ""
    shift = ",".join(f"{d:g}" for d in offset_mm)
    origin = ",".join(f"{g + d:g}" for g, d in zip(g54_mm, offset_mm, strict=True))
    now = "" if g54_mm == _ORIGIN else f", where it is {','.join(f'{g:g}' for g in g54_mm)} now"
    return (
        f"; moved by {shift} mm it fits: place it with --work-offset={origin} (G54's origin "
        f"in the machine's work frame{now}; or the machine file's [work] g54_mm)"
    )


def extent_points(move: Move) -> np.ndarray:
    """Points (k, 3) [mm] whose bounding box is the move's true extent."""
    pts = [np.asarray(move.start, dtype=float), np.asarray(move.end, dtype=float)]
    if isinstance(move, Spline):
        return spline_extent_points(move)
    if isinstance(move, Arc):
        frame = arc_frame(move)
        theta0 = frame.theta0_rad
        sweep = frame.sigma * move.angle
        lo, hi = sorted((theta0, theta0 + sweep))
        k0, k1 = math.ceil(lo / (0.5 * math.pi)), math.floor(hi / (0.5 * math.pi))
        if k1 >= k0:
            # the radius changes linearly: the first and last turn hold the extremes
            ks = sorted(set(range(k0, min(k1, k0 + 4) + 1)) | set(range(max(k0, k1 - 4), k1 + 1)))
            angles = np.asarray(ks, dtype=float) * 0.5 * math.pi
            u = np.clip((angles - theta0) / sweep, 0.0, 1.0)
            pts.extend(arc_points(move, u))
    return np.vstack(pts)


def check_travel(moves: Sequence[Move], travel: Travel, g54_mm: Vec3 = _ORIGIN) -> None:
    """Raise :class:`PlanningError` (with the line) for the first move leaving ``travel``;
    ``g54_mm``: G54's origin the program ran with [mm] (its suggestion is that moved).

    Each move's exact extent (:func:`extent_points`) is only computed where a box around it
    (:func:`_may_leave`), made for all moves in a few array operations, reaches past the
    travel: 100,000 arcs inside it are checked in a few tens of milliseconds, not seconds."""
    lo = np.asarray(travel.min_mm, dtype=float)
    hi = np.asarray(travel.max_mm, dtype=float)
    for k in np.flatnonzero(_may_leave(moves, lo, hi)).tolist():
        move = moves[k]
        pts = extent_points(move)
        mins, maxs = pts.min(axis=0), pts.max(axis=0)
        for i in range(3):
            bad = None
            if mins[i] < lo[i] - SLACK_MM:
                bad = mins[i]
            elif maxs[i] > hi[i] + SLACK_MM:
                bad = maxs[i]
            if bad is not None:
                extent, offset_mm = placement(moves, lo, hi)
                raise TravelError(
                    f"{move.kind} move reaches {AXES[i]}{bad:.4f}, outside the machine's travel: "
                    f"{AXES[i]} must stay within {lo[i]:g}..{hi[i]:g} mm (work coordinates)",
                    extent,
                    offset_mm,
                    move.line,
                    g54_mm,
                    move.file,
                )


def check_program_travel(items: Iterable[object], travel: Travel, g54_mm: Vec3 = _ORIGIN) -> None:
    """The checks :func:`~gantry_sim.controller.planner.plan.plan` makes first, alone: every
    move's numbers within their bounds (:func:`~gantry_sim.controller.planner.magnitudes.
    check_magnitudes`), then the whole program within ``travel`` (:func:`check_travel`);
    PlanningError with the line. ``items``: the interpreter's moves and events."""
    moves = SpilledList(
        check_magnitudes(m) for m in items if isinstance(m, Rapid | Linear | Arc | Spline)
    )
    check_travel(moves, travel, g54_mm)


#: Relative and absolute padding [mm] of an arc's box (:func:`_may_leave`) over rounding.
_BOX_PAD_REL, _BOX_PAD_MM = 1e-9, 1e-9
#: Moves whose boxes are made at once.
BOX_MOVES = 4096


def _may_leave(moves: Sequence[Move], lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(len(moves),) bool: False where the move certainly stays within ``lo``..``hi`` [mm]:
    its end points' box, widened for an arc to its centre +- its larger in-plane radius
    (padded, so rounding never makes the box smaller than the arc's exact extent). A spline
    is always checked exactly. Made :data:`BOX_MOVES` moves at a time (a long program's moves
    are read from disk: :class:`~gantry_sim.controller.spill.SpilledList`)."""
    parts = [
        _boxes_leave(moves[k : k + BOX_MOVES], lo, hi) for k in range(0, len(moves), BOX_MOVES)
    ]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=bool)


def _boxes_leave(moves: Sequence[Move], lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """:func:`_may_leave` of a list of moves."""
    n = len(moves)
    if n == 0:
        return np.zeros(0, dtype=bool)
    start = np.array([m.start for m in moves], dtype=float)
    end = np.array([m.end for m in moves], dtype=float)
    box_lo, box_hi = np.minimum(start, end), np.maximum(start, end)
    arcs = [(k, m) for k, m in enumerate(moves) if isinstance(m, Arc)]
    if arcs:
        at = np.array([k for k, _ in arcs])
        sel = [m for _, m in arcs]
        centre = np.array([m.center for m in sel], dtype=float)
        axes = np.array([PLANE_AXES[m.plane][:2] for m in sel], dtype=np.intp)
        rows = np.arange(len(sel))[:, None]
        d = end[at][rows, axes] - centre[rows, axes]
        r = np.maximum(np.array([m.radius for m in sel]), np.hypot(d[:, 0], d[:, 1]))
        r = r * (1.0 + _BOX_PAD_REL) + _BOX_PAD_MM
        c = centre[rows, axes]
        box_lo[at[:, None], axes] = np.minimum(box_lo[at[:, None], axes], c - r[:, None])
        box_hi[at[:, None], axes] = np.maximum(box_hi[at[:, None], axes], c + r[:, None])
    out = np.any(box_lo < lo - SLACK_MM, axis=1) | np.any(box_hi > hi + SLACK_MM, axis=1)
    out[[k for k, m in enumerate(moves) if isinstance(m, Spline)]] = True
    return out


def placement(moves: Sequence[Move], lo: np.ndarray, hi: np.ndarray) -> tuple[str, Vec3 | None]:
    """The program's extent [mm, work frame] in words, and the shift [mm] that would fit it in
    ``lo``..``hi`` (None where it is longer than the travel, which the words then say).

    The first move's start is where the machine rests before the program, which a work offset
    does not move, so it is left out of the extent.
    """
    pts = np.vstack([extent_points(m)[1 if k == 0 else 0 :] for k, m in enumerate(moves)])
    mins, maxs = pts.min(axis=0), pts.max(axis=0)
    extent = ", ".join(f"{AXES[i]} {mins[i]:.4g}..{maxs[i]:.4g}" for i in range(3))
    shift, too_long = [], []
    for i in range(3):
        if maxs[i] - mins[i] > hi[i] - lo[i] + SLACK_MM:
            too_long.append(f"{maxs[i] - mins[i]:.4g} mm in {AXES[i]} (travel {hi[i] - lo[i]:g})")
        d = lo[i] - mins[i] if mins[i] < lo[i] else hi[i] - maxs[i] if maxs[i] > hi[i] else 0.0
        # rounded to um away from the limit it was moved off, so the shifted program fits
        shift.append(math.ceil(d * 1e3) / 1e3 if d > 0 else math.floor(d * 1e3) / 1e3)
    text = f"the program spans {extent} mm (work frame)"
    if too_long:
        return f"{text}; it cannot be placed within the travel: it is {', '.join(too_long)}", None
    return text, (shift[0], shift[1], shift[2])
