"""The exact peak path speed of a piece whose axes switch jerk at their own times
(controller/planner/piece_speed.py), against Ruckig's own samples of the same piece."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.controller.planner.piece_speed import (
    axis_speed_bound,
    max_speed_squared,
    peak_speed,
    speed_exceeds,
)
from gantry_sim.controller.planner.ruckig_solver import RuckigRejected, RuckigSolver
from tests.plan_helpers import PLAN_PROPERTY_SETTINGS

vec = st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array)


@PLAN_PROPERTY_SETTINGS
@given(dp=vec, v0=vec, v1=vec, a0=vec, a1=vec, t_min=st.floats(0.0, 0.1))
def test_peak_speed_is_the_largest_speed_of_the_piece(machine, dp, v0, v1, a0, a1, t_min):  # type: ignore[no-untyped-def]
    solver = RuckigSolver(machine.limits)
    start = (np.zeros(3), 40.0 * v0, 400.0 * a0)
    end = (dp, 40.0 * v1, 400.0 * a1)
    try:
        piece = solver.piece(start, end, t_min)
    except RuckigRejected:
        return
    tr = solver._tr3  # the piece just made: sampled by Ruckig itself, 20,001 times
    dense = max(
        float(np.linalg.norm(tr.at_time(t)[1])) for t in np.linspace(0.0, piece.duration_s, 20001)
    )
    exact = peak_speed(piece.phases)
    assert exact >= dense * (1 - 1e-12)  # never below a sample: no bulge missed
    # and no higher than the samples can miss between them (|a| <= 1e4 mm/s^2, 5 us apart)
    assert exact <= dense + 1e4 * piece.duration_s / 20000


def test_peak_speed_of_a_bulge_between_coarse_samples():  # type: ignore[no-untyped-def]
    # X cruises at 6 mm/s for 100 ms; Y steps out and back at 1e5 mm/s^3 in its first 2 ms,
    # peaking at 0.025 mm/s after 1 ms: |v| peaks at sqrt(6^2 + 0.025^2), inside a phase
    ms = 1e-3
    x = ([100 * ms], [0.0], [6.0], [0.0], [0.0])
    y = (
        [ms / 2, ms, ms / 2, 98 * ms],
        [0.0, 0.0, 0.0, 0.0],  # positions do not enter the speed
        [0.0, 0.0125, 0.0125, 0.0],
        [0.0, 50.0, -50.0, 0.0],
        [1e5, -1e5, 1e5, 0.0],
    )
    z = ([100 * ms], [0.0], [0.0], [0.0], [0.0])
    assert peak_speed((x, y, z)) == np.hypot(6.0, 0.025)
    ts = np.linspace(0.0, 100 * ms, 25)  # what 25 samples see
    assert np.hypot(_velocity(x, ts), _velocity(y, ts)).max() == 6.0


def _velocity(axis, ts):  # type: ignore[no-untyped-def]
    dur, _, v, a, j = (np.asarray(c, dtype=float) for c in axis)
    starts = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
    k = np.clip(np.searchsorted(starts, ts, side="right") - 1, 0, dur.size - 1)
    tau = np.minimum(ts - starts[k], dur[k])
    return v[k] + tau * (a[k] + 0.5 * tau * j[k])


@PLAN_PROPERTY_SETTINGS
@given(
    v=st.lists(st.floats(-50.0, 50.0), min_size=9, max_size=9),
    a=st.lists(st.floats(-2000.0, 2000.0), min_size=9, max_size=9),
    j=st.lists(st.floats(-1e5, 1e5), min_size=9, max_size=9),
    h=st.floats(1e-5, 0.05),
)
def test_five_samples_and_the_bound_between_them_cover_the_peak(v, a, j, h):  # type: ignore[no-untyped-def]
    # jerk3.piece_limits_ok samples five points a phase and refines exactly only where the
    # samples plus _between_samples could pass the cap: that sum must never be below the peak
    from gantry_sim.controller.planner.jerk3 import _between_samples

    vs, as_, js = (np.reshape(x, (1, 3, 3)) for x in (v, a, j))
    hh = np.full((1, 1, 1), h)
    taus = np.linspace(0.0, h, 5)[:, None, None, None]
    vel = vs + taus * (as_ + 0.5 * taus * js)
    sampled = np.einsum("fnkd,fnkd->fnk", vel, vel).max(axis=0)
    peak = max_speed_squared(vs[0], as_[0], js[0], np.full(3, h))
    assert np.all(sampled[0] + _between_samples(vs, as_, js, hh)[0] >= peak * (1 - 1e-12))


@PLAN_PROPERTY_SETTINGS
@given(dp=vec, v0=vec, v1=vec, a0=vec, a1=vec, t_min=st.floats(0.0, 0.1))
def test_the_axis_bound_settles_the_feed_check_as_the_exact_peak_does(  # type: ignore[no-untyped-def]
    machine, dp, v0, v1, a0, a1, t_min
):
    # the planner asks speed_exceeds(piece, feed); the cheap per-axis bound may answer only
    # where it lies below the cap, so the answer is the exact peak's at every cap
    solver = RuckigSolver(machine.limits)
    try:
        piece = solver.piece(
            (np.zeros(3), 40.0 * v0, 400.0 * a0), (dp, 40.0 * v1, 400.0 * a1), t_min
        )
    except RuckigRejected:
        return
    exact = peak_speed(piece.phases)
    bound = axis_speed_bound(piece.phases)
    assert bound >= exact * (1 - 1e-12)
    for cap in (0.5 * exact, exact * (1 - 1e-12), exact, exact * (1 + 1e-12), bound, 2.0 * bound):
        assert speed_exceeds(piece.phases, cap) == (exact > cap)


def test_the_axis_bound_of_a_bulge_inside_a_phase_and_of_an_axis_at_rest():  # type: ignore[no-untyped-def]
    ms = 1e-3
    x = ([100 * ms], [0.0], [6.0], [0.0], [0.0])
    y = ([2 * ms], [0.0], [0.0], [100.0], [-1e5])  # out and back: 0.05 mm/s at 1 ms
    z = ([], [], [], [], [])  # no phase: holds its start velocity (none: 0)
    assert np.isclose(axis_speed_bound((x, y, z)), np.hypot(6.0, 0.05), rtol=1e-15, atol=0)
    assert axis_speed_bound((x, y, z)) >= peak_speed((x, y, z))
    assert not speed_exceeds((x, y, z), 6.001) and speed_exceeds((x, y, z), 6.0001)


def test_a_piece_longer_than_asked_carries_no_samples(machine):  # type: ignore[no-untyped-def]
    solver = RuckigSolver(machine.limits)
    start, end = (
        (np.zeros(3), np.zeros(3), np.zeros(3)),
        (np.array([1.0, 0.5, 0.0]), np.zeros(3), np.zeros(3)),
    )
    piece = solver.piece(start, end, 0.0, samples=25)
    assert piece.positions is not None and piece.positions.shape == (25, 3)
    assert solver.piece(start, end, 0.0, 25, piece.duration_s).positions is not None
    assert solver.piece(start, end, 0.0, 25, 0.5 * piece.duration_s).positions is None


@PLAN_PROPERTY_SETTINGS
@given(
    seed=st.integers(0, 2**31),
    rows=st.integers(1, 12),
    per_row_cap=st.booleans(),
)
def test_pieces_checked_together_are_checked_as_each_alone(seed, rows, per_row_cap):  # type: ignore[no-untyped-def]
    # piece_limits_ok checks the speeds only of the pieces that keep the jerk and acceleration
    # limits: the answer of a batch is each piece's own, whichever fail first
    from gantry_sim.controller.planner.jerk3 import jerk3_pairs, piece_limits_ok

    rng = np.random.default_rng(seed)  # about a third break the jerk, a fifth only the speeds
    dur = rng.uniform(0.002, 0.03, rows)
    v0 = rng.normal(0, 25, (rows, 3))
    v1 = v0 + rng.normal(0, 1, (rows, 3)) * rng.uniform(0, 3, (rows, 1))
    a0 = rng.normal(0, 50, (rows, 3))
    a1 = a0 + rng.normal(0, 50, (rows, 3))
    p0 = np.zeros((rows, 3))
    p1 = 0.5 * (v0 + v1) * dur[:, None] + rng.normal(0, 1e-4, (rows, 3))
    _, vs, as_, js = jerk3_pairs(p0, v0, a0, p1, v1, a1, dur)
    lim = ((40.0, 40.0, 40.0), (900.0, 900.0, 900.0), (1e5, 8e4, 1e5))
    cap = rng.uniform(20.0, 80.0, rows) if per_row_cap else 50.0
    together = piece_limits_ok(vs, as_, js, dur, a1, *lim, cap)
    alone = [
        piece_limits_ok(
            vs[i : i + 1],
            as_[i : i + 1],
            js[i : i + 1],
            dur[i : i + 1],
            a1[i : i + 1],
            *lim,
            cap[i : i + 1] if per_row_cap else cap,
        )[0]
        for i in range(rows)
    ]
    assert together.tolist() == alone
