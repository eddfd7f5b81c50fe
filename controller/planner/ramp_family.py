"""The ramps of one end of a saturated profile, every switch time at once.

A saturated ramp (:mod:`~gantry_sim.controller.planner.saturated_ramp`) starts at speed ``v0``
with a = 0, steps up at the highest jerk the state leaves until its switch time, then down at
the lowest until its acceleration is back to 0. Ramps with different switch times are the same
ramp until the earlier switch time, so :class:`RampFamily` integrates the up steps once, as
far as any switch time of the search reaches, and a batch of switch times only steps down,
each from its own switch state. Before, each batch of 33 switch times integrated its up steps
again (4 batches a search, 5 searches an end): 0.51 s an arc from rest, most of it there.

Steps are constant-jerk phases of at most ``dt`` [s]; a switch time between two steps' starts
ends the up steps with a shorter step. The bounds (:class:`RampLimits`) give, at each state,
the range of tangential jerk [mm/s^3] and the highest tangential acceleration [mm/s^2] that
keep the axes within their limits; a state whose range is empty ends its ramp as a failure
(NaN), and so does a down step that finds no negative jerk left, or a ramp still running after
``MAX_RAMP_S``. Units: mm, s.
"""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.planner.ramp_bounds import RampLimits

#: Longest ramp [s] tried (a ramp whose jerk runs out crawls towards its end: a failure).
MAX_RAMP_S = 2.0


def advance(h, s, v, a, j):
    """State (s, v, a) after ``h`` [s] of constant jerk ``j`` from (s, v, a)."""
    return s + h * (v + h * (0.5 * a + h * j / 6.0)), v + h * (a + 0.5 * h * j), a + h * j


def _up_jerk(j_hi, a_hi, a, h):
    """The up steps' jerk: the highest the bounds allow, less where it would pass a_hi."""
    return np.minimum(j_hi, np.maximum(a_hi - a, 0.0) / h)


class RampFamily:
    """The ramps from ``v0`` [mm/s] (a = 0) under ``lim`` with steps of ``dt`` [s], for switch
    times up to ``reach`` [s]: the shared up steps are integrated here, once."""

    def __init__(self, v0: float, lim: RampLimits, dt: float, reach: float) -> None:
        self.lim, self.dt = lim, dt
        self._tiny = 1e-9 * lim.jerk_min
        t, s, v, a = 0.0, 0.0, float(v0), 0.0
        ts: list[float] = []
        ss: list[float] = []
        vs: list[float] = []
        as_: list[float] = []
        js: list[float] = []
        self.first_bad = None  # the first state whose bounds leave no jerk (None: none)
        while True:
            for col, x in ((ts, t), (ss, s), (vs, v), (as_, a)):
                col.append(x)
            if t >= reach or t >= MAX_RAMP_S:
                js.append(np.nan)
                break
            j_lo, j_hi, a_hi = lim.bounds(np.array([s]), np.array([v]), np.array([a]))
            if j_lo[0] > j_hi[0]:
                self.first_bad = len(ts) - 1
                js.append(np.nan)
                break
            j = float(_up_jerk(j_hi, a_hi, np.array([a]), dt)[0])
            js.append(j)
            s, v, a = advance(dt, s, v, a, j)
            t = t + dt
        self.t, self.s, self.v, self.a, self.j = (np.array(x) for x in (ts, ss, vs, as_, js))

    @property
    def grid(self) -> np.ndarray:
        """The switch times at the up steps' starts [s]."""
        return self.t

    def ramps(
        self, tau: np.ndarray, rows: list | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(peak speed [mm/s], distance [mm], duration [s]) of the ramps switching at ``tau``
        [s] (each at most the family's reach), NaN where a ramp fails. ``rows``: when given,
        the phases (dur, s, v, a, j) of the first ramp are appended to it."""
        tau = np.asarray(tau, dtype=float)
        n = tau.size
        dt, last_state = self.dt, self.t.size - 1
        # full up steps: from each state whose time leaves at least dt before the switch
        full = (tau[:, None] - self.t[None, :last_state] >= dt).sum(axis=1)
        k = np.minimum(full, last_state)
        dead = np.zeros(n, dtype=bool) if self.first_bad is None else k >= self.first_bad
        t, s, v, a = self.t[k], self.s[k], self.v[k], self.a[k]
        if rows is not None and n and not dead[0]:
            rows.extend((dt, self.s[i], self.v[i], self.a[i], self.j[i]) for i in range(int(k[0])))
        # the last up step, shorter, where the switch falls between two steps' starts
        h = tau - t
        part = ~dead & (h > 0.0)
        if part.any():
            j_lo, j_hi, a_hi = self.lim.bounds(s, v, a)
            dead |= part & (j_lo > j_hi)
            hp = np.where(part & ~dead, h, 1.0)
            j = _up_jerk(j_hi, a_hi, a, hp)
            step = part & ~dead
            if rows is not None and step[0]:
                rows.append((h[0], s[0], v[0], a[0], j[0]))
            s1, v1, a1 = advance(hp, s, v, a, j)
            s, v, a = (np.where(step, x, y) for x, y in ((s1, s), (v1, v), (a1, a)))
            t = np.where(step, tau, t)
        return self._down(t, s, v, a, dead, rows)

    def _down(self, t, s, v, a, dead, rows):
        """The down steps, at the lowest jerk, from each state until a = 0."""
        n, dt, tiny = t.size, self.dt, self._tiny
        out_v, out_s, out_t = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
        live = ~dead
        # a lane that has ended keeps stepping with the others (one batch of array operations
        # a step): only a live lane's results are kept, so its numbers are never read
        with np.errstate(all="ignore"):
            for _ in range(200000):
                live &= t < MAX_RAMP_S
                if not live.any():
                    break
                j_lo, j_hi, _ = self.lim.bounds(s, v, a)
                j = j_lo
                last = a + j * dt <= 0.0
                h = np.where(last, a / np.maximum(-j, tiny), dt)
                if rows is not None and live[0] and h[0] > 0:
                    rows.append((h[0], s[0], v[0], a[0], j[0]))
                s, v, a = advance(h, s, v, a, j)
                t = t + h
                bad = (j_lo > j_hi) | (j >= -tiny)
                ended = live & (last | bad)
                if ended.any():
                    done = ended & last & ~bad
                    out_v[done], out_s[done], out_t[done] = v[done], s[done], t[done]
                    live &= ~ended
        return out_v, out_s, out_t
