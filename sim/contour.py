"""Contour error: the traced tool tip against the COMMANDED geometry, and its parts.

Every sample k carries the program line being executed (the trajectory's ``line``). Its contour
error is the distance to the nearest point of that line's move(s) and their neighbours in program
order (near a block junction the tool may be just before or after it). Parts (all [um]):

* chord: how far the chords (the planner's vertices) leave the true arcs -- segmentation;
* reference: how far the reference samples leave the geometry -- planning;
* tracking: how far the traced points leave the reference path (a polyline through the reference
  samples, searched near the same instant) -- the servo and the machine.

Statistics cover the feed moves only (G1/G2/G3): rapids are not cutting.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.move_table import MoveTable, box_distance, move_table
from gantry_sim.sim.nearest import nearest_on_moves
from gantry_sim.sim.tracking import max_distance_to_polyline_near

#: reference samples either side searched for the tracking part (50 ms at 1 kHz)
TRACKING_WINDOW = 50
#: path searched beyond a sample's own moves, per mm the tool is from the reference
LAG_REACH = 2.0
#: points along each chord checked for the chord part (fractions of the chord)
CHORD_FRACTIONS = (0.25, 0.5, 0.75)


@dataclass(frozen=True)
class Analysis:
    """Contour error of a trace.

    Attributes:
        err_um: (N,) contour error of each traced point [um].
        nearest: (N, 3) the nearest commanded point to each traced point [mm].
        feed: (N,) True where the sample belongs to a feed move (G1/G2/G3).
        contour_um: {"max", "rms", "p95"} over the feed samples [um].
        parts_um: {"chord_max", "reference_max", "tracking_max"} [um].
        blocks: per feed block in program order: {"line", "kind", "max_error_um", "rms_error_um"}.
    """

    err_um: np.ndarray
    nearest: np.ndarray
    feed: np.ndarray
    contour_um: dict
    parts_um: dict
    blocks: list


#: servo ticks analysed at once (bounds the temporary arrays of the search, ~50 MB)
TICKS_PER_PASS = 1 << 16


def _line_ranges(tab: MoveTable, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample: the first and last index of its line's moves, and whether the line has any."""
    order = np.argsort(tab.line, kind="stable")
    sorted_lines = tab.line[order]
    uniq, first_at = np.unique(sorted_lines, return_index=True)
    last_at = np.concatenate([first_at[1:], [len(sorted_lines)]]) - 1
    pos = np.minimum(np.searchsorted(uniq, lines), max(len(uniq) - 1, 0))
    found = uniq[pos] == lines if len(uniq) else np.zeros(len(lines), dtype=bool)
    return order[first_at][pos], order[last_at][pos], found


