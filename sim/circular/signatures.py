"""Signatures in a traced circle's radial deviation dev(theta) [um] against the angle theta
[rad] about its centre (after ISO 230-4), NumPy only: the 2nd-harmonic ellipse
(:func:`harmonic_ellipse`, axis [deg], magnitude [um]) and the reversal spikes at the quadrant
crossings (:func:`reversal_spikes` [um]). Angles and signs as in :mod:`gantry_sim.sim.circular.figures`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Reversal-spike windows [deg of travel about the crossing], see ``reversal_spikes``.
SPIKE_BASELINE_DEG = 15.0
SPIKE_GAP_DEG = 3.0
SPIKE_WINDOW_DEG = 10.0


@dataclass(frozen=True)
class Ellipse:
    """The 2nd harmonic of the radial deviation, d(theta) ~ (M/2) cos(2 (theta - axis)).

    Attributes:
        axis_deg: direction of the major axis (largest radius) [deg] in [0, 180).
        magnitude_um: major minus minor semi-axis [um] (twice the harmonic's amplitude).
    """

    axis_deg: float
    magnitude_um: float

    def to_json(self) -> dict:
        return {"axis_deg": self.axis_deg, "magnitude_um": self.magnitude_um}


def _harmonics(theta_rad: np.ndarray, dev_um: np.ndarray, order: int = 2) -> np.ndarray:
    """Least-squares coefficients [c0, c1, s1, ..., c_order, s_order] of dev(theta) [um]."""
    cols = [np.ones_like(theta_rad)]
    for k in range(1, order + 1):
        cols += [np.cos(k * theta_rad), np.sin(k * theta_rad)]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), dev_um, rcond=None)
    return coef


def _harmonic_model(theta_rad: np.ndarray, coef: np.ndarray) -> np.ndarray:
    out = np.full_like(theta_rad, coef[0])
    for k in range(1, (len(coef) - 1) // 2 + 1):
        out += coef[2 * k - 1] * np.cos(k * theta_rad) + coef[2 * k] * np.sin(k * theta_rad)
    return out


def harmonic_ellipse(theta_rad: np.ndarray, dev_um: np.ndarray) -> Ellipse:
    """Fit dev = c0 + c1 cos t + s1 sin t + c2 cos 2t + s2 sin 2t; return the 2nd-harmonic ellipse.

    The 1st harmonic (a centre offset) is fitted jointly, so uneven angular sampling does not
    leak into the ellipse. With A = hypot(c2, s2): magnitude = 2 A, axis = atan2(s2, c2) / 2.

    Args:
        theta_rad: (N,) angles of the samples about the centre [rad].
        dev_um: (N,) radial deviation [um].
    """
    coef = _harmonics(theta_rad, dev_um, 2)
    c2, s2 = coef[3], coef[4]
    axis = math.degrees(0.5 * math.atan2(s2, c2)) % 180.0
    return Ellipse(axis_deg=float(axis), magnitude_um=float(2.0 * math.hypot(c2, s2)))


def reversal_spikes(theta_rad: np.ndarray, dev_um: np.ndarray, sense: float) -> list[float]:
    """Reversal spike [um] at each quadrant crossing theta_k = 0, 90, 180, 270 deg.

    Definition. Let rho = dev - (harmonics 0..2 of dev), the deviation with the centre offset
    and the ellipse removed, and psi = the angle travelled since the crossing, wrapped to
    (-180, 180] deg (positive after the crossing in the direction of motion). The baseline is
    the straight line (in psi) fitted to rho over the neighbourhood just before the crossing,
    psi in [-SPIKE_BASELINE_DEG, -SPIKE_GAP_DEG]. The spike is the residual rho - baseline of
    largest magnitude over psi in [-SPIKE_GAP_DEG, +SPIKE_WINDOW_DEG], signed (positive
    outward). A friction spike that recovers gives its peak height; a step (a pure PD loop
    whose friction offset reverses with the axis) gives the step height; a smooth path gives
    about 0. Angles are positions on the circle, so the windows wrap around the data's ends.

    Args:
        theta_rad: (N,) angles about the LSQ centre [rad].
        dev_um: (N,) radial deviation about the LSQ centre [um].
        sense: +1 if theta increases with time, -1 if it decreases.

    Returns:
        4 values [um], in the order theta_k = 0, 90, 180, 270 deg (nan where a window is empty).
    """
    rho = dev_um - _harmonic_model(theta_rad, _harmonics(theta_rad, dev_um, 2))
    lo, gap, hi = (math.radians(v) for v in (SPIKE_BASELINE_DEG, SPIKE_GAP_DEG, SPIKE_WINDOW_DEG))
    spikes = []
    for k in range(4):
        psi = np.angle(np.exp(1j * sense * (theta_rad - k * math.pi / 2)))
        before = (psi >= -lo) & (psi <= -gap)
        after = (psi >= -gap) & (psi <= hi)
        if before.sum() < 2 or not after.any():
            spikes.append(float("nan"))
            continue
        slope, offset = np.polyfit(psi[before], rho[before], 1)
        resid = rho[after] - (offset + slope * psi[after])
        spikes.append(float(resid[np.argmax(np.abs(resid))]))
    return spikes


#: where the level after a crossing is read [deg of travel after it], see ``reversal_steps``
STEP_AFTER_DEG = (SPIKE_WINDOW_DEG, SPIKE_WINDOW_DEG + SPIKE_BASELINE_DEG - SPIKE_GAP_DEG)


def reversal_steps(theta_rad: np.ndarray, dev_um: np.ndarray, sense: float) -> list[float]:
    """The step that persists at each quadrant crossing theta_k = 0, 90, 180, 270 deg [um].

    psi as in :func:`reversal_spikes`; rho = dev minus its harmonics 0..2, fitted jointly with
    the two step patterns sign(v_a) cos theta and sign(v_b) sin theta (so that the steps do not
    bend the harmonics; the steps stay in rho). A straight line (in psi) is fitted to rho
    before the crossing (psi in [-SPIKE_BASELINE_DEG, -SPIKE_GAP_DEG]) and one after it, once a
    spike has died away (psi in STEP_AFTER_DEG); the step is the after-line minus the
    before-line at psi = 0, signed (positive: the trace moves outward). The lines are fitted to
    rho / cos(psi), since lost motion along the reversing axis moves the radius by its step
    times cos(psi) on either side. A spike that recovers
    gives about 0, backlash or a PD loop's friction lag its full step, a smooth path about 0.

    Returns:
        4 values [um] in the order theta_k = 0, 90, 180, 270 deg (nan where a window is empty).
    """
    harmonics = [np.ones_like(theta_rad)]
    for k in (1, 2):
        harmonics += [np.cos(k * theta_rad), np.sin(k * theta_rad)]
    c, sn = np.cos(theta_rad), np.sin(theta_rad)
    step_patterns = [np.sign(-sense * sn) * c, np.sign(sense * c) * sn]
    design = np.column_stack(harmonics + step_patterns)
    coef, *_ = np.linalg.lstsq(design, dev_um, rcond=None)
    rho = dev_um - design[:, :5] @ coef[:5]
    lo, gap = math.radians(SPIKE_BASELINE_DEG), math.radians(SPIKE_GAP_DEG)
    a0, a1 = (math.radians(v) for v in STEP_AFTER_DEG)
    steps = []
    for k in range(4):
        psi = np.angle(np.exp(1j * sense * (theta_rad - k * math.pi / 2)))
        before = (psi >= -lo) & (psi <= -gap)
        after = (psi >= a0) & (psi <= a1)
        if before.sum() < 2 or after.sum() < 2:
            steps.append(float("nan"))
            continue
        # A step of lost motion along the reversing axis scales as cos(psi) about it.
        level = rho / np.cos(psi)
        level_before = np.polyfit(psi[before], level[before], 1)[1]
        level_after = np.polyfit(psi[after], level[after], 1)[1]
        steps.append(float(level_after - level_before))
    return steps
