"""Distance from points to the COMMANDED program near the move each point is executing: the
search behind the contour error (sim/contour.py), linear in the points.

Per point: its own moves and one move either side (near a block junction the tool may be just
before or after it), then -- where a reach is given -- every further move less than that reach
of path away from its own moves (a tool lagging or leading by several short moves), counted
where strictly nearer. Its own moves: those it is executing, where the plan says which
(``window``: Plan.move_sources, sampled as Trajectory.source), else every move of its line (a
line may hold hundreds: an O-word loop, a canned cycle). Each point's result depends on that
point, its own moves and its reach only: a trace may be cut anywhere, in any order, with
identical numbers.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.moves import Move
from gantry_sim.sim.move_table import MoveTable, box_distance, move_table
from gantry_sim.sim.nearest import nearest_on_moves

#: servo ticks analysed at once (bounds the temporary arrays of the search, ~50 MB)
TICKS_PER_PASS = 1 << 16
#: (point, move) pairs measured at once: a pass holds fewer ticks where their lines have many
#: moves (an O-word loop or a canned cycle on one line, or a dwell's line, which has none and
#: is compared with every move), so the temporary arrays stay near 100 MB. Before, 400 moves
#: on one line took 2.8 GB and a 30 s dwell beside 200 moves 1.1 GB.
PAIRS_PER_PASS = 1 << 19


def line_ranges(tab: MoveTable, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample: the first and last index of its line's moves, and whether the line has any."""
    order = np.argsort(tab.line, kind="stable")
    sorted_lines = tab.line[order]
    uniq, first_at = np.unique(sorted_lines, return_index=True)
    last_at = np.concatenate([first_at[1:], [len(sorted_lines)]]) - 1
    pos = np.minimum(np.searchsorted(uniq, lines), max(len(uniq) - 1, 0))
    found = uniq[pos] == lines if len(uniq) else np.zeros(len(lines), dtype=bool)
    return order[first_at][pos], order[last_at][pos], found


#: window positions searched one at a time (a vectorised pass over the points whose window
#: reaches that far); a point whose window is longer (a line without moves, compared with every
#: move) is searched pair by pair (:func:`_closest_in_long_window`)
SLOTS = 8


