"""sim.json_text.indented writes what json.dumps(value, indent=2) writes, character for
character, for flat objects (its own path) and anything else (json's)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.sim.json_text import indented

SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text()
)


@given(st.dictionaries(st.text(), SCALARS, max_size=8))
def test_flat_objects_as_json_writes_them(value):
    assert indented(value) == json.dumps(value, indent=2)


@given(st.recursive(SCALARS, lambda inner: st.lists(inner) | st.dictionaries(st.text(), inner)))
def test_any_json_value_as_json_writes_it(value):
    assert indented(value) == json.dumps(value, indent=2)


@pytest.mark.parametrize(
    "value",
    [
        {"line": 3, "kind": "arc", "max_error_um": 1.25, "rms_error_um": 0.5, "time_s": 0.001},
        {"nan": math.nan, "inf": math.inf, "-inf": -math.inf, "é": 'ü\n"', "t": True},
        {"numpy": np.float64(0.1), "flag": False, "none": None},
        {1: 2.0},  # a non-string key: json's own conversion
        {"nested": [1, {"a": 2}]},
        {},
        [],
    ],
)
def test_examples_as_json_writes_them(value):
    assert indented(value) == json.dumps(value, indent=2)


def test_what_json_refuses_is_refused():
    with pytest.raises(TypeError):
        indented({"count": np.int64(3)})
    with pytest.raises(TypeError):
        json.dumps({"count": np.int64(3)}, indent=2)
