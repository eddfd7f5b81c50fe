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
    ellipse: the 2nd harmonic of the deviation about the LSQ centre, see ``harmonic_ellipse``.
    reversal_spikes_um: one value per quadrant crossing, see ``reversal_spikes``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controller.units import UM_PER_MM

#: (a, b) indices of the plane's 2-D coordinates in (x, y, z), in the order the plane is named.
PLANE_2D: dict[str, tuple[int, int]] = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}

#: Reversal-spike windows [deg of travel about the crossing], see ``reversal_spikes``.
SPIKE_BASELINE_DEG = 15.0
SPIKE_GAP_DEG = 3.0
SPIKE_WINDOW_DEG = 10.0


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

    def to_json(self) -> dict:
        """The contract's per-direction object (exactly its keys)."""
        return {
            "circular_deviation_um": self.circular_deviation_um,
            "radial_deviation_um": {
                "max": self.radial_deviation_max_um,
                "min": self.radial_deviation_min_um,
            },
            "reversal_spikes_um": [None if math.isnan(v) else v for v in self.reversal_spikes_um],
            "centre_offset_um": list(self.centre_offset_um),
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
    plane: str, radius_mm: float, feed_mm_per_min: float, cw: CircleAnalysis, ccw: CircleAnalysis
) -> dict:
    """The ``gantry ballbar`` contract object.

    The "ellipse" gives the CCW run's axis and magnitude (the mathematically positive
    direction); when it flips with direction, the CW run's axis is about 90 deg away.
    """
    return {
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
