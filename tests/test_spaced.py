"""``spaced`` is ``np.linspace(0.0, stop, num)`` bit for bit (the planner samples every Ruckig
piece and checks every corner blend with it: a different last bit could change a plan)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.planner.spaced import spaced


@settings(max_examples=300, deadline=None)
@given(
    stop=st.one_of(
        st.floats(0.0, 10.0),
        st.floats(0.0, 1e-300),  # steps that round to 0 or to subnormals
        st.floats(allow_nan=False, allow_infinity=False),
        st.sampled_from([0.0, -0.0, 5e-324, float("inf"), float("nan")]),
    ),
    num=st.integers(0, 70),
)
def test_spaced_is_numpys_linspace(stop, num):
    with np.errstate(invalid="ignore", over="ignore"):
        got, want = spaced(stop, num), np.linspace(0.0, stop, num)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert np.array_equal(got, want, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(want))


def test_spaced_gives_a_new_array_each_time():
    a = spaced(1.0, 5)
    a[0] = 7.0
    assert spaced(1.0, 5)[0] == 0.0
