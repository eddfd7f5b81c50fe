"""Unit conventions and the few conversions the controller needs.

Names carry their units where a reader could doubt them: ``feed_mm_per_min``,
``max_jerk_mm_per_s3``, ``err_um``. Internally: mm, s, mm/s, mm/s^2, mm/s^3, N.
"""

from __future__ import annotations

MM_PER_INCH = 25.4
S_PER_MIN = 60.0
UM_PER_MM = 1000.0


def mm_per_min_to_mm_per_s(feed_mm_per_min: float) -> float:
    """Convert a feed [mm/min] to a speed [mm/s]."""
    return feed_mm_per_min / S_PER_MIN


def mm_per_s_to_mm_per_min(speed_mm_per_s: float) -> float:
    """Convert a speed [mm/s] to a feed [mm/min]."""
    return speed_mm_per_s * S_PER_MIN
