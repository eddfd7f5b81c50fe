"""The longest overlap of two straight moves' profiles at the stop between them that keeps
every limit and the G64 budget (:mod:`~gantry_sim.controller.planner.stop_overlap` says what
an overlap is and where it is used).

The first move A runs to rest at the corner C along the unit direction dA, the second B from
rest along dB. Let u(t) be A's distance still to go and w(t) B's distance gone at time t of an
overlap of length tau (u only falls, w only grows). The reference is r = C - u dA + w dB, so

* its velocity is -u' dA + w' dB (speed^2 = u'^2 + w'^2 - 2 cos u' w', cos = dA . dB) and
  likewise its acceleration;
* its distance from the two programmed segments is sin(theta) min(u, w) (the nearer
  segment's line, where the foot of the perpendicular lies on the segment: theta the turn),
  largest where u = w;
* C's distance from it is min over t of |w dB - u dA|.

Each axis' velocity, acceleration and jerk are checked exactly on the overlap's constant-jerk
phases (a phase of the sum starts at every phase start of either move inside it: the ends
and, for the velocity, where the acceleration crosses 0), within :data:`LIMIT_REL`. The
rest is checked on a grid: tau is a whole number n of steps (:data:`STEP_S`, longer where the
search may reach beyond :data:`MAX_STEPS` of them), u and w are
laid out every step from the stop once per corner (A's at s = k steps before its stop, B's k
steps after its start: an overlap of n steps has u = U[n - i], w = W[i] at its i-th step), so
trying a length costs a few array operations on n numbers and no evaluation. Between steps
nothing escapes: the path speed and acceleration get half a step at the largest acceleration
(jerk) the axes' limits allow; the crossing of u and w between steps k - 1 and k is at most both
u[k - 1] and w[k]; C's distance is a minimum, so a sample of it bounds it from above.

The search: the bounds that grow with the overlap (the budget, the feed, Marlin's path
acceleration), by regula falsi on n over their margin, then the axes' limits at the length
found (on the grid, then exactly); where one breaks there (rarely), a bisection with every
check below it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = [
    "LIMIT_REL",
    "MAX_STEPS",
    "STEP_S",
    "Corner",
    "Found",
    "Phases",
    "phase_starts_s",
    "search",
    "state_at",
]

#: Relative slack on the axis limits (the planner's pieces keep theirs to about 1e-12).
LIMIT_REL = 1e-9
#: An overlap is a whole number of steps of this [s] (a stop between lines saves 10-15 ms) ...
STEP_S = 2e-5
#: ... or, where the search could reach further, of 1/MAX_STEPS of that reach.
MAX_STEPS = 2048

#: Per axis, a (5, n) array of phases: rows duration [s], position [mm], velocity [mm/s],
#: acceleration [mm/s^2], jerk [mm/s^3].
Phases = tuple[np.ndarray, np.ndarray, np.ndarray]


class Corner(NamedTuple):
    """An exact stop at the corner ``point_mm`` (3,) [mm] between the straight move from
    ``start_mm`` and the one to ``end_mm`` [mm]; ``feed_mm_per_s``: the smaller of their path
    speed bounds; ``budget_mm``: how far the reference may leave them [mm]; ``limits``: per axis
    (velocity [mm/s], acceleration [mm/s^2], jerk [mm/s^3]), each (3,); ``path_acc_mm_per_s2``:
    the path acceleration's bound (Marlin's M204; inf: none)."""

    start_mm: np.ndarray
    point_mm: np.ndarray
    end_mm: np.ndarray
    feed_mm_per_s: float
    budget_mm: float
    limits: tuple[np.ndarray, np.ndarray, np.ndarray]
    path_acc_mm_per_s2: float = math.inf

    def directions(self) -> tuple[np.ndarray, np.ndarray]:
        """The two moves' unit directions (3,) each."""
        a, b = self.point_mm - self.start_mm, self.end_mm - self.point_mm
        return a / np.linalg.norm(a), b / np.linalg.norm(b)


