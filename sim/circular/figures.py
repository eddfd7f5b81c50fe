"""Circular-test (ballbar) figures from a traced circle, after ISO 230-4. NumPy only.

Coordinates. A circle in plane "XY", "XZ" or "YZ" is analysed in that plane's 2-D coordinates
(a, b) in the order the plane is named: XY -> (X, Y), XZ -> (X, Z), YZ -> (Y, Z) [mm]. Angles
theta [deg] are measured about a centre from +a towards +b; results in [0, 360) or [0, 180).
Quadrant crossings, where one axis reverses, lie at theta = 0, 90, 180, 270 deg.
(In XZ, G2 "clockwise seen from +Y" turns from +X towards +Z, i.e. increasing theta.)

Sign convention: a radial deviation is the traced radius minus a reference radius [um],
positive outside the circle.

Figures (``analyse_circle``):
    centre_offset_um   [a, b]: least-squares (LSQ) centre minus the nominal centre.
    circular_deviation_um   G: max - min traced radius about the LSQ centre (the minimum radial
        zone about that centre) over the 360-degree data arc.
    radial_deviation_um     F max / min: max and min of (traced radius - nominal radius) about
        the nominal centre (the ballbar's pivot).
    ellipse: the 2nd harmonic of the deviation about the LSQ centre, see
        :func:`gantry_sim.sim.circular.signatures.harmonic_ellipse`.
    reversal_spikes_um: one value per quadrant crossing, see
        :func:`gantry_sim.sim.circular.signatures.reversal_spikes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gantry_sim.controller.planes import PLANE_2D
from gantry_sim.controller.units import UM_PER_MM
from gantry_sim.sim.circular.diagnostics import DirectionData
from gantry_sim.sim.circular.signatures import (
    Ellipse,
    harmonic_ellipse,
    reversal_spikes,
    reversal_steps,
)

#: (a, b) indices of the plane's 2-D coordinates in (x, y, z), in the order the plane is named.


def plane_coords(points: np.ndarray, plane: str) -> np.ndarray:
    """Points (N, 3) [mm] -> their (N, 2) coordinates (a, b) in ``plane`` [mm]."""
    if plane not in PLANE_2D:
        raise ValueError(f"plane must be one of {', '.join(PLANE_2D)}, got {plane!r}")
    ia, ib = PLANE_2D[plane]
    pts = np.asarray(points, dtype=float)
    return np.column_stack((pts[:, ia], pts[:, ib]))


def fit_circle(ab: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through 2-D points: min sum (|p - c| - r)^2.

    Kasa's algebraic fit (linear in c and r^2 - |c|^2) gives the start; Gauss-Newton on the
    geometric residuals refines it (converges in a few steps for ballbar data, where the
    deviations are micrometres on a radius of millimetres).

    Args:
        ab: (N, 2) points [mm], N >= 3, not collinear.

    Returns:
        (centre (2,) [mm], radius [mm]).
    """
    p = np.asarray(ab, dtype=float)
    # Kasa: |p|^2 = 2 c.p + (r^2 - |c|^2), linear least squares in (c_a, c_b, k).
    design = np.column_stack((2.0 * p, np.ones(len(p))))
    sol, *_ = np.linalg.lstsq(design, (p**2).sum(axis=1), rcond=None)
    c = sol[:2]
    r = math.sqrt(max(sol[2] + c @ c, 0.0))
    for _ in range(20):
        d = p - c
        dist = np.hypot(d[:, 0], d[:, 1])
        res = dist - r
        # d(res)/dc = -(p - c)/|p - c|, d(res)/dr = -1.
        jac = np.column_stack((-d / dist[:, None], -np.ones(len(p))))
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        c = c + step[:2]
        r = r + step[2]
        if np.abs(step).max() < 1e-12 * max(r, 1.0):
            break
    return c, float(r)


