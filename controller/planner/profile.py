"""The 1-D speed profile along one move, the hand-off between the planner's steps.

A move's reference runs along its path at arc length s(t) [mm]: a sequence of phases of constant
jerk, each stored by its duration and its start state. Ruckig makes the profiles
(:mod:`gantry_sim.controller.planner.ruckig_solver`), :mod:`~gantry_sim.controller.planner.speedup`
and :mod:`~gantry_sim.controller.planner.saturated_ramp` make faster ones,
:mod:`~gantry_sim.controller.planner.arc_states` and :mod:`~gantry_sim.controller.planner.pieces`
read them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Profile1D:
    """Constant-jerk phases of a 1-D profile along the path, in time order, without gaps.

    ``rows`` is a (k, 5) array, one phase per row: duration [s], and at the phase's start the arc
    length s [mm], path speed v [mm/s], tangential acceleration a [mm/s^2], with the phase's
    tangential jerk j [mm/s^3]. The columns are also available by name.
    """

    rows: np.ndarray

    @property
    def dur(self) -> np.ndarray:
        """Phase durations (k,) [s]."""
        return self.rows[:, 0]

    @property
    def s(self) -> np.ndarray:
        """Arc length at each phase's start (k,) [mm]."""
        return self.rows[:, 1]

    @property
    def v(self) -> np.ndarray:
        """Path speed at each phase's start (k,) [mm/s]."""
        return self.rows[:, 2]

    @property
    def a(self) -> np.ndarray:
        """Tangential acceleration at each phase's start (k,) [mm/s^2]."""
        return self.rows[:, 3]

    @property
    def j(self) -> np.ndarray:
        """Tangential jerk of each phase (k,) [mm/s^3]."""
        return self.rows[:, 4]

    @functools.cached_property
    def duration_s(self) -> float:
        """Total duration [s] (the rows are never changed after the profile is made)."""
        return float(self.rows[:, 0].sum())

    def states_at(
        self, per_phase: int = 9
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Arc length [mm], path speed [mm/s] and tangential acceleration [mm/s^2] at
        ``per_phase`` evenly spaced points of every phase (ends included), each (k, per_phase),
        and each phase's jerk [mm/s^3] (k, 1): what a point-by-point check of following the
        path reads."""
        ph = self.rows
        t = ph[:, :1] * _fractions(per_phase)
        s0, v0, a0, j = ph[:, 1:2], ph[:, 2:3], ph[:, 3:4], ph[:, 4:5]
        s = s0 + t * (v0 + t * (0.5 * a0 + t * j / 6.0))
        return (s, *self.speeds_at(per_phase))

    def speeds_at(self, per_phase: int = 9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`states_at` without the arc length: speed, acceleration, jerk (a check that
        needs no position is called hundreds of thousands of times)."""
        ph = self.rows
        t = ph[:, :1] * _fractions(per_phase)
        v0, a0, j = ph[:, 2:3], ph[:, 3:4], ph[:, 4:5]
        return v0 + t * (a0 + 0.5 * t * j), a0 + t * j, j

    def invert(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times [s], speeds [mm/s], tangential accelerations [mm/s^2] where the profile passes
        the arc lengths ``s`` [mm] (ascending)."""
        return invert_many([(self, s)])[0]


@functools.cache
def _fractions(count: int) -> np.ndarray:
    """``count`` evenly spaced fractions of a phase, 0 and 1 included (read-only: shared)."""
    out = np.linspace(0.0, 1.0, count)
    out.flags.writeable = False
    return out


def invert_many(
    queries: list[tuple[Profile1D, np.ndarray]],
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """:meth:`Profile1D.invert` for several (profile, arc lengths) at once: one vectorised
    solve over all of them (each number is computed exactly as alone, bit for bit: the solve is
    element by element), so planning many arcs costs a few numpy calls, not a few hundred each.

    The profiles' phases are laid out as rows of one padded table (each row's cumulative start
    times summed in the same order as one profile's ``np.cumsum``), and each arc length finds
    its phase by counting its profile's phase starts at or below it, so no profile costs a call
    of its own. That count is ``np.searchsorted``'s ``side="right"`` where the starts never go
    back; a profile whose starts do (a candidate that reverses, later refused) or that is asked
    for NaN is inverted on its own, by ``np.searchsorted`` as before (a polyline of a Fusion
    360 program planned 2e-6 of its time longer with the count), and so is a profile of more
    than :data:`TABLE_PHASES` phases (the table is as wide as its widest profile)."""
    if not queries:
        return []
    ss = [np.asarray(s, dtype=float).reshape(-1) for _, s in queries]
    table = np.concatenate([prof.rows for prof, _ in queries])
    owner = np.repeat(np.arange(len(queries)), [prof.rows.shape[0] for prof, _ in queries])
    keep = table[:, 0] > 0
    table, owner = table[keep], owner[keep]
    kept = np.bincount(owner, minlength=len(queries))
    counts = np.array([s.size for s in ss])
    if np.any((kept == 0) & (counts > 0)):  # a profile of no time asked for a point
        raise IndexError("invert_many: a profile without phases cannot be inverted")
    narrow = kept <= TABLE_PHASES
    out: list[tuple[np.ndarray, np.ndarray, np.ndarray] | None] = [None] * len(queries)
    at = np.flatnonzero(narrow)
    if at.size:
        rows = narrow[owner]  # the narrow profiles' phases, their owners renumbered in order
        renumber = np.cumsum(narrow) - 1
        got = _invert_table(
            table[rows], renumber[owner[rows]], kept[at], counts[at], [ss[i] for i in at]
        )
        for i, inv in zip(at.tolist(), got, strict=True):
            out[i] = inv
    return [
        inv if inv is not None else _invert_one(queries[i][0], ss[i]) for i, inv in enumerate(out)
    ]


#: Phases of a profile above which :func:`invert_many` inverts it on its own.
TABLE_PHASES = 32


def _invert_table(
    table: np.ndarray,
    owner: np.ndarray,
    kept: np.ndarray,
    counts: np.ndarray,
    ss: list[np.ndarray],
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
    """:func:`invert_many` of profiles whose phases of time are the rows of ``table``, in
    order, row r of profile ``owner[r]``; ``kept``: each profile's count of them (at most
    :data:`TABLE_PHASES`, at least one where asked for a point), asked for the ``counts`` arc
    lengths ``ss``, in one padded table; None for those to invert on their own."""
    n = kept.size
    width = max(int(kept.max()), 1)
    first = np.concatenate(([0], np.cumsum(kept)[:-1]))
    col = np.arange(table.shape[0]) - first[owner]
    grid = np.zeros((n, width, 5))
    grid[owner, col] = table
    starts = np.full((n, width), np.inf)  # padding: never at or below a query
    starts[owner, col] = table[:, 1]
    t0 = np.zeros((n, width))
    t0[:, 1:] = np.cumsum(grid[:, :-1, 0], axis=1)
    s_all = np.concatenate(ss)
    q = np.repeat(np.arange(n), counts)
    k = (starts[q] <= s_all[:, None]).sum(axis=1) - 1
    k = np.clip(k, 0, np.maximum(kept[q] - 1, 0))
    dk, pk, vk, ak, jk = grid[q, k].T
    t, vel, acc = _solve_tau(pk, vk, ak, jk, dk, t0[q, k], s_all)
    cuts = np.cumsum(counts)[:-1]
    out: list[tuple[np.ndarray, np.ndarray, np.ndarray] | None] = list(
        zip(np.split(t, cuts), np.split(vel, cuts), np.split(acc, cuts), strict=True)
    )
    ordered = np.all(starts == np.maximum.accumulate(starts, axis=1), axis=1)  # NaN: not
    asked_nan = np.bincount(q[np.isnan(s_all)], minlength=n) > 0
    for i in np.flatnonzero(~ordered | asked_nan):
        out[i] = None
    return out


def _invert_one(prof: Profile1D, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`Profile1D.invert` of one profile, with its own arrays (the same numbers)."""
    dur, p, v, a, j = prof.rows[prof.rows[:, 0] > 0].T
    t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
    k = np.clip(np.searchsorted(p, s, side="right") - 1, 0, p.size - 1)
    return _solve_tau(p[k], v[k], a[k], j[k], dur[k], t0[k], s)


def _solve_tau(pk, vk, ak, jk, dk, t0k, s):
    """Element by element: the time in its phase (start state pk, vk, ak, jerk jk, duration dk,
    start time t0k) where s(t) = ``s``; returns (t0k + tau, speed, acceleration) there."""
    lo, hi = np.zeros(s.size), dk.copy()
    half_a = 0.5 * ak
    mid, poly, below = np.empty(s.size), np.empty(s.size), np.empty(s.size, dtype=bool)
    for _ in range(24):  # bisection: s(t) is monotone (v >= 0) ...
        np.add(lo, hi, out=mid)
        mid *= 0.5
        np.multiply(mid, jk, out=poly)  # pk + mid * (vk + mid * (0.5 ak + mid jk / 6))
        poly /= 6.0
        poly += half_a
        poly *= mid
        poly += vk
        poly *= mid
        poly += pk
        np.less(poly, s, out=below)
        np.copyto(lo, mid, where=below)
        np.logical_not(below, out=below)
        np.copyto(hi, mid, where=below)
    tau = 0.5 * (lo + hi)
    for _ in range(3):  # ... then Newton, kept inside the bracket
        f = pk + tau * (vk + tau * (0.5 * ak + tau * jk / 6.0)) - s
        df = vk + tau * (ak + 0.5 * tau * jk)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df > 0, f / df, 0.0)
        tau = np.clip(tau - step, lo, hi)
    return t0k + tau, vk + tau * (ak + 0.5 * tau * jk), ak + tau * jk
