"""A G2 transition (:class:`~gantry_sim.controller.moves.Transition`) as the planner takes a curve:
its chord vertices, points, derivatives and the deviation of a piece from it, in closed form on
the quintic (:mod:`~gantry_sim.controller.quintic_curve`).

The planner's parameter u on a transition is the Bezier parameter t itself, not the arc-length
fraction (as on a spiral arc, whose u is its sweep fraction): points and derivatives are then
one small matrix product each, and only the profile's own knots need the arc length inverted.
The planner corrects for |dp/du| varying along the curve (``ArcGeometry.speed_rate``; on these
curves it varies by a few per cent).

Chords: n of equal steps in t, the fewest whose sagitta stays within the chord tolerance: a chord
spanning the arc length c of a curve whose curvature is at most k lies within k c^2 / 8 of it
(the circle of curvature k is the worst case), and a step 1/n of t spans at most |C'|_max / n of
arc length, so n = ceil(|C'|_max sqrt(k_max / (8 tol))) with the curve's bounds
(:attr:`~gantry_sim.controller.quintic_curve.QuinticCurve.bounds`, ``speed_max``); method
"fixed" also takes at least floor(L / segment_length_mm) chords, and a chord turns by 90
degrees at most, as on arcs. Every vertex lies on the curve (the ends exactly).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.moves import Transition
from gantry_sim.controller.quintic_curve import (
    WINDOW_SEED_SAMPLES,
    derivative_coefficients,
    end_frames,
    evaluate,
    lengths_at,
    nearest_parameters,
    packed_rows,
    parameters_at,
    points_on_rows,
    row_cells,
    row_coefficients,
)

#: Largest turn of one chord [rad] (as segment.MAX_CHORD_SWEEP_RAD on arcs).
MAX_CHORD_SWEEP_RAD = 0.5 * math.pi


def transition_chords(
    move: Transition, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> int:
    """Number of chords of ``move``, equal steps of its parameter (module docstring)."""
    if method not in ("chord", "fixed"):
        raise ConfigError(f"segmentation method {method!r} is unknown; valid: chord, fixed")
    if not (chord_tolerance_mm > 0 and segment_length_mm > 0):
        raise ConfigError("chord_tolerance_mm and segment_length_mm must be > 0")
    curve = move.curve
    k, reach = curve.bounds[0], curve.speed_max
    n = math.ceil(reach * math.sqrt(k / (8.0 * chord_tolerance_mm)) - 1e-12)
    if method == "fixed":
        n = max(n, math.floor(curve.length_mm / segment_length_mm))
    return max(n, math.ceil(k * reach / MAX_CHORD_SWEEP_RAD - 1e-12), 1)


def transition_vertices(
    move: Transition, method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> np.ndarray:
    """Chord vertices (n + 1, 3) [mm] of ``move`` at equal steps of t (read-only; the ends
    exactly)."""
    return transition_vertices_many([move], method, chord_tolerance_mm, segment_length_mm)[0]


def transition_deviation(move: Transition, q: np.ndarray, t_hint: float, window: float) -> float:
    """Largest distance [mm] of points ``q`` (k, 3) from the curve, searched within ``window``
    of the parameter ``t_hint`` (the nearest of a few samples there, then Newton steps)."""
    q = np.asarray(q, dtype=float).reshape(1, -1, 3)
    return float(transition_deviation_many([move], q, [t_hint], [window])[0])


def transition_deviation_many(
    moves: Sequence[Transition],
    q: np.ndarray,
    t_hint: Sequence[float],
    window: Sequence[float],
    t_next: Sequence[float] | None = None,
) -> np.ndarray:
    """:func:`transition_deviation` of the points ``q[i]`` (k, 3) from each curve at once ->
    (m,) [mm]. With ``t_next`` (the parameter of the piece's other vertex, its points evenly
    spread in time between the two), each point's search starts where its share of the
    piece puts it, instead of from samples."""
    hint, half = np.array(t_hint, dtype=float), np.array(window, dtype=float)
    rows = packed_rows([m.row for m in moves])
    coef = row_coefficients(rows)
    if t_next is None:
        lo, hi = np.maximum(hint - half, 0.0), np.minimum(hint + half, 1.0)
        t = nearest_parameters(coef, q, lo, hi, WINDOW_SEED_SAMPLES)
    else:
        nxt = np.array(t_next, dtype=float)
        lo = np.maximum(np.minimum(hint, nxt) - half, 0.0)
        hi = np.minimum(np.maximum(hint, nxt) + half, 1.0)
        share = np.linspace(0.0, 1.0, q.shape[1])
        start = hint[:, None] + (nxt - hint)[:, None] * share[None, :]
        t = nearest_parameters(coef, q, lo, hi, t_start=start)
    off = points_on_rows(rows, t) - q
    return np.sqrt((off * off).sum(axis=2)).max(axis=1)


def _rows(moves: Sequence[Transition], values: Sequence[np.ndarray]) -> tuple[np.ndarray, ...]:
    """Per point of ``values[i]`` (on ``moves[i]``), stacked: its curve's coefficients
    (N, 6, 3), first derivative's coefficients (N, 5, 3) and cell lengths (N, CELLS + 1), and
    the value (N,)."""
    rows = packed_rows([m.row for m in moves])
    counts = [np.size(v) for v in values]
    coef = np.repeat(row_coefficients(rows), counts, 0)
    cum = np.repeat(row_cells(rows), counts, 0)
    flat = [np.asarray(v, dtype=float).ravel() for v in values]
    v = np.concatenate(flat) if flat else np.zeros(0)
    return coef, derivative_coefficients(coef, 1), cum, v


def transition_derivatives_many(
    moves: Sequence[Transition], us: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """dp/du and d2p/du2 (N, 3) [mm] of each curve at its parameters ``us[i]``, stacked: the
    numbers of ``move.curve.derivatives``, for all at once."""
    coef, coef1, _, u = _rows(moves, us)
    t = u[:, None]
    return evaluate(coef1, t)[:, 0], evaluate(derivative_coefficients(coef, 2), t)[:, 0]


def transition_lengths_many(moves: Sequence[Transition], us: Sequence[np.ndarray]) -> np.ndarray:
    """Arc length [mm] (N,) from each curve's start to its parameters ``us[i]``, stacked: the
    numbers of ``move.curve.s_of_t``, for all at once."""
    _, coef1, cum, u = _rows(moves, us)
    return lengths_at(coef1, cum, u)


def transition_parameters_many(
    moves: Sequence[Transition], s_mm: Sequence[np.ndarray]
) -> np.ndarray:
    """The parameters (N,) where each curve has run ``s_mm[i]`` [mm], stacked: the numbers of
    ``move.curve.t_of_s``, for all at once."""
    _, coef1, cum, s = _rows(moves, s_mm)
    return parameters_at(coef1, cum, s)


def transition_speed_rates_many(
    moves: Sequence[Transition], us: Sequence[np.ndarray]
) -> np.ndarray:
    """d|dp/du|/du [mm] (N,) of each curve at its parameters ``us[i]``, stacked (the numbers
    of ``move.curve.speed_rate``)."""
    d1, d2 = transition_derivatives_many(moves, us)
    return (d1[:, 0] * d2[:, 0] + d1[:, 1] * d2[:, 1] + d1[:, 2] * d2[:, 2]) / np.sqrt(
        d1[:, 0] * d1[:, 0] + d1[:, 1] * d1[:, 1] + d1[:, 2] * d1[:, 2]
    )


def transition_end_frames_many(moves: Sequence[Transition]) -> np.ndarray:
    """(T_start, k_start, T_end, k_end) (m, 4, 3) of each move's curve, in one batch (the
    numbers of ``move.curve.end_frames``)."""
    coef = row_coefficients(packed_rows([m.row for m in moves]))
    return end_frames(coef)


def transition_vertices_many(
    moves: Sequence[Transition], method: str, chord_tolerance_mm: float, segment_length_mm: float
) -> list[np.ndarray]:
    """:func:`transition_vertices` of each move, the points of all of them in one batch."""
    counts = [transition_chords(m, method, chord_tolerance_mm, segment_length_mm) for m in moves]
    us = [np.arange(n + 1) / n for n in counts]
    coef, _, _, u = _rows(moves, us)
    pts = evaluate(coef, u[:, None])[:, 0]
    out = []
    lo = 0
    for m, n in zip(moves, counts, strict=True):
        verts = pts[lo : lo + n + 1]
        verts[0], verts[-1] = m.start, m.end
        verts.setflags(write=False)
        out.append(verts)
        lo += n + 1
    return out