@dataclass(frozen=True)
class CircleAnalysis:
    """Ballbar figures of one traced circle (see the module docstring for definitions).

    Attributes:
        direction: "cw" or "ccw" as programmed.
        theta_deg: (N,) angle of each sample about the LSQ centre [deg], in [0, 360).
        deviation_um: (N,) traced radius - LSQ radius about the LSQ centre [um].
        fitted_radius_mm: LSQ radius [mm].
        centre_offset_um: LSQ centre - nominal centre, (a, b) [um].
        circular_deviation_um: G [um].
        radial_deviation_max_um / radial_deviation_min_um: F max / min [um].
        reversal_spikes_um: 4 values at theta 0, 90, 180, 270 deg [um].
        ellipse: the 2nd harmonic of deviation_um.
        ab_mm: (N, 2) the analysed points [mm] (for the bidirectional deviation).
        reversal_steps_um: 4 persistent steps at theta 0, 90, 180, 270 deg [um] (added).
        nominal: angle about the nominal centre [rad], traced radius minus nominal radius
            about it [um] and sense (+1 CCW, -1 CW): the diagnostics' input.
    """

    direction: str
    theta_deg: np.ndarray
    deviation_um: np.ndarray
    fitted_radius_mm: float
    centre_offset_um: tuple[float, float]
    circular_deviation_um: float
    radial_deviation_max_um: float
    radial_deviation_min_um: float
    reversal_spikes_um: tuple[float, ...]
    ellipse: Ellipse
    ab_mm: np.ndarray
    reversal_steps_um: tuple[float, ...]
    nominal: DirectionData

    def to_json(self) -> dict:
        """The contract's per-direction object (its keys, then the added reversal steps)."""
        return {
            "circular_deviation_um": self.circular_deviation_um,
            "radial_deviation_um": {
                "max": self.radial_deviation_max_um,
                "min": self.radial_deviation_min_um,
            },
            "reversal_spikes_um": [None if math.isnan(v) else v for v in self.reversal_spikes_um],
            "centre_offset_um": list(self.centre_offset_um),
            "reversal_steps_um": [None if math.isnan(v) else v for v in self.reversal_steps_um],
        }