class Found(NamedTuple):
    """An overlap: its length ``tau_s`` [s], the larger of the reference's distance from the
    two moves and C's from the reference [mm], and its phases (per axis, over [0, tau_s])."""

    tau_s: float
    deviation_mm: float
    phases: Phases


class _Side(NamedTuple):
    """One move's phases near the stop, on knots common to the three axes: ``t0`` (n,) the
    phase starts [s] (the first move's counted from its stop, so <= 0; the second's from its
    start), ``rows`` (4, 3, n): position [mm], velocity [mm/s], acceleration [mm/s^2] and
    jerk [mm/s^3] per axis at each phase start; ``along`` (4, n): the same of its distance
    from C along the move [mm] (the first move's still to go, the second's gone: each axis'
    phases are the move's profile times its direction, so this is that profile)."""

    t0: np.ndarray
    rows: np.ndarray
    along: np.ndarray


class _Dirs(NamedTuple):
    """The two moves' unit directions ``a``, ``b`` (3,), the cosine and sine of the turn, and
    the norms of the axes' acceleration and jerk limits."""

    a: np.ndarray
    b: np.ndarray
    cos: float
    sin: float
    acc_norm: float  # |the axes' acceleration limits| [mm/s^2]
    jerk_norm: float  # |the axes' jerk limits| [mm/s^3]

    @classmethod
    def of(cls, corner: Corner) -> _Dirs:
        da, db = corner.directions()
        cos = float(da @ db)
        sin = math.sqrt(max(0.0, 1.0 - cos * cos))
        _, alim, jlim = corner.limits
        return cls(da, db, cos, sin, float(np.linalg.norm(alim)), float(np.linalg.norm(jlim)))


class _Grid(NamedTuple):
    """Both moves' distances from C every ``step_s`` [s] from the stop: ``a`` (4, N + 1) the
    first move's (to go) and its first three derivatives in time [mm, mm/s, mm/s^2, mm/s^3]
    k steps before its stop; ``b`` the second's (gone) k steps after its start."""

    step_s: float
    a: np.ndarray
    b: np.ndarray


def phase_starts_s(rows: np.ndarray) -> np.ndarray:
    """The start times [s] of the phases ``rows`` (5, n) (rows: duration, p, v, a, j), from 0:
    the running sum of the durations before each."""
    return np.concatenate(([0.0], np.cumsum(rows[0])[:-1]))


def _advance(p, v, a, j, dt):
    """Position, velocity, acceleration and jerk ``dt`` [s] into a phase of constant jerk ``j``
    from ``p``, ``v``, ``a`` (scalars or arrays alike)."""
    return (
        p + dt * (v + dt * (0.5 * a + dt * j / 6.0)),
        v + dt * (a + 0.5 * dt * j),
        a + dt * j,
        j,
    )


