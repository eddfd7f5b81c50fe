"""Figures of one axis' position loop, as a controls engineer reads them; numbers only.

The loop is the servo law of :mod:`gantry_sim.controller.servo` (PD, optionally PID, on the error
r - x, held over each period T by a zero-order hold) around the axis' moving mass m, sampled at
the period T. The plant is a pure mass: damping and friction are left out (damping only adds
margin). With m' = m * 1e-3 [N/(mm/s^2)] (m in kg, x in mm):

    P(z) = T^2 (z + 1) / (2 m' (z - 1)^2)                  the exact ZOH discretisation of 1/(m' s^2)
    C(z) = kp + kd (1 - 1/z) / T + ki T z / (z - 1)        the law of controller.servo [N/mm]

and the closed loop's characteristic polynomial is (denominators of C cleared, the common
factor z - 1 left out when ki = 0):

    PD:   2 m' (z - 1)^2 z           + a T^2 (z + 1) ((kp + kd/T) z - kd/T)
    PID:  2 m' (z - 1)^3 z           + a T^2 (z + 1) (((kp + kd/T) z - kd/T)(z - 1) + ki T z^2)

with every gain scaled by a (a = 1: the gains as set). The loop is stable when all roots lie
inside the unit circle. :func:`gain_margin` is the largest a of the stable range around 1: the
factor by which kp, kd and ki together could grow before the sampled loop goes unstable.

The same law as a cascade (what drive manuals and LinuxCNC's velocity-mode PID speak of): a
velocity loop of gain kd [N s/mm] around a position loop of gain Kv = kp / kd [1/s] gives
F = kd (Kv e + v_ref - v) = kp e + kd de/dt, the PD above. Kv [1/s] * 0.06 = Kv in
(m/min)/mm, the unit machine-tool builders quote.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: (m/min)/mm per 1/s: (mm/s)/mm * 60 s/min / 1000 mm/m
M_PER_MIN_PER_MM_PER_S = 0.06
#: gain scales scanned for the stable range (log-spaced), then refined by bisection
_SCALES = np.geomspace(1e-4, 1e4, 161)


@dataclass(frozen=True)
class AxisLoop:
    """One axis: moving mass [kg], gains kp [N/mm], kd [N s/mm], ki [N/(mm s)], period [s]."""

    mass_kg: float
    kp_N_per_mm: float
    kd_N_s_per_mm: float
    ki_N_per_mm_s: float
    period_s: float

    @property
    def _m(self) -> float:
        return self.mass_kg * 1e-3  # N per (mm/s^2)

    def characteristic(self, scale: float = 1.0) -> np.ndarray:
        """Closed-loop characteristic polynomial in z, highest power first (see module doc)."""
        t, kp, kd, ki = self.period_s, self.kp_N_per_mm, self.kd_N_s_per_mm, self.ki_N_per_mm_s
        pd = np.array([kp + kd / t, -kd / t])
        zoh = t * t * np.array([1.0, 1.0])
        if ki == 0.0:
            den = 2 * self._m * np.polymul([1.0, -2.0, 1.0], [1.0, 0.0])
            num = np.polymul(zoh, pd)
        else:
            den = 2 * self._m * np.polymul([1.0, -3.0, 3.0, -1.0], [1.0, 0.0])
            num = np.polymul(zoh, np.polyadd(np.polymul(pd, [1.0, -1.0]), [ki * t, 0.0, 0.0]))
        return np.polyadd(den, scale * num)

    def poles(self, scale: float = 1.0) -> np.ndarray:
        """Closed-loop poles z (complex), gains scaled by ``scale``."""
        return np.roots(self.characteristic(scale))

    def pole_radius(self, scale: float = 1.0) -> float:
        """Largest |z| of the closed-loop poles (< 1: stable)."""
        return float(np.abs(self.poles(scale)).max())

    def closed_loop_gain(self, omega_rad_per_s: float) -> complex:
        """G(e^{jwT}) = x / r of the sampled loop at angular frequency w [rad/s]."""
        t = self.period_s
        z = complex(np.exp(1j * omega_rad_per_s * t))
        p = t * t * (z + 1) / (2 * self._m * (z - 1) ** 2)
        c = self.kp_N_per_mm + self.kd_N_s_per_mm * (1 - 1 / z) / t
        c += self.ki_N_per_mm_s * t * z / (z - 1)
        return p * c / (1 + p * c)


def _stable(loop: AxisLoop, scale: float) -> bool:
    return loop.pole_radius(scale) < 1.0


def _edge(loop: AxisLoop, stable: float, unstable: float) -> float:
    """Bisect (in log scale) the gain scale where the loop turns unstable."""
    for _ in range(60):
        mid = math.sqrt(stable * unstable)
        if _stable(loop, mid):
            stable = mid
        else:
            unstable = mid
    return stable


def gain_margin(loop: AxisLoop) -> float:
    """The factor by which all gains together could grow before the sampled loop is unstable.

    Returns the upper edge of the stable range of gain scales containing 1 (> 1 when the loop
    as set is stable); when the loop is unstable as set, the upper edge of the highest stable
    range below 1 (< 1: the gains must shrink by that factor at least), or 0 if none is found.
    inf when no scale up to 1e4 destabilises it.
    """
    stable = [_stable(loop, a) for a in _SCALES]
    if _stable(loop, 1.0):
        above = [a for a, s in zip(_SCALES, stable, strict=True) if a > 1.0 and not s]
        return _edge(loop, 1.0, float(above[0])) if above else math.inf
    below = [
        i
        for i in range(len(_SCALES) - 1)
        if _SCALES[i + 1] < 1.0 and stable[i] and not stable[i + 1]
    ]
    if not below:
        return 0.0
    i = below[-1]
    return _edge(loop, float(_SCALES[i]), float(_SCALES[i + 1]))


def bandwidth_hz(loop: AxisLoop) -> float | None:
    """-3 dB bandwidth of the sampled loop [Hz]: the lowest frequency where |G| falls below
    1/sqrt(2); None if it stays above up to the Nyquist frequency or the loop is unstable."""
    if not _stable(loop, 1.0):
        return None
    nyquist = math.pi / loop.period_s
    grid = np.geomspace(1e-2, nyquist, 2000)
    below = [w for w in grid if abs(loop.closed_loop_gain(float(w))) < 1 / math.sqrt(2)]
    if not below:
        return None
    hi = float(below[0])
    lo = float(grid[max(int(np.searchsorted(grid, hi)) - 1, 0)])
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if abs(loop.closed_loop_gain(mid)) < 1 / math.sqrt(2):
            hi = mid
        else:
            lo = mid
    return hi / (2 * math.pi)


def sampled_mode(loop: AxisLoop) -> tuple[float, float]:
    """Natural frequency [Hz] and damping ratio of the sampled loop's dominant oscillatory pole
    pair (s = ln(z) / T of the complex pole of largest |z|); (nan, nan) if no pole oscillates."""
    poles = [z for z in loop.poles() if z.imag > 1e-12]
    if not poles:
        return math.nan, math.nan
    z = max(poles, key=abs)
    s = complex(np.log(z)) / loop.period_s
    return abs(s) / (2 * math.pi), -s.real / abs(s)


def design_mode(loop: AxisLoop) -> tuple[float, float]:
    """Natural frequency [Hz] and damping ratio of the continuous PD design:
    wn = sqrt(kp / m'), zeta = kd / (2 sqrt(kp m'))."""
    m = loop.mass_kg * 1e-3
    wn = math.sqrt(loop.kp_N_per_mm / m)
    return wn / (2 * math.pi), loop.kd_N_s_per_mm / (2 * math.sqrt(loop.kp_N_per_mm * m))


def kv_per_s(kp_N_per_mm: float, kd_N_s_per_mm: float) -> float:
    """Position-loop gain Kv = kp / kd [1/s] of the equivalent cascade (inf when kd = 0)."""
    return kp_N_per_mm / kd_N_s_per_mm if kd_N_s_per_mm > 0 else math.inf