def data_arc(ab: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Boolean mask keeping the first 360 degrees of travel about ``centre`` (trims overrun)."""
    theta = np.unwrap(np.arctan2(ab[:, 1] - centre[1], ab[:, 0] - centre[0]))
    travel = np.abs(theta - theta[0])
    return travel <= 2.0 * math.pi + 1e-12


def analyse_circle(
    ab_mm: np.ndarray, centre_mm: np.ndarray, radius_mm: float, direction: str
) -> CircleAnalysis:
    """Ballbar figures of one traced circle.

    Args:
        ab_mm: (N, 2) traced points in the plane's coordinates [mm], in time order, covering
            one full circle (samples past 360 degrees of travel are dropped).
        centre_mm: (2,) nominal centre [mm].
        radius_mm: nominal radius [mm].
        direction: "cw" or "ccw" (as programmed; only stored).
    """
    centre_nom = np.asarray(centre_mm, dtype=float)
    ab = np.asarray(ab_mm, dtype=float)
    ab = ab[data_arc(ab, centre_nom)]
    if len(ab) < 16:
        raise ValueError(f"too few samples on the circle ({len(ab)}); need at least 16")
    c, r = fit_circle(ab)
    d = ab - c
    theta = np.arctan2(d[:, 1], d[:, 0])
    dev_um = (np.hypot(d[:, 0], d[:, 1]) - r) * UM_PER_MM
    nom = ab - centre_nom
    radial_um = (np.hypot(nom[:, 0], nom[:, 1]) - radius_mm) * UM_PER_MM
    sense = 1.0 if np.unwrap(theta)[-1] > np.unwrap(theta)[0] else -1.0
    offset = (c - centre_nom) * UM_PER_MM
    return CircleAnalysis(
        direction=direction,
        theta_deg=np.degrees(theta) % 360.0,
        deviation_um=dev_um,
        fitted_radius_mm=r,
        centre_offset_um=(float(offset[0]), float(offset[1])),
        circular_deviation_um=float(dev_um.max() - dev_um.min()),
        radial_deviation_max_um=float(radial_um.max()),
        radial_deviation_min_um=float(radial_um.min()),
        reversal_spikes_um=tuple(reversal_spikes(theta, dev_um, sense)),
        ellipse=harmonic_ellipse(theta, dev_um),
        ab_mm=ab,
        reversal_steps_um=tuple(reversal_steps(theta, dev_um, sense)),
        nominal=DirectionData(np.arctan2(nom[:, 1], nom[:, 0]), radial_um, sense),
    )


def bidirectional_deviation_um(cw: CircleAnalysis, ccw: CircleAnalysis) -> float:
    """ISO 230-4 bidirectional circular deviation G(b) [um].

    The radial zone (max - min radius) of the CW and CCW traces together, about the
    least-squares circle fitted to both together.
    """
    both = np.vstack((cw.ab_mm, ccw.ab_mm))
    c, _ = fit_circle(both)
    r = np.hypot(both[:, 0] - c[0], both[:, 1] - c[1])
    return float((r.max() - r.min()) * UM_PER_MM)


def circular_hysteresis_um(cw: CircleAnalysis, ccw: CircleAnalysis) -> float:
    """ISO 230-4 circular hysteresis H [um]: the largest radial difference between the CW and
    CCW traces at the same angle, both about the least-squares circle fitted to both together
    (the CW radius is interpolated, periodically, at the CCW samples' angles)."""
    both = np.vstack((cw.ab_mm, ccw.ab_mm))
    c, _ = fit_circle(both)
    radius_angle = []
    for res in (cw, ccw):
        d = res.ab_mm - c
        radius_angle.append((np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0])))
    (r_cw, t_cw), (r_ccw, t_ccw) = radius_angle
    order = np.argsort(t_cw)
    r_at = np.interp(t_ccw, t_cw[order], r_cw[order], period=2.0 * math.pi)
    return float(np.abs(r_ccw - r_at).max() * UM_PER_MM)


def ellipse_flips(cw: Ellipse, ccw: Ellipse, min_magnitude_um: float = 0.1) -> bool:
    """Whether the ellipse's axis flips with direction.

    True when both ellipses are at least ``min_magnitude_um`` [um] (below that the axis is
    noise) and their axes differ by more than 45 deg (modulo 180): the signature of a servo
    mismatch (unequal axis lags), where squareness or scale errors keep their axis.
    """
    if min(cw.magnitude_um, ccw.magnitude_um) < min_magnitude_um:
        return False
    diff = abs(cw.axis_deg - ccw.axis_deg) % 180.0
    return min(diff, 180.0 - diff) > 45.0


def ballbar_json(
    plane: str,
    radius_mm: float,
    feed_mm_per_min: float,
    cw: CircleAnalysis,
    ccw: CircleAnalysis,
    extra: dict | None = None,
) -> dict:
    """The ``gantry ballbar`` contract object, then the keys of ``extra`` (added ones).

    The "ellipse" gives the CCW run's axis and magnitude (the mathematically positive
    direction); when it flips with direction, the CW run's axis is about 90 deg away.
    """
    out = {
        "plane": plane,
        "radius_mm": float(radius_mm),
        "feed_mm_per_min": float(feed_mm_per_min),
        "cw": cw.to_json(),
        "ccw": ccw.to_json(),
        "bidirectional_deviation_um": bidirectional_deviation_um(cw, ccw),
        "ellipse": {
            "axis_deg": ccw.ellipse.axis_deg,
            "magnitude_um": ccw.ellipse.magnitude_um,
            "flips_with_direction": ellipse_flips(cw.ellipse, ccw.ellipse),
        },
    }
    out["circular_hysteresis_um"] = circular_hysteresis_um(cw, ccw)
    out.update(extra or {})
    return out
