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
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from gantry_sim.controller.arcs import ArcFrame


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

    @classmethod
    def ends(
        cls,
        frame: ArcFrame,
        length_mm: float,
        acc: tuple[float, float],
        jerk: tuple[float, float],
        share: float,
    ) -> tuple[CircleLimits, CircleLimits]:
        """The bounds of the ramp up from the start of the arc of ``frame`` (``length_mm``
        long) and of the ramp back from its end, at ``share`` of the plane axes' acceleration
        ``acc`` [mm/s^2] and jerk ``jerk`` [mm/s^3] limits."""
        scaled_acc = (share * acc[0], share * acc[1])
        scaled_jerk = (share * jerk[0], share * jerk[1])
        up, down = (
            cls(frame.theta0_rad, frame.sigma, frame.r0_mm, length_mm, rev, scaled_acc, scaled_jerk)
            for rev in (False, True)
        )
        return up, down

    def bounds(
        self, dist: np.ndarray, v: np.ndarray, a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`RampLimits.bounds`."""
        s_pos = self.length_mm - dist if self.reverse else dist
        th = self.theta0 + self.sigma * s_pos / self.radius_mm
        sign = -self.sigma if self.reverse else self.sigma
        cos_t, sin_t = np.cos(th), np.sin(th)
        r = self.radius_mm
        c, n, an = v**3 / r**2, 3.0 * v * a / r, v * v / r
        # axis i: |t_i j_t + n_i (3 v a / r) - t_i c| <= jerk_i and |t_i a + n_i v^2/r| <=
        # acc_i, solved for the tangential jerk j_t and acceleration a (t, n: the axis' share
        # of the tangent and of the inward normal; a share below 1e-12 counts as 1e-12)
        out = []
        for t_i, n_i, jl, al in (
            (-sign * sin_t, -cos_t, self.jerk[0], self.acc[0]),
            (sign * cos_t, -sin_t, self.jerk[1], self.acc[1]),
        ):
            inv = 1.0 / np.where(np.abs(t_i) > 1e-12, t_i, 1e-12)
            reach = np.abs(inv)
            mid = c - n_i * n * inv
            out.append((mid - jl * reach, mid + jl * reach, al * reach - n_i * an * inv))
        (lo0, hi0, a0), (lo1, hi1, a1) = out
        return np.maximum(lo0, lo1), np.minimum(hi0, hi1), np.maximum(np.minimum(a0, a1), 0.0)

    @property
    def acc_min(self) -> float:
        return min(self.acc)

    @property
    def jerk_min(self) -> float:
        return min(self.jerk)
