"""Ballbar diagnostics in the terms ballbar users read (Renishaw QC20 style, ISO 230-4 terms).

One linear least-squares model is fitted to the radial deviation of BOTH directions at once,
about the nominal centre, against the angle theta [rad] about it (angles, (a, b) and signs as in
:mod:`gantry_sim.sim.circular.figures`). For a direction of sense s (+1 CCW, theta increasing;
-1 CW) each axis's velocity sign is u_a = sign(-s sin theta), u_b = sign(s cos theta): axis a
reverses at theta = 0 and 180 deg, axis b at 90 and 270 deg. Model [um]:

    dev = r0_d + p_d cos t + q_d sin t       radius and centre, per direction (nuisance)
        + S cos 2t                           scaling mismatch (same in both directions)
        + Q sin 2t                           squareness (same in both directions)
        + M s sin 2t                         servo mismatch (flips with the direction)
        - (B_a / 2) u_a cos t - (B_b / 2) u_b sin t      backlash: lost motion B along the
                                             reversing axis, the position lagging by B/2
        + (L_a / 2) u_a sin t + (L_b / 2) u_b cos t      lateral play: when axis a reverses the
                                             path shifts along b by L_a (b: along a by L_b)

The samples within REVERSAL_ZONE_DEG after each quadrant crossing (in the direction of travel)
are left out of the fit: the reversal spikes and the step's settling live there, and a step
that settles late would otherwise leak into the 2nd harmonics. Figures from the coefficients:

    servo mismatch [ms]  tau_a - tau_b = 2 M / v (v the path speed [mm/s]; M [um]): a lag tau per
                         axis traces R (1 + (w/2)(tau_a - tau_b) sin 2t) at w = v / R; positive
                         when axis a lags axis b.
    squareness [um/m]    2 Q / R * 1e3 (Q [um], R [mm]): b moving along (alpha, 1) traces
                         R (1 + (alpha/2) sin 2t); positive when +a and +b meet at LESS than
                         90 deg (the trace is long along the +45 deg diagonal).
    scaling mismatch [ppm]  2 S / R * 1e3: scales (1 + k_a), (1 + k_b) trace
                         R (1 + ((k_a - k_b)/2) cos 2t); positive when a travels further than b.
    backlash [um]        B_a, B_b: the radial step at that axis's reversal points (a PD loop's
                         friction lag 2 F / kp has the same signature); positive = lost motion.
    lateral play [um]    L_a, L_b (signed): the sideways shift of the path when that axis reverses.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gantry_sim.sim.circular.signatures import SPIKE_WINDOW_DEG

#: degrees of travel after each quadrant crossing left out of the model fit
REVERSAL_ZONE_DEG = SPIKE_WINDOW_DEG
#: names of the model's shared terms, in column order after the per-direction ones
TERMS = ("scale", "square", "servo", "backlash_a", "backlash_b", "lateral_a", "lateral_b")


@dataclass(frozen=True)
class DirectionData:
    """One direction's samples for the fit.

    Attributes:
        theta_rad: (N,) angle about the nominal centre [rad].
        dev_um: (N,) traced radius minus nominal radius about the nominal centre [um].
        sense: +1 (CCW, theta increases with time) or -1 (CW).
    """

    theta_rad: np.ndarray
    dev_um: np.ndarray
    sense: float


@dataclass(frozen=True)
class Diagnostics:
    """The fitted figures (see the module docstring for methods and signs).

    Attributes:
        servo_mismatch_ms: lag of axis a minus lag of axis b [ms].
        squareness_um_per_m: out-of-squareness of a and b [um/m].
        scaling_mismatch_ppm: scale of a minus scale of b [ppm].
        backlash_um: (a, b) lost motion per axis [um].
        lateral_play_um: (a, b) sideways shift when the axis reverses [um].
        path_speed_mm_per_s: the speed the servo mismatch was converted with [mm/s].
        residual_rms_um: RMS of the deviation the model leaves unexplained [um].
    """

    servo_mismatch_ms: float
    squareness_um_per_m: float
    scaling_mismatch_ppm: float
    backlash_um: tuple[float, float]
    lateral_play_um: tuple[float, float]
    path_speed_mm_per_s: float
    residual_rms_um: float


def _shared_columns(theta: np.ndarray, s: float) -> np.ndarray:
    """(N, 7) columns of TERMS for samples at ``theta`` [rad] of sense ``s``."""
    c, sn = np.cos(theta), np.sin(theta)
    u_a, u_b = np.sign(-s * sn), np.sign(s * c)
    return np.column_stack(
        (
            np.cos(2 * theta),
            np.sin(2 * theta),
            s * np.sin(2 * theta),
            -0.5 * u_a * c,
            -0.5 * u_b * sn,
            0.5 * u_a * sn,
            0.5 * u_b * c,
        )
    )


def outside_reversal_zones(theta_rad: np.ndarray, sense: float, zone_deg: float) -> np.ndarray:
    """Mask of samples NOT within ``zone_deg`` of travel after a quadrant crossing."""
    travelled = np.degrees(sense * np.asarray(theta_rad)) % 90.0
    return travelled > zone_deg


def fit_diagnostics(
    directions: Sequence[DirectionData],
    radius_mm: float,
    path_speed_mm_per_s: float,
    zone_deg: float = REVERSAL_ZONE_DEG,
) -> Diagnostics:
    """Fit the model of the module docstring to both directions at once.

    Args:
        directions: the CCW and CW data (one of each; the sense tells them apart).
        radius_mm: nominal radius [mm].
        path_speed_mm_per_s: speed along the circle [mm/s].
        zone_deg: degrees of travel after each crossing left out of the fit.
    """
    n_dir = len(directions)
    rows, rhs = [], []
    for k, d in enumerate(directions):
        keep = outside_reversal_zones(d.theta_rad, d.sense, zone_deg)
        th = np.asarray(d.theta_rad)[keep]
        own = np.zeros((len(th), 3 * n_dir))
        own[:, 3 * k : 3 * k + 3] = np.column_stack((np.ones_like(th), np.cos(th), np.sin(th)))
        rows.append(np.hstack((own, _shared_columns(th, d.sense))))
        rhs.append(np.asarray(d.dev_um)[keep])
    design, y = np.vstack(rows), np.concatenate(rhs)
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    resid = y - design @ coef
    shared = dict(zip(TERMS, coef[3 * n_dir :], strict=True))
    per_mm = 1e3 / radius_mm  # [um] of a 2nd-harmonic coefficient -> [um/m] or [ppm]
    return Diagnostics(
        servo_mismatch_ms=float(2.0 * shared["servo"] / path_speed_mm_per_s),
        squareness_um_per_m=float(2.0 * shared["square"] * per_mm),
        scaling_mismatch_ppm=float(2.0 * shared["scale"] * per_mm),
        backlash_um=(float(shared["backlash_a"]), float(shared["backlash_b"])),
        lateral_play_um=(float(shared["lateral_a"]), float(shared["lateral_b"])),
        path_speed_mm_per_s=float(path_speed_mm_per_s),
        residual_rms_um=float(math.sqrt(np.mean(resid**2))),
    )


def diagnostics_json(diag: Diagnostics, plane: str) -> dict:
    """The "diagnostics" object of ``gantry ballbar`` (per-axis values keyed by axis letter)."""
    a, b = plane[0], plane[1]
    return {
        "servo_mismatch_ms": diag.servo_mismatch_ms,
        "squareness_um_per_m": diag.squareness_um_per_m,
        "scaling_mismatch_ppm": diag.scaling_mismatch_ppm,
        "backlash_um": {a: diag.backlash_um[0], b: diag.backlash_um[1]},
        "lateral_play_um": {a: diag.lateral_play_um[0], b: diag.lateral_play_um[1]},
        "path_speed_mm_per_min": diag.path_speed_mm_per_s * 60.0,
        "model_residual_rms_um": diag.residual_rms_um,
    }