def _closest_in_window(
    tab: MoveTable, lo: np.ndarray, hi: np.ndarray, first: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the distance [mm] and nearest point on moves lo..hi (the first one on a tie;
    inf and the point itself when no distance is finite).

    The move ``first`` (one of the window's) is measured first; another move of the window is
    measured only where its box is not farther than that: a move it skips is strictly farther
    than the best, so the result is that of measuring every move of the window.
    """
    counts = hi - lo + 1
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    owner = np.repeat(np.arange(len(pts)), counts)
    move = lo[owner] + np.arange(int(counts.sum())) - starts[owner]
    dist = np.full(len(move), np.inf)
    near = np.empty((len(move), 3))
    primary = starts + (first - lo)
    rest = np.flatnonzero(move != first[owner])
    for sel in (primary, None):
        if sel is None:
            bound = dist[primary][owner[rest]]
            sel = rest[box_distance(tab, move[rest], pts[owner[rest]]) <= bound]
        q = nearest_on_moves(tab, move[sel], pts[owner[sel]])
        d = np.linalg.norm(q - pts[owner[sel]], axis=1)
        dist[sel] = np.where(np.isnan(d), np.inf, d)
        near[sel] = q
    best = np.minimum.reduceat(dist, starts)
    hit = np.flatnonzero((dist == best[owner]) & (dist < np.inf))
    winner = hit[np.concatenate([[True], owner[hit][1:] != owner[hit][:-1]])]
    nearest = np.array(pts, dtype=float, copy=True)
    nearest[owner[winner]] = near[winner]
    return best, nearest


def _walk_out(tab, own, step, reach, pts, best, nearest) -> None:
    """Search the moves past a window, one move further per pass in direction ``step`` (-1 or
    +1) from the window's edge, while the path between the point's own moves (``own``: its
    line's first move for -1, last for +1) and the next move is shorter than ``reach`` [mm]. A
    move is measured only where its box is nearer than the best so far, and counts only where
    it is strictly nearer. Updates ``best`` and ``nearest`` in place."""
    m = len(tab)
    k = own + 2 * step
    live = np.flatnonzero((k >= 0) & (k < m) & (reach > 0))
    while live.size:
        kl, ol = k[live], own[live]
        gap = (
            tab.cum_len[ol] - tab.cum_len[kl + 1]
            if step < 0
            else tab.cum_len[kl] - tab.cum_len[ol + 1]
        )
        live = live[gap < reach[live]]
        if not live.size:
            break
        measure = live[box_distance(tab, k[live], pts[live]) < best[live]]
        if measure.size:
            near = nearest_on_moves(tab, k[measure], pts[measure])
            dist = np.linalg.norm(near - pts[measure], axis=1)
            better = dist < best[measure]
            best[measure[better]] = dist[better]
            nearest[measure[better]] = near[better]
        k[live] += step
        live = live[(k[live] >= 0) & (k[live] < m)]


def distance_to_moves(
    tab: MoveTable, lines: np.ndarray, pts: np.ndarray, reach_mm: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] and nearest commanded point (n, 3) [mm] for points executing ``lines``.

    Searched per point: the moves of its line and one move either side (near a block junction
    the tool may be just before or after it); then, where ``reach_mm`` (n,) is given, every
    further move less than reach_mm of path away from its line's moves (a tool lagging or
    leading by several short moves), counted where strictly nearer. A line no move has is
    compared with every move. Linear in the points; done TICKS_PER_PASS points at a time.
    """
    n, m = len(pts), len(tab)
    if m == 0 or n == 0:
        return np.zeros(n), np.array(pts, dtype=float, copy=True)
    first, last, found = _line_ranges(tab, np.asarray(lines))
    lo = np.where(found, np.maximum(first - 1, 0), 0)
    hi = np.where(found, np.minimum(last + 1, m - 1), m - 1)
    best = np.empty(n)
    nearest = np.empty((n, 3))
    for a in range(0, n, TICKS_PER_PASS):
        sl = slice(a, min(n, a + TICKS_PER_PASS))
        p = np.asarray(pts[sl], dtype=float)
        b, q = _closest_in_window(tab, lo[sl], hi[sl], np.where(found[sl], first[sl], lo[sl]), p)
        if reach_mm is not None:
            reach = np.where(found[sl], reach_mm[sl], 0.0)
            _walk_out(tab, first[sl], -1, reach, p, b, q)
            _walk_out(tab, last[sl], +1, reach, p, b, q)
        best[sl], nearest[sl] = b, q
    return best, nearest


def distance_to_program(
    moves: Sequence[Move], lines: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] and nearest commanded point (n, 3) [mm] for points executing ``lines``
    (see :func:`distance_to_moves`)."""
    return distance_to_moves(move_table(moves), lines, np.asarray(pts, dtype=float))


def _stats(err_um: np.ndarray) -> dict:
    if err_um.size == 0:
        return {"max": 0.0, "rms": 0.0, "p95": 0.0}
    return {
        "max": float(err_um.max()),
        "rms": float(np.sqrt(np.mean(err_um**2))),
        "p95": float(np.percentile(err_um, 95)),
    }


def chord_max_um(
    moves: Sequence[Move], vertices: Sequence[np.ndarray] | None, tab: MoveTable | None = None
) -> float:
    """Largest distance of the chords between each arc's vertices from the arc [um]."""
    if vertices is None:
        return 0.0
    tab = move_table(moves) if tab is None else tab
    pts, owner = [], []
    for j, verts in enumerate(vertices):
        verts = np.asarray(verts, dtype=float).reshape(-1, 3)
        if not tab.arc[j] or len(verts) < 2:
            continue
        pts += [verts[:-1] + f * (verts[1:] - verts[:-1]) for f in CHORD_FRACTIONS]
        owner.append(np.full(len(CHORD_FRACTIONS) * (len(verts) - 1), j))
    if not pts:
        return 0.0
    p = np.concatenate(pts)
    dist = np.linalg.norm(nearest_on_moves(tab, np.concatenate(owner), p) - p, axis=1)
    return float(dist.max()) * UM_PER_MM


def feed_samples(tab: MoveTable, line: np.ndarray) -> np.ndarray:
    """(N,) True where the sample's line is a feed move's (its last move, if it has several)."""
    _, last, found = _line_ranges(tab, line)
    return found & tab.feed[last]


def block_stats(tab: MoveTable, line: np.ndarray, err_um: np.ndarray) -> list[dict]:
    """Per feed line in program order: {"line", "kind", "max_error_um", "rms_error_um"} over
    the samples executing it (0 when none do).

    One stable sort of the samples by line, then one slice per block: linear in the samples.
    The sum of squares is numpy's pairwise sum of each block's samples in time order, so the
    figures are those of a direct ``np.mean`` over the block's samples.
    """
    feed_moves = np.flatnonzero(tab.feed)
    block_lines, first = np.unique(tab.line[feed_moves], return_index=True)
    in_order = np.argsort(first, kind="stable")
    block_lines, kinds = block_lines[in_order], tab.arc[feed_moves[first[in_order]]]
    by_line = np.argsort(line, kind="stable")
    sorted_lines = line[by_line]
    err = err_um[by_line]
    sq = err**2
    lo = np.searchsorted(sorted_lines, block_lines, "left").tolist()
    hi = np.searchsorted(sorted_lines, block_lines, "right").tolist()
    add, biggest = np.add.reduce, np.maximum.reduce
    blocks = []
    for ln, is_arc, a, b in zip(block_lines.tolist(), kinds.tolist(), lo, hi, strict=True):
        if b > a:
            peak, rms = float(biggest(err[a:b])), float(np.sqrt(add(sq[a:b]) / (b - a)))
        else:
            peak = rms = 0.0
        blocks.append(
            {
                "line": ln,
                "kind": "arc" if is_arc else "linear",
                "max_error_um": peak,
                "rms_error_um": rms,
            }
        )
    return blocks


def analyse(
    moves: Sequence[Move],
    line: np.ndarray,
    ref: np.ndarray,
    pos: np.ndarray,
    vertices: Sequence[np.ndarray] | None = None,
) -> Analysis:
    """Contour error of the trace ``pos`` (N, 3) [mm] following ``ref`` (N, 3) [mm].

    Args:
        moves: the interpreter's moves (the commanded geometry).
        line: (N,) program line executed at each sample.
        ref: (N, 3) reference samples [mm] (program coordinates).
        pos: (N, 3) traced tool tip [mm] (program coordinates).
        vertices: per move, the planner's chord vertices (k, 3) [mm], for the chord part.
    """
    line = np.asarray(line)
    tab = move_table(moves)
    feed = feed_samples(tab, line)
    pos = np.asarray(pos, dtype=float)
    lag_mm = LAG_REACH * np.linalg.norm(pos - ref, axis=1)
    dist, nearest = distance_to_moves(tab, line, pos, lag_mm)
    err_um = dist * UM_PER_MM
    ref_um = distance_to_moves(tab, line[feed], np.asarray(ref, dtype=float)[feed])[0] * UM_PER_MM
    parts = {
        "chord_max": chord_max_um(moves, vertices, tab),
        "reference_max": float(ref_um.max()) if ref_um.size else 0.0,
        "tracking_max": max_distance_to_polyline_near(ref, pos, TRACKING_WINDOW, feed) * UM_PER_MM,
    }
    blocks = block_stats(tab, line, err_um)
    for arr in (err_um, nearest, feed):
        arr.setflags(write=False)
    return Analysis(err_um, nearest, feed, _stats(err_um[feed]), parts, blocks)
