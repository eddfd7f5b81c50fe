"""The planner's merge of break points gives np.union1d's array, bit for bit."""

from __future__ import annotations

import numpy as np

from gantry_sim.controller.planner.knots import union_sorted


def test_merged_break_points_are_numpy_s_union_bit_for_bit() -> None:
    """Random times and fractions with repeats (the planner's inputs: not negative), and
    negative numbers, signed zeros and NaNs (which go to NumPy itself)."""
    rng = np.random.default_rng(12)
    for trial in range(3000):
        n, m = rng.integers(0, 60, 2)
        a = np.round(rng.random(n) * 16) / 16
        b = list(np.round(rng.random(m) * 16) / 16)
        if trial % 3 == 1:
            a = a * rng.choice([-1.0, 1.0], n)
        if trial % 5 == 2:
            a = np.concatenate((a, [-0.0]))
        if trial % 7 == 3 and n:
            a[0] = np.nan
        want = np.union1d(a, b)
        got = union_sorted(a, b)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), (a, b)


def test_the_first_array_is_not_changed() -> None:
    a = np.array([0.5, 0.0, 0.5])
    assert union_sorted(a, [0.25]).tolist() == [0.0, 0.25, 0.5]
    assert a.tolist() == [0.5, 0.0, 0.5]