def _closest_in_window(
    tab: MoveTable, lo: np.ndarray, hi: np.ndarray, first: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the distance [mm] and nearest point on moves lo..hi (the first one in the
    window on a tie; inf and the point itself when no distance is finite).

    One move of the window is measured first: the one whose box is nearest (``first``, one of
    the window's, where its box is among the nearest; else the first such): a point inside
    its own move's box measures that move first, wherever it lies in the window (a reference
    point on an arc measures the arc, not the transition the window starts with). Another
    move of the window is measured only where its box is not farther than the nearest so far:
    a move it skips is strictly farther, so the result is that of measuring every move of the
    window (tests/test_window_search.py). Windows of up to :data:`SLOTS` moves go position by
    position, each a vectorised pass over the points whose window reaches it (no (point,
    move) pairs laid out: the three searches of each range of a streamed run took 0.32-0.39 s
    of CPU instead of 0.43-0.45 on 10,000 polyline blocks, 0.52-0.60 instead of 0.57-0.64 on
    1,000 tangent arcs, the same numbers bit for bit); longer ones pair by pair.
    """
    n = len(pts)
    count = hi - lo + 1
    long = np.flatnonzero(count > SLOTS)
    if long.size == n:
        return _closest_in_long_window(tab, lo, hi, first, pts)
    best = np.full(n, np.inf)
    nearest = np.array(pts, dtype=float, copy=True)
    if long.size:
        best[long], nearest[long] = _closest_in_long_window(
            tab, lo[long], hi[long], first[long], nearest[long]
        )
    short = np.flatnonzero(count <= SLOTS)
    n_short, cnt, lo_s = len(short), count[short], lo[short]
    own = first[short] - lo_s
    p = np.take(pts, short, axis=0)
    # per window position, each point's box distance (NaN, and a position past its window,
    # count as inf); the nearest box, the own move's where it is among the nearest
    boxes: list[np.ndarray] = []
    lowest, nearest_at, own_box = np.full(n_short, np.inf), np.zeros(n_short, np.intp), None
    for k in range(int(cnt.max(initial=0))):
        on = np.flatnonzero(cnt > k)
        col = np.full(n_short, np.inf)
        col[on] = box_distance(tab, lo_s[on] + k, np.take(p, on, axis=0))
        col[np.isnan(col)] = np.inf
        boxes.append(col)
        nearest_at[col < lowest] = k
        np.minimum(lowest, col, out=lowest)
        own_box = col if own_box is None else np.where(own == k, col, own_box)
    primary = np.where(own_box == lowest, own, nearest_at)
    at = np.full(n_short, SLOTS)  # the window position of the nearest so far (SLOTS: none)
    got, close = best[short], nearest[short]
    _measure(tab, np.arange(n_short), lo_s + primary, primary, p, got, close, at)
    for k, col in enumerate(boxes):
        sel = np.flatnonzero((col <= got) & (primary != k) & (cnt > k))
        _measure(tab, sel, lo_s[sel] + k, k, p, got, close, at)
    best[short], nearest[short] = got, close
    return best, nearest


def _measure(
    tab: MoveTable,
    rows: np.ndarray,
    move: np.ndarray,
    k: np.ndarray | int,
    pts: np.ndarray,
    best: np.ndarray,
    nearest: np.ndarray,
    at: np.ndarray,
) -> None:
    """Measure points ``rows`` on moves ``move`` (window position ``k``) and keep the result
    where it is finite and nearer than ``best``, or as near and earlier in the window than
    ``at`` (``best``, ``nearest`` and ``at`` are changed)."""
    if not rows.size:
        return
    p = np.take(pts, rows, axis=0)
    q = nearest_on_moves(tab, move, p)
    d = np.linalg.norm(q - p, axis=1)
    was = best[rows]
    keep = (d < was) | ((d == was) & (k < at[rows]) & (d < np.inf))
    won = rows[keep]
    best[won], nearest[won] = d[keep], q[keep]
    at[won] = k if isinstance(k, int) else k[keep]


def _closest_in_long_window(
    tab: MoveTable, lo: np.ndarray, hi: np.ndarray, first: np.ndarray, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_closest_in_window` pair by pair: each point's (point, move) pairs laid out
    at once."""
    counts = hi - lo + 1
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    owner = np.repeat(np.arange(len(pts)), counts)
    move = lo[owner] + np.arange(int(counts.sum())) - starts[owner]
    dist = np.full(len(move), np.inf)
    near = np.empty((len(move), 3))
    box = box_distance(tab, move, pts[owner])
    primary = _nearest_box(box, owner, starts, starts + (first - lo))
    rest = np.flatnonzero(np.arange(len(move)) != primary[owner])
    for sel in (primary, None):
        if sel is None:
            bound = dist[primary][owner[rest]]
            sel = rest[box[rest] <= bound]
        q = nearest_on_moves(tab, move[sel], pts[owner[sel]])
        d = np.linalg.norm(q - pts[owner[sel]], axis=1)
        dist[sel] = np.where(np.isnan(d), np.inf, d)
        near[sel] = q
    best = np.minimum.reduceat(dist, starts)
    hit = np.flatnonzero((dist == best[owner]) & (dist < np.inf))
    winner = hit[np.concatenate([[True], owner[hit][1:] != owner[hit][:-1]])] if hit.size else hit
    nearest = np.array(pts, dtype=float, copy=True)
    nearest[owner[winner]] = near[winner]
    return best, nearest


def _nearest_box(
    box: np.ndarray, owner: np.ndarray, starts: np.ndarray, preferred: np.ndarray
) -> np.ndarray:
    """Per point (segment ``starts`` of ``box``, the box distances of its window's moves;
    ``owner``: the point of each entry), the entry with the nearest box: ``preferred`` where
    its box is among the nearest, else the first of them (a NaN box counts as infinitely
    far)."""
    key = np.where(np.isnan(box), np.inf, box)
    low = key == np.minimum.reduceat(key, starts)[owner]
    hit = np.flatnonzero(low)
    first_low = hit[np.concatenate([[True], owner[hit][1:] != owner[hit][:-1]])]
    return np.where(low[preferred], preferred, first_low)


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
    tab: MoveTable,
    lines: np.ndarray,
    pts: np.ndarray,
    reach_mm: np.ndarray | None = None,
    window: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] and nearest commanded point (n, 3) [mm] for points executing ``lines``.

    Searched per point: its own moves and one move either side (near a block junction the
    tool may be just before or after it); then, where ``reach_mm`` (n,) is given, every
    further move less than reach_mm of path away from its own moves (a tool lagging or
    leading by several short moves), counted where strictly nearer. Its own moves: rows
    ``window`` (n, 2) first..last of ``tab`` where given and >= 0, else every move of its line.
    A point with none (a line no move has) is compared with every move. Linear in the points
    and, with ``window``, in the moves; done TICKS_PER_PASS points at a time.
    """
    n, m = len(pts), len(tab)
    if m == 0 or n == 0:
        return np.zeros(n), np.array(pts, dtype=float, copy=True)
    if window is None:
        first, last, found = line_ranges(tab, np.asarray(lines))
    else:
        window = np.asarray(window, dtype=np.int64).reshape(n, 2)
        found = (window[:, 0] >= 0) & (window[:, 1] < m)
        first = np.where(found, window[:, 0], 0)
        last = np.where(found, np.maximum(window[:, 1], first), 0)
    lo = np.where(found, np.maximum(first - 1, 0), 0)
    hi = np.where(found, np.minimum(last + 1, m - 1), m - 1)
    best = np.empty(n)
    nearest = np.empty((n, 3))
    for sl in _passes(hi - lo + 1):
        p = np.asarray(pts[sl], dtype=float)
        b, q = _closest_in_window(tab, lo[sl], hi[sl], np.where(found[sl], first[sl], lo[sl]), p)
        if reach_mm is not None:
            reach = np.where(found[sl], reach_mm[sl], 0.0)
            _walk_out(tab, first[sl], -1, reach, p, b, q)
            _walk_out(tab, last[sl], +1, reach, p, b, q)
        best[sl], nearest[sl] = b, q
    return best, nearest


def path_window(path_sources: np.ndarray, window: np.ndarray) -> np.ndarray:
    """The rows of the path the planner followed (Plan.path_moves, whose program moves are
    ``path_sources`` (p, 2)) that come from the program moves ``window`` (n, 2) (-1: none):
    (n, 2), -1 where ``window`` is -1. Where no path move comes from them (a dwell between two
    moves), the two path moves either side. Both columns of ``path_sources`` grow along the
    path (moves in program order, a blend arc between its corner's two moves)."""
    window = np.asarray(window, dtype=np.int64).reshape(-1, 2)
    p = len(path_sources)
    if p == 0:
        return np.full(window.shape, -1, dtype=np.int64)
    lo = np.searchsorted(path_sources[:, 1], window[:, 0], side="left")
    hi = np.searchsorted(path_sources[:, 0], window[:, 1], side="right") - 1
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    out = np.stack([np.clip(lo, 0, p - 1), np.clip(hi, 0, p - 1)], axis=1)
    out[window[:, 0] < 0] = -1
    return out


def _passes(counts: np.ndarray) -> list[slice]:
    """Consecutive slices of the points, each of at most TICKS_PER_PASS points and (unless
    one point alone has more) PAIRS_PER_PASS pairs of ``counts`` (n,) moves per point."""
    out: list[slice] = []
    cum = np.cumsum(counts)
    a, n, done = 0, len(counts), 0
    while a < n:
        b = int(np.searchsorted(cum, done + PAIRS_PER_PASS, side="right"))
        b = min(max(b, a + 1), a + TICKS_PER_PASS, n)
        out.append(slice(a, b))
        done, a = int(cum[b - 1]), b
    return out


def distance_to_program(
    moves: Sequence[Move], lines: np.ndarray, pts: np.ndarray, window: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] and nearest commanded point (n, 3) [mm] for points executing ``lines``
    (``window``: the moves they execute; see :func:`distance_to_moves`)."""
    tab = move_table(moves)
    return distance_to_moves(tab, lines, np.asarray(pts, dtype=float), window=window)
