"""The reference stays on a polyline of very short G1 steps (grbl, junction deviation).

Found on OpenBuilds CAM grbl output (ps2cnc/ps2cnc ``readme/004obc.nc``): 0.035 mm steps at
F1000 along a gentle curve, coordinates rounded to 4 decimals. The look-ahead lowered the
junction speeds over many re-planning rounds; a junction whose blend arc's piece first left
the path in the last round was kept, so the reference ran 0.1 mm on along a step and back,
217 um off the program (the blends themselves: 0.03 um). Two things were wrong:

* a point past an arc's end on its circle read as on the arc (a nearly straight blend arc's
  circle is nearly the tangent line: the run-on was invisible);
* the last round kept its offending junctions instead of stopping at them.

The programs here are generated the same way (a circle of 0.035 mm steps rounded to 4
decimals); before the fix the reference left them by 33 um (R 30 mm) and 60 um (R 5 mm).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.dialects import with_segmentation_default
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.moves import Linear
from gantry_sim.controller.planner.plan import plan
from tests.plan_helpers import assert_within_limits, blending


def _steps(radius_mm: float, step_mm: float = 0.035, n: int = 150) -> str:
    lines = ["G21", "G90", "G0 Z0"]
    for i in range(n):
        a = i * step_mm / radius_mm
        x, y = 20 + radius_mm * math.cos(a), 10 + radius_mm * math.sin(a)
        lines.append(f"G1 F1000 X{x:.4f} Y{y:.4f} Z-1.0000")
    return "\n".join([*lines, "M2", ""])


def _distance_to_polyline(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance [mm] of each point of ``q`` (k, 3) to the nearest of segments a[i]-b[i]."""
    d = b - a
    t = np.einsum("kmj,mj->km", q[:, None, :] - a[None], d) / np.einsum("mj,mj->m", d, d)
    foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * d[None]
    return np.linalg.norm(q[:, None, :] - foot, axis=2).min(axis=1)


@pytest.mark.parametrize("radius_mm", [5.0, 30.0])
def test_the_reference_stays_on_a_polyline_of_short_steps(radius_mm: float, machine) -> None:  # type: ignore[no-untyped-def]
    machine = with_segmentation_default(machine, "grbl")
    items = list(interpret_events(_steps(radius_mm), "grbl"))
    steps = [m for m in items if isinstance(m, Linear)]
    p = plan(items, machine)
    tr = p.sample(machine.servo.period_s / 10)
    on = tr.pos[:, 2] < -0.5  # at the cutting depth: the steps
    a = np.array([m.start for m in steps])
    b = np.array([m.end for m in steps])
    off = _distance_to_polyline(tr.pos[on], a, b)
    blends = max(bl.deviation_mm for bl in p.blends)
    assert off.max() <= blends + 1e-3 * 0.5, (off.max(), tr.line[on][off.argmax()])


def test_a_junction_still_offending_is_softened_before_it_becomes_a_stop(
    machine, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    """Past the backoff rounds, a junction whose blend piece still fails first has its two
    moves' tangential acceleration and jerk lowered (the chain's profile ends its ramps with
    less jerk, which leaves room for the curvature's change), and only then stops. On 0.035 mm
    steps along R 30 mm the stops it saves shorten the cycle by a fifth."""
    machine = blending(machine)  # the blends' junctions (the G64 fit has none)
    import importlib

    rounds = importlib.import_module("gantry_sim.controller.planner.rounds")
    machine = with_segmentation_default(machine, "grbl")
    items = list(interpret_events(_steps(30.0, n=300), "grbl"))
    softened = plan(items, machine)
    monkeypatch.setattr(rounds, "SOFTEN_TRIES", 0)
    stopped = plan(items, machine)
    assert softened.duration_s < 0.9 * stopped.duration_s
    tr = softened.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, [m for m in items if isinstance(m, Linear)])
