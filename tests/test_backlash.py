"""Backlash in the transmission: the play operator and the reversal spikes it puts on a circle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.controller.transmission import motor_side_mm
from gantry_sim.sim.api import run_program
from gantry_sim.sim.circular.signatures import reversal_spikes

# ~1 s: lead-in, a full R5 circle at F2000 counter-clockwise about X0 Y0, lead-out
CIRCLE = "G21 G17 G90 G94\nG1 X5 F2000\nG3 I-5 J0\nG1 X0\nM2\n"


def test_play_operator_carries_the_motor_side_only_at_the_faces_of_the_gap():
    p = 0.0
    seen = []
    for x in (0.004, 0.01, 0.02, 0.015, 0.011, 0.0, -0.01):
        p = motor_side_mm(x, p, 0.01)
        seen.append(p)
    # inside +-0.005 nothing moves; then dragged at x - 0.005; on the way back it waits a full
    # 0.01 of axis travel before it follows at x + 0.005
    assert seen == pytest.approx([0.0, 0.005, 0.015, 0.015, 0.015, 0.005, -0.005])


@given(
    st.lists(st.floats(-5.0, 5.0), min_size=1, max_size=30),
    st.floats(0.0, 0.1),
)
def test_play_operator_keeps_the_axis_within_half_the_gap(path, backlash):
    p = path[0]
    for x in path:
        p = motor_side_mm(x, p, backlash)
        assert abs(x - p) <= 0.5 * backlash + 1e-12
    assert motor_side_mm(1.25, 7.0, 0.0) == 1.25  # no backlash: the encoder is the axis


def _spike_at_180_um(machine, backlash_mm: float) -> float:
    """The reversal spike [um] where X reverses (theta = 180 deg) on the circle above."""
    m = machine.with_changes("sim", backlash_mm=[backlash_mm, 0.0, 0.0]).with_changes(
        "servo",
        ff_friction=[1.0, 1.0, 1.0],  # friction's own step out of the way
    )
    tr = run_program(CIRCLE, machine=m).trace
    on = tr.line == 3
    theta = np.arctan2(tr.pos[on, 1], tr.pos[on, 0])
    dev_um = (np.hypot(tr.pos[on, 0], tr.pos[on, 1]) - 5.0) * 1000
    spikes = reversal_spikes(theta, dev_um, 1.0)
    assert abs(spikes[1]) < 5.0  # Y reverses at 90 deg: Y has no backlash, no spike
    return spikes[2]


def test_reversal_spike_tracks_the_backlash(machine):
    """X's backlash shows where X reverses: the axis crosses the gap while the motor-side
    encoder stands still, and the loop pulls the circle inward by about the backlash."""
    none = _spike_at_180_um(machine, 0.0)
    b20 = _spike_at_180_um(machine, 0.02)
    b40 = _spike_at_180_um(machine, 0.04)
    assert abs(none) < 5.0
    assert -1.6 * 20 < b20 < -0.8 * 20
    assert -1.6 * 40 < b40 < -0.8 * 40
    assert (b40 - none) / (b20 - none) == pytest.approx(2.0, rel=0.2)


def test_stateful_loop_with_zero_state_terms_is_the_pd_loop_bit_for_bit(machine, monkeypatch):
    """The runner's stateful loop (integral, backlash) with ki = 0 and no backlash computes the
    same trace and forces as its unrolled PD loop, to the last bit."""
    from gantry_sim.controller.servo import DiscretePD
    from gantry_sim.sim import servo_loop

    plain = run_program(CIRCLE, machine=machine).trace

    chunks = []

    class Forced(DiscretePD):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            self.has_integral = True  # take the stateful path with ki = 0

    class Counted(servo_loop.StatefulTicks):
        def run(self, b, ref, record):
            chunks.append(len(b))
            return super().run(b, ref, record)

    monkeypatch.setattr(servo_loop, "DiscretePD", Forced)
    monkeypatch.setattr(servo_loop, "StatefulTicks", Counted)
    stateful = run_program(CIRCLE, machine=machine).trace
    assert sum(chunks) == plain.t.size
    assert np.array_equal(stateful.pos, plain.pos)
    assert np.array_equal(stateful.force_N, plain.force_N)
