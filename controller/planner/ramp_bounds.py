"""The bounds a saturated ramp rides (:mod:`gantry_sim.controller.planner.saturated_ramp`).

Following an arc of curvature k = 1/R [1/mm] at path speed v [mm/s] with tangential acceleration
a [mm/s^2] and jerk j [mm/s^3] needs acceleration a T + v^2 k N and jerk (j - v^3 k^2) T +
3 v a k N (T tangent, N inward normal). Given the state, each class here returns the range of
tangential jerk and the highest tangential acceleration that keep the axes within their limits:
:class:`NormLimits` orientation-free (as
:func:`gantry_sim.controller.planner.speedup.follow_ok` checks), :class:`CircleLimits` each plane
axis against its own limit along a plain circle (exact).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class RampLimits(Protocol):
    """The bounds a ramp rides: :class:`NormLimits` or :class:`CircleLimits`."""

    def bounds(
        self, dist: np.ndarray, v: np.ndarray, a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lowest, highest) tangential jerk [mm/s^3] and highest tangential acceleration
        [mm/s^2] at ``dist`` [mm] along the ramp, speed ``v`` [mm/s], acceleration ``a``."""
        ...

    @property
    def acc_min(self) -> float: ...

    @property
    def jerk_min(self) -> float: ...


@dataclass(frozen=True)
class NormLimits:
    """Orientation-free bounds (those of :func:`gantry_sim.controller.planner.speedup.follow_ok`): curvature k
    [1/mm], the third derivative's size dk [1/mm^2], the plane's acceleration [mm/s^2] and jerk
    [mm/s^3]."""

    k: float
    dk: float
    acc: float
    jerk: float

    def bounds(
        self, dist: np.ndarray, v: np.ndarray, a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`RampLimits.bounds` (``dist`` unused: the bounds hold anywhere)."""
        jm = np.sqrt(np.maximum(self.jerk**2 - (3.0 * v * a * self.k) ** 2, 0.0)) - v**3 * self.dk
        a_hi = np.sqrt(np.maximum(self.acc**2 - (v * v * self.k) ** 2, 0.0))
        return -jm, jm, a_hi

    @property
    def acc_min(self) -> float:
        return self.acc

    @property
    def jerk_min(self) -> float:
        return self.jerk


@dataclass(frozen=True)
class CircleLimits:
    """Per-axis bounds on a plain circular arc (exact: each plane axis against its own limit).

    The ramp runs from the arc's start (``reverse`` False) or, reversed in time, back from its
    end: angle theta(s) = theta0 + sigma s / R at arc length s; forward tangent
    sigma (-sin, cos), inward normal (-cos, -sin) in the plane's axes. Following exactly needs
    acceleration a T + (v^2/R) N and jerk (j - v^3/R^2) T + (3 v a / R) N (T reversed for the
    reversed ramp, whose jerk keeps its sign). ``acc``, ``jerk``: the plane axes' limits.
    """

    theta0: float
    sigma: float
    radius_mm: float
    length_mm: float
    reverse: bool
    acc: tuple[float, float]
    jerk: tuple[float, float]

    def bounds(
        self, dist: np.ndarray, v: np.ndarray, a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`RampLimits.bounds`."""
        s_pos = self.length_mm - dist if self.reverse else dist
        th = self.theta0 + self.sigma * s_pos / self.radius_mm
        sign = -self.sigma if self.reverse else self.sigma
        tang = (-sign * np.sin(th), sign * np.cos(th))
        norm = (-np.cos(th), -np.sin(th))
        r = self.radius_mm
        c, n, an = v**3 / r**2, 3.0 * v * a / r, v * v / r
        j_lo, j_hi, a_hi = (np.full(np.shape(v), x) for x in (-np.inf, np.inf, np.inf))
        for t_i, n_i, jl, al in zip(tang, norm, self.jerk, self.acc, strict=True):
            t_safe = np.where(np.abs(t_i) > 1e-12, t_i, 1e-12)
            e1, e2 = (-jl - n_i * n) / t_safe, (jl - n_i * n) / t_safe
            j_lo = np.maximum(j_lo, c + np.minimum(e1, e2))
            j_hi = np.minimum(j_hi, c + np.maximum(e1, e2))
            b1, b2 = (-al - n_i * an) / t_safe, (al - n_i * an) / t_safe
            a_hi = np.minimum(a_hi, np.maximum(b1, b2))
        return j_lo, j_hi, np.maximum(a_hi, 0.0)

    @property
    def acc_min(self) -> float:
        return min(self.acc)

    @property
    def jerk_min(self) -> float:
        return min(self.jerk)
