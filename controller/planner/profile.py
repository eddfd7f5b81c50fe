"""The 1-D speed profile along one move, the hand-off between the planner's steps.

A move's reference runs along its path at arc length s(t) [mm]: a sequence of phases of constant
jerk, each stored by its duration and its start state. Ruckig makes the profiles
(:mod:`gantry_sim.controller.planner.ruckig_solver`), :mod:`~gantry_sim.controller.planner.speedup`
and :mod:`~gantry_sim.controller.planner.saturated_ramp` make faster ones,
:mod:`~gantry_sim.controller.planner.arc_states` and :mod:`~gantry_sim.controller.planner.pieces`
read them.
"""

from __future__ import annotations

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

    @property
    def duration_s(self) -> float:
        """Total duration [s]."""
        return float(self.rows[:, 0].sum())

    def invert(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times [s], speeds [mm/s], tangential accelerations [mm/s^2] where the profile passes
        the arc lengths ``s`` [mm] (ascending)."""

        keep = self.rows[:, 0] > 0
        dur, p, v, a, j = self.rows[keep].T
        t0 = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
        k = np.clip(np.searchsorted(p, s, side="right") - 1, 0, p.size - 1)
        lo, hi = np.zeros(s.size), dur[k].copy()
        pk, vk, ak, jk = p[k], v[k], a[k], j[k]
        for _ in range(24):  # bisection: s(t) is monotone (v >= 0) ...
            mid = 0.5 * (lo + hi)
            below = pk + mid * (vk + mid * (0.5 * ak + mid * jk / 6.0)) < s
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        tau = 0.5 * (lo + hi)
        for _ in range(3):  # ... then Newton, kept inside the bracket
            f = pk + tau * (vk + tau * (0.5 * ak + tau * jk / 6.0)) - s
            df = vk + tau * (ak + 0.5 * tau * jk)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(df > 0, f / df, 0.0)
            tau = np.clip(tau - step, lo, hi)
        return t0[k] + tau, vk + tau * (ak + 0.5 * tau * jk), ak + tau * jk