def _eval(t0: np.ndarray, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(4, ..., len(t)): the state and jerk of the phases ``t0`` (n,), ``rows`` (4, ..., n)
    at times ``t`` [s] (the phase starting at a time owns it)."""
    k = np.clip(np.searchsorted(t0, t, side="right") - 1, 0, t0.size - 1)
    p, v, a, j = rows[..., k]
    return np.array(_advance(p, v, a, j, t - t0[k]))


def state_at(rows: np.ndarray, dt: float) -> tuple[float, float, float, float]:
    """Position, velocity, acceleration and jerk ``dt`` [s] into the phase whose start state
    and jerk are ``rows`` (4,) (one phase: in Python floats, not arrays)."""
    p, v, a, j = (float(x) for x in rows)
    return _advance(p, v, a, j, dt)


def _side(phases: Phases, tail: bool, corner: Corner, dirs: _Dirs) -> _Side:
    """:class:`_Side` of one move's laid-out ``phases`` (its ``tail`` up to the stop at
    ``corner``, or its head from it): each axis evaluated at the knots of all three (an
    axis' phase split at another's knot is the same cubic; a straight move's axes share
    their knots, and are taken as they are)."""
    h = phases[0][0]
    if all(ph.shape == phases[0].shape and np.array_equal(ph[0], h) for ph in phases[1:]):
        knots = phase_starts_s(phases[0]) - (float(np.sum(h)) if tail else 0.0)
        rows = np.stack([ph[1:5] for ph in phases], axis=1)
    else:
        starts = [phase_starts_s(ph) for ph in phases]
        if tail:
            starts = [t - float(np.sum(ph[0])) for t, ph in zip(starts, phases, strict=True)]
        knots = np.unique(np.concatenate(starts))
        rows = np.empty((4, 3, knots.size))
        for i, (t0, ph) in enumerate(zip(starts, phases, strict=True)):
            rows[:, i] = _eval(t0, ph[1:5], knots)
    d = dirs.a if tail else dirs.b
    along = np.einsum("i,kin->kn", -d if tail else d, rows)
    along[0] += float(d @ corner.point_mm) if tail else -float(d @ corner.point_mm)
    return _Side(knots, rows, along)


def _merged(tail: _Side, head: _Side, tau: float, corner_mm: np.ndarray) -> tuple[np.ndarray, ...]:
    """The overlap of ``tau`` [s]: its phases' durations (m,) [s] and position, velocity,
    acceleration and jerk (3, m) per axis at their starts (the tail's last ``tau`` seconds
    and the head's first, summed, less the corner ``corner_mm`` (3,) [mm])."""
    ta = tail.t0 + tau  # the tail's phase starts in the overlap's time
    knots = np.concatenate(([0.0], ta, head.t0))
    knots = np.unique(knots[(knots >= 0.0) & (knots < tau)])
    out = _eval(ta, tail.rows, knots) + _eval(head.t0, head.rows, knots)
    out[0] -= corner_mm[:, None]
    return (np.diff(np.append(knots, tau)), *out)


def _extremes(h, v, a, j) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per axis the largest |velocity|, |acceleration|, |jerk| over phases of durations ``h``
    (m,) starting in ``v``, ``a`` with jerks ``j`` (3, m) (exact: the ends, and where the
    acceleration crosses 0)."""
    a_end = a + h * j
    tt = -a / np.where(j != 0.0, j, math.inf)  # where the acceleration crosses 0
    tt = np.where((tt > 0.0) & (tt < h), tt, 0.0)
    v_turn = v + tt * (a + 0.5 * tt * j)
    v_end = v + h * (a + 0.5 * h * j)
    vmax = np.maximum(np.abs(v), np.maximum(np.abs(v_end), np.abs(v_turn))).max(axis=1)
    return vmax, np.maximum(np.abs(a), np.abs(a_end)).max(axis=1), np.abs(j).max(axis=1)


def _crossing(u: np.ndarray, w: np.ndarray) -> float:
    """An upper bound of max min(u, w) [mm] from samples of u (falling) and w (growing):
    where they cross between samples k - 1 and k, the crossing is at most u[k - 1] and w[k]."""
    k = int(np.argmax(u <= w)) if (u <= w).any() else u.size
    if k == 0:
        return float(u[0])
    if k == u.size:
        return float(w[-1])
    return float(min(u[k - 1], w[k]))


def _margin(grid: _Grid, n: int, corner: Corner, dirs: _Dirs) -> tuple[float, float]:
    """How far an overlap of ``n`` steps is from the bounds that grow with it, on the grid:
    the largest of its deviation over the budget, its path speed over the feed and (where
    Marlin's M204 applies) its path acceleration over that, less 1 (<= 0: all kept), and its
    deviation [mm] (:attr:`Found.deviation_mm`). Between steps the speed (acceleration) moves
    by at most half a step at the largest acceleration (jerk) the axes' limits allow."""
    half_step = 0.5 * grid.step_s
    u, w = grid.a[0, n::-1], grid.b[0, : n + 1]
    off = dirs.sin * _crossing(u, w)
    to_corner = float(np.sqrt(np.maximum(u * u + w * w - 2.0 * dirs.cos * u * w, 0.0)).min())
    deviation = max(off, to_corner)
    speed = _norm_top(grid.a[1, n::-1], grid.b[1, : n + 1], dirs.cos)
    worst = max(
        deviation / corner.budget_mm,
        (speed + dirs.acc_norm * half_step) / corner.feed_mm_per_s,
    )
    if math.isfinite(corner.path_acc_mm_per_s2):
        acc = _norm_top(grid.a[2, n::-1], grid.b[2, : n + 1], dirs.cos)
        worst = max(worst, (acc + dirs.jerk_norm * half_step) / corner.path_acc_mm_per_s2)
    return worst - 1.0, deviation


def _axes_keep(grid: _Grid, n: int, corner: Corner, dirs: _Dirs) -> bool:
    """Whether each axis keeps its velocity, acceleration and jerk limits on the grid's steps
    of an overlap of ``n`` steps (the first two with half a step at the next one's limit; a
    phase shorter than a step may hide a jerk, which :func:`_check` finds on the phases)."""
    half_step = 0.5 * grid.step_s
    vlim, alim, jlim = corner.limits
    grace = 1.0 + LIMIT_REL
    a, b = grid.a[1:, n::-1], grid.b[1:, : n + 1]  # (3, n + 1): rate, its derivatives
    axes = -dirs.a[None, :, None] * a[:, None, :] + dirs.b[None, :, None] * b[:, None, :]
    tops = np.abs(axes).max(axis=2)  # (3 orders, 3 axes)
    return not (
        (tops[0] + alim * half_step > vlim * grace).any()
        or (tops[1] + jlim * half_step > alim * grace).any()
        or (tops[2] > jlim * grace).any()
    )


def _norm_top(x: np.ndarray, y: np.ndarray, cos: float) -> float:
    """The largest |x dA - y dB| over the samples ``x``, ``y`` (of the two moves' rates)."""
    return float(np.sqrt(np.maximum(x * x + y * y - 2.0 * cos * x * y, 0.0)).max())


def _check(
    tail: _Side,
    head: _Side,
    grid: _Grid,
    n: int,
    corner: Corner,
    dirs: _Dirs,
    deviation: float | None = None,
) -> Found | None:
    """The overlap of ``n`` steps if it keeps every check of the module docstring
    (``deviation``: its :func:`_margin` deviation [mm], where that margin is known <= 0 and
    :func:`_axes_keep` known true)."""
    if deviation is None:
        margin, deviation = _margin(grid, n, corner, dirs)
        if margin > 0.0 or not _axes_keep(grid, n, corner, dirs):
            return None
    tau = n * grid.step_s
    h, _, v, a, j = merged = _merged(tail, head, tau, corner.point_mm)
    vlim, alim, jlim = corner.limits
    vmax, amax, jmax = _extremes(h, v, a, j)
    grace = 1.0 + LIMIT_REL
    if (jmax > jlim * grace).any() or (amax > alim * grace).any() or (vmax > vlim * grace).any():
        return None
    phases = np.empty((3, 5, h.size))
    phases[:, 0] = h
    phases[:, 1:] = np.swapaxes(np.array(merged[1:]), 0, 1)
    return Found(tau, deviation, (phases[0], phases[1], phases[2]))


def _reach_s(tail: _Side, head: _Side, corner: Corner, dirs: _Dirs, room_s: float) -> float:
    """An overlap longer than this [s] (at most ``room_s``) leaves C farther than the budget:
    C's distance, |w dB - u dA|, is at least max(u, w) sqrt(1 - |cos|), and at the overlap's
    middle max(u, w) >= min(U(tau / 2), W(tau / 2)) (U, W: the two moves' distances from C
    that long before and after the stop), so U and W may not both pass
    budget / sqrt(1 - |cos|) within tau / 2."""
    spread = 1.0 - abs(dirs.cos)
    if spread <= 0.0:
        return room_s
    reach = corner.budget_mm / math.sqrt(spread)
    s_u = _time_to(tail, reach, tail=True)
    s_w = _time_to(head, reach, tail=False)
    # a step more than found, so that rounding leaves the bound above the truth
    return min(room_s, 2.0 * max(s_u, s_w) * (1.0 + 1e-9) + 2.0 * STEP_S)


def _time_to(side: _Side, reach_mm: float, tail: bool) -> float:
    """How long [s] before its stop (``tail``) or after its start the move is ``reach_mm``
    from C (inf: not within its phases): its phase found by its knots, the time within it by
    bisection of the phase's cubic (the distance only grows away from C)."""
    dist = side.along[0]
    if tail:  # distance to go: falls with time, the stop at time 0
        over = np.flatnonzero(dist > reach_mm)
        if over.size == 0:
            return math.inf
        k = int(over[-1])
        end = float(side.t0[k + 1]) if k + 1 < side.t0.size else 0.0
    else:  # distance gone: grows with time
        over = np.flatnonzero(dist > reach_mm)
        if over.size == 0 or over[0] == 0:
            return math.inf if over.size == 0 else 0.0
        k = int(over[0]) - 1
        end = float(side.t0[k + 1])
    p, v, a, j = (float(x) for x in side.along[:, k])
    lo, hi = 0.0, end - float(side.t0[k])
    far_at_lo = tail  # the tail is farther at its phase start, the head at its end
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        far = p + mid * (v + mid * (0.5 * a + mid * j / 6.0)) > reach_mm
        if far == far_at_lo:
            lo = mid
        else:
            hi = mid
    t = float(side.t0[k]) + (lo if tail else hi)
    return -t if tail else t


def _grid(tail: _Side, head: _Side, reach_s: float) -> _Grid:
    step = max(STEP_S, reach_s / MAX_STEPS)
    s = np.arange(int(reach_s / step) + 1) * step
    return _Grid(step, _eval(tail.t0, tail.along, -s), _eval(head.t0, head.along, s))


def _longest_on_grid(grid: _Grid, top: int, corner: Corner, dirs: _Dirs) -> tuple[int, float]:
    """The most steps (at most ``top``) whose :func:`_margin` is <= 0 (0: none), and their
    deviation [mm]: regula falsi (the Illinois variant) on the margin, which grows smoothly
    with the overlap, so that a few tries find the step where it crosses 0."""
    lo, hi = 0, top + 1  # lo keeps the margin (0 trivially), hi does not (top + 1: beyond)
    f_lo, f_hi = -1.0, math.nan
    kept = 0.0  # lo's deviation [mm]
    side = 0
    while hi - lo > 1:
        if hi == top + 1:
            mid = top  # the longest first: its margin steers the next tries
        else:
            mid = lo + round((hi - lo) * (-f_lo) / (f_hi - f_lo))
            mid = min(max(mid, lo + 1), hi - 1)
        f, deviation = _margin(grid, mid, corner, dirs)
        if f <= 0.0:
            lo, f_lo, kept = mid, f, deviation
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = mid, f
            if side == 1:
                f_lo *= 0.5
            side = 1
    return lo, kept


def search(tail: Phases, head: Phases, corner: Corner, room_s: float) -> Found | None:
    """The longest overlap of at most ``room_s`` [s] of the phases ``tail`` (per axis, the
    first move's up to its stop at ``corner``, covering at least ``room_s``) and ``head`` (the
    second's from it, likewise) that keeps every check (see the module docstring); None where
    none does."""
    dirs = _Dirs.of(corner)
    a, b = _side(tail, True, corner, dirs), _side(head, False, corner, dirs)
    grid = _grid(a, b, _reach_s(a, b, corner, dirs, room_s))
    top = grid.a.shape[1] - 1  # steps
    if top < 1:
        return None
    lo, deviation = _longest_on_grid(grid, top, corner, dirs)
    if lo == 0:
        return None
    if not _axes_keep(grid, lo, corner, dirs):  # an axis' limit binds first: bisect on it
        hi, lo = lo, 0
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _axes_keep(grid, mid, corner, dirs):
                lo = mid
            else:
                hi = mid
        if lo == 0:
            return None
        found = _check(a, b, grid, lo, corner, dirs)  # (its margin checked again)
    else:
        found = _check(a, b, grid, lo, corner, dirs, deviation)
    if found is not None:
        return found
    best, lo, hi = None, 0, lo  # a limit breaks at hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        got = _check(a, b, grid, mid, corner, dirs)
        if got is None:
            hi = mid
        else:
            lo, best = mid, got
    return best
