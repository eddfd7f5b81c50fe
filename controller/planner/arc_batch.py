"""Arc geometry for many arcs at once: each row computed exactly as
:mod:`gantry_sim.controller.arcs` computes it for one arc (the same operations, element by
element), so a batch gives the numbers bit for bit, in a few numpy calls instead of a few per
arc.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gantry_sim.controller.arcs import arc_frame
from gantry_sim.controller.moves import Arc
from gantry_sim.controller.planes import PLANE_AXES


def arc_derivatives_many(
    arcs: Sequence[Arc], us: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`gantry_sim.controller.arcs.arc_derivatives` of each arc at its fractions ``us[i]``,
    stacked: dp/du and d2p/du2 (sum of the sizes, 3) [mm]."""
    counts = [u.size for u in us]
    frames = [arc_frame(a) for a in arcs]

    def rows(values: list[float]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=float), counts)

    u = np.concatenate(us) if us else np.zeros(0)
    a = rows([f.sigma * arc.angle for f, arc in zip(frames, arcs, strict=True)])
    r0, r1 = rows([f.r0_mm for f in frames]), rows([f.r1_mm for f in frames])
    theta = rows([f.theta0_rad for f in frames]) + a * u
    r = r0 + (r1 - r0) * u
    dr = r1 - r0
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    axes = np.repeat(np.array([PLANE_AXES[arc.plane] for arc in arcs], dtype=np.intp), counts, 0)
    at = np.arange(u.size)
    d1 = np.zeros((u.size, 3))
    d2 = np.zeros((u.size, 3))
    d1[at, axes[:, 0]] = dr * cos_t - r * a * sin_t
    d1[at, axes[:, 1]] = dr * sin_t + r * a * cos_t
    d1[at, axes[:, 2]] = rows([f.h1_mm - f.h0_mm for f in frames])
    d2[at, axes[:, 0]] = -2.0 * dr * a * sin_t - r * a * a * cos_t
    d2[at, axes[:, 1]] = 2.0 * dr * a * cos_t - r * a * a * sin_t
    return d1, d2
