"""Checks of the overlapped stops of a plan (tests/test_stop_overlap.py,
tests/test_shared_jerk.py): around each overlap, every limit, the feed and the G64 budget."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from gantry_sim.controller.moves import Linear, Rapid
from gantry_sim.controller.planner.blend import REFERENCE_SHARE

SAMPLE_S = 1e-5  # fine samples of the reference around each overlap [s]


def segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    u = np.clip(((q - a) @ d) / (d @ d), 0.0, 1.0)
    return np.linalg.norm(q - (a + np.outer(u, d)), axis=1)


def check_overlaps(p, machine, tolerance_mm: float = 0.01) -> None:
    """Around every overlap, sampled every SAMPLE_S: each axis within its velocity, acceleration
    and jerk (by differences) limits, the path speed within the smaller feed, the reference
    within the budget (P less the reference's share) of the two programmed segments, and the
    corner within it of the reference; the reference continuous in position across the
    overlap's ends; each overlap recorded as a blend of kind "overlap" within P."""
    vmax, amax, jmax = (np.asarray(x) for x in machine.limits.per_axis())
    budget = tolerance_mm - REFERENCE_SHARE * machine.segmentation.chord_tolerance_mm
    for t0, t1 in p.overlaps_s:
        a, b = moves_at(p, t0, t1)
        t = np.arange(max(t0 - 2e-3, 0.0), min(t1 + 2e-3, p.duration_s), SAMPLE_S)
        pos, vel, acc = p.curve.evaluate(t)
        assert (np.abs(vel) <= vmax * (1 + 1e-9)).all()
        assert (np.abs(acc) <= amax * (1 + 1e-9)).all()
        jerk = np.diff(acc, axis=0) / SAMPLE_S
        assert (np.abs(jerk) <= jmax * (1 + 1e-6)).all()
        # continuous: each step is the mean velocity times the step, to second order
        steps = np.diff(pos, axis=0) - 0.5 * (vel[1:] + vel[:-1]) * SAMPLE_S
        assert np.abs(steps).max() < 1e-9
        inside = (t >= t0) & (t < t1)
        feed = min(getattr(m, "feed_mm_per_min", np.inf) for m in (a, b)) / 60.0  # rapids: none
        assert np.linalg.norm(vel[inside], axis=1).max() <= feed * (1 + 1e-9)
        c = np.asarray(a.end, float)
        off = np.minimum(
            segment_distance(pos[inside], np.asarray(a.start, float), c),
            segment_distance(pos[inside], c, np.asarray(b.end, float)),
        )
        assert off.max() <= budget + 1e-12
        assert np.linalg.norm(pos[inside] - c, axis=1).min() <= budget + 1e-12
    kinds = [bl for bl in p.blends if bl.kind == "overlap"]
    assert len(kinds) == len(p.overlaps_s)
    assert all(
        0 < bl.deviation_mm <= bl.tolerance_mm == pytest.approx(tolerance_mm) for bl in kinds
    )


def moves_at(p, t0: float, t1: float):
    """The two straight path moves (feed moves or rapids) an overlap from ``t0`` to ``t1`` [s]
    joins: the pair of consecutive ones whose first holds the reference at its start and whose
    second holds it at its end (the path's moves: a G64 Q merge is one of them)."""
    (start, end), _, _ = p.curve.evaluate(np.array([t0, t1]))
    path = list(p.path_moves)
    best, pair = np.inf, None
    for a, b in pairwise(path):
        straight = isinstance(a, Linear | Rapid) and isinstance(b, Linear | Rapid)
        if straight and a.end == b.start:
            sa = np.asarray(a.start, float)
            ca = np.asarray(a.end, float)
            off = segment_distance(start[None], sa, ca)[0]
            off += segment_distance(end[None], ca, np.asarray(b.end, float))[0]
            if off < best:
                best, pair = off, (a, b)
    assert pair is not None and best < 1e-9
    return pair
