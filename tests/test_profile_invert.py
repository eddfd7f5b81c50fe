"""Profiles inverted many at once (one padded table) give each profile's own inversion, bit for
bit: where the reference passes an arc length (time, speed, acceleration) must not depend on
which other arcs were planned in the same batch."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.planner import profile as profile_mod
from gantry_sim.controller.planner.profile import Profile1D, invert_many


def _profile(
    rng: np.random.Generator, phases: int, back: bool = False
) -> tuple[Profile1D, np.ndarray]:
    """A profile of ``phases`` constant-jerk phases (some of no time) whose arc length never
    goes back (as a planned profile's; ``back``: whose last phase starts behind the first, as a
    candidate that reverses), and arc lengths along it (its ends, its phase starts, points
    between and just outside)."""
    dur = rng.uniform(0.0, 0.02, phases) * (rng.random(phases) > 0.2)
    v0, a0 = rng.uniform(1.0, 50.0), 0.0
    rows, s = [], 0.0
    for d in dur:
        j = rng.uniform(-2e4, 2e4)
        rows.append((d, s, v0, a0, j))
        s += abs(d * (v0 + d * (0.5 * a0 + d * j / 6.0)))
        v0 = max(v0 + d * (a0 + 0.5 * d * j), 0.0)
        a0 = a0 + d * j
    table = np.array(rows)
    if back and phases > 2:
        table[-1, 1] = -0.5 * s
    starts = table[:, 1]
    queries = np.concatenate((starts, rng.uniform(0.0, max(s, 1e-9), 6), [0.0, s, s + 1e-3, -1e-3]))
    return Profile1D(table), np.sort(queries)


def _one_by_one(queries):
    return [invert_many([q])[0] for q in queries]


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.tuples(st.integers(1, 12), st.booleans(), st.booleans()), max_size=8),
    seed=st.integers(0, 2**31),
)
def test_many_profiles_at_once_invert_as_each_alone(sizes, seed):
    """Each profile's numbers are its own, in any batch: a reversing profile's (searched as
    np.searchsorted searches its unordered starts) and one asked for NaN too."""
    rng = np.random.default_rng(seed)
    queries = []
    for n, back, nan in sizes:
        prof, s = _profile(rng, n, back)
        queries.append((prof, np.append(s, np.nan) if nan else s))
    queries = [(p, s) for p, s in queries if (p.rows[:, 0] > 0).any()]
    if not queries:
        return
    together = invert_many(queries)
    for (prof, s), got in zip(queries, together, strict=True):
        want = profile_mod._invert_one(prof, s)  # the profile alone, its own arrays
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w, equal_nan=True)
    assert all(
        np.array_equal(g, w, equal_nan=True)
        for a, b in zip(together, _one_by_one(queries), strict=True)
        for g, w in zip(a, b, strict=True)
    )


def test_profiles_of_many_phases_are_inverted_alone_with_the_same_numbers(monkeypatch):
    """A profile of more phases than the table takes (a long chain's) is inverted on its own,
    the others in the table: each number as every profile alone gives it."""
    rng = np.random.default_rng(7)
    queries = [_profile(rng, n) for n in (3, 9, profile_mod.TABLE_PHASES + 8, 5)]
    together = invert_many(queries)
    for (prof, s), got in zip(queries, together, strict=True):
        for g, w in zip(got, profile_mod._invert_one(prof, s), strict=True):
            assert np.array_equal(g, w)
    monkeypatch.setattr(profile_mod, "TABLE_PHASES", 0)  # every profile alone
    for a, b in zip(together, invert_many(queries), strict=True):
        for g, w in zip(a, b, strict=True):
            assert np.array_equal(g, w)


def test_a_profile_of_no_time_cannot_be_asked_for_a_point():
    empty = Profile1D(np.array([[0.0, 0.0, 1.0, 0.0, 0.0]]))
    assert invert_many([(empty, np.zeros(0))])[0][0].size == 0
    with pytest.raises(IndexError):
        invert_many([(empty, np.array([0.0]))])
