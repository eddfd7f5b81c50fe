"""Saturated ramps on small arcs from rest (controller/planner/saturated_ramp.py, its bounds in
ramp_bounds.py) and their use."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gantry_sim.controller.gcode.dialects import with_segmentation_default
from gantry_sim.controller.gcode.interpreter import interpret_events, parse_program
from gantry_sim.controller.moves import Arc, Linear
from gantry_sim.controller.planner import speedup
from gantry_sim.controller.planner.limits import FollowGeometry, s_curve_time
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.ramp_bounds import CircleLimits, NormLimits
from gantry_sim.controller.planner.saturated_ramp import SHARE, saturated_profile
from gantry_sim.controller.planner.speedup import follow_ok
from tests.plan_helpers import arc, arc_deviation, assert_within_limits

AMAX, JMAX = (3000.0, 2500.0, 3000.0), (1e5, 8e4, 1e5)


def _check_phases(ph, length, v_in, v_out):
    h, s, v, a, j = ph.T
    assert (h > 0).all()
    nxt = np.column_stack(
        [s + h * (v + h * (0.5 * a + h * j / 6.0)), v + h * (a + 0.5 * h * j), a + h * j]
    )
    np.testing.assert_allclose(nxt[:-1], ph[1:, 1:4], atol=1e-9)  # phases join exactly
    np.testing.assert_allclose(nxt[-1], (length, v_out, 0.0), atol=1e-9)  # exact end
    assert (s[0], v[0], a[0]) == (0.0, v_in, 0.0)


@pytest.mark.parametrize(
    ("radius", "v_in", "v_out"), [(1.0, 0.0, 0.0), (2.0, 3.0, 0.0), (5.0, 0.0, 2.0)]
)
def test_orientation_free_ramps_are_continuous_end_exactly_and_follow_the_arc(radius, v_in, v_out):
    length = 2 * math.pi * radius
    lim = NormLimits(1 / radius, 1 / radius**2, SHARE * 2500.0, SHARE * 8e4)
    ph = saturated_profile(length, v_in, v_out, 100.0, (lim, lim))
    assert ph is not None
    _check_phases(ph.rows, length, v_in, v_out)
    fg = FollowGeometry((0, 1, 2), 0.0, 1 / radius, 1 / radius**2, 100.0)
    assert follow_ok(ph, fg, 100.0, AMAX, JMAX)


def test_per_axis_ramps_keep_each_axis_limit_along_the_circle():
    """Ideal motion along the profile on a clockwise R 1 circle starting at 30 degrees: each
    axis' jerk and acceleration, at 9 points of every phase, within its own limit."""
    r, th0, sg = 1.0, math.radians(30.0), -1.0
    length = 2 * math.pi * r
    acc, jerk = (SHARE * 3000.0, SHARE * 2500.0), (SHARE * 1e5, SHARE * 8e4)
    lims = tuple(CircleLimits(th0, sg, r, length, rev, acc, jerk) for rev in (False, True))
    cap = (SHARE * 8e4 * r * r) ** (1 / 3)
    ph = saturated_profile(length, 0.0, 0.0, cap, lims)
    assert ph is not None
    _check_phases(ph.rows, length, 0.0, 0.0)
    tt = ph.dur[:, None] * np.linspace(0.0, 1.0, 9)[None, :]
    s, v, a, j = (col[:, None] for col in (ph.s, ph.v, ph.a, ph.j))
    ss, vv, aa = (
        s + tt * (v + tt * (0.5 * a + tt * j / 6.0)),
        v + tt * (a + 0.5 * tt * j),
        a + tt * j,
    )
    th = th0 + sg * ss / r
    tang = np.stack([-sg * np.sin(th), sg * np.cos(th)])
    norm = np.stack([-np.cos(th), -np.sin(th)])
    jerk_vec = (j - vv**3 / r**2) * tang + 3 * vv * aa / r * norm
    acc_vec = aa * tang + vv**2 / r * norm
    for i in range(2):
        assert np.abs(jerk_vec[i]).max() <= 0.97 * JMAX[i]
        assert np.abs(acc_vec[i]).max() <= 0.97 * AMAX[i]
    assert vv.max() <= cap * (1 + 1e-12)


def test_small_circle_from_rest_meets_the_cycle_time_target(machine):
    """R 1 at F6000: the curvature caps the speed at (J R^2)^(1/3) = 43 mm/s; constant-limit
    profiles took 1.31 x (length / cap + the S-curve to the cap); the issue asks <= 1.10."""
    r = 1.0
    moves = [arc(1, (r, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=6000.0)]
    p = plan(moves, machine)
    cap = min(100.0, math.sqrt(2500.0 * r), (8e4 * r * r) ** (1 / 3))
    bound = 2 * math.pi * r / cap + s_curve_time(cap, 3000.0, 1e5)
    assert p.duration_s <= 1.10 * bound
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    assert arc_deviation(tr, moves[0]) <= 0.25 * machine.segmentation.chord_tolerance_mm
    np.testing.assert_allclose(tr.pos[-1], moves[0].end, atol=1e-9)


def test_short_arc_whose_ramps_leave_no_room_for_the_bridge_still_gets_its_ramps():
    """An arc of 0.27 mm on R 0.21 from rest to rest (a rounded corner of a PrusaSlicer
    arc-fitted print, Marlin's M201 X500 Y500, SHARE of it). The ramps' distance table leaves
    out the 2 ms bridge between their peaks, 0.02 mm here: the peaks tried one grid step apart
    all fell short by 0.006-0.014 mm and the arc got none (0.7 s spent). Each peak tried now
    asks for the room the last one lacked."""
    r, length = 0.2101523257068534, 0.26975739453650943
    acc, jerk = (470.0, 470.0), (94000.0, 75200.0)
    lims = tuple(
        CircleLimits(2.9983497047781, -1.0, r, length, rev, acc, jerk) for rev in (False, True)
    )
    cap = 9.93838986366582
    ph = saturated_profile(length, 0.0, 0.0, cap, lims)
    assert ph is not None
    _check_phases(ph.rows, length, 0.0, 0.0)
    assert ph.rows[:, 2].max() <= cap * (1 + 1e-12)
    # the constant-limit profile under the tangent's limits takes 0.0627 s on this arc
    assert ph.duration_s < 0.055


@pytest.mark.parametrize(("radius", "built"), [(5.0, True), (10.0, False)])
def test_saturated_ramps_only_where_the_curvature_takes_half_the_limits(
    machine, monkeypatch, radius, built
):
    """Full circles from rest at F6000 on the bundled machine: at the feed cap the curvature
    takes 0.8 of Y's acceleration on R 5 and 0.4 on R 10. The saturated ramps (tenths of a
    second each) are built on R 5 only; R 10 still gets the tangent's profile, faster than the
    block's constant-limit profiles alone."""
    moves = [arc(1, (radius, 0.0, 0.0), (0.0, 0.0, 0.0), 2 * math.pi, feed=6000.0)]
    real = speedup.saturated_profile
    calls = []

    def counted(*args, **kwargs):
        calls.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(speedup, "saturated_profile", counted)
    with_tangent = plan(moves, machine).duration_s
    assert bool(calls) == built
    monkeypatch.setattr(speedup, "saturated_candidates", lambda *a, **k: ())
    assert with_tangent < plan(moves, machine).duration_s


#: Five lines of a Bambu Studio arc-fitted print under M201 X20000 Y20000: two G3 arcs whose
#: junction (a kink of 0.25 degrees) offends round after round in G61 until it is a stop, so the
#: first arc's end speed changes every round (16 rounds, then 3 of softened limits).
BACKED_OFF = (
    "M201 X20000 Y20000 Z500 E5000\nG1 F11541.081\nG1 X133.769 Y119.697 E.00132\n"
    "G3 X124.271 Y116.215 I-7.386 J5.451 E2.08902\nG3 X126.393 Y115.969 I2.153 J9.284 E.09524\n"
)


def test_arc_next_to_a_junction_backed_off_round_by_round_builds_its_ramps_from_rest_only(
    machine, monkeypatch
):
    """The saturated ramps (0.35 s each on this arc) were built again for each of the end
    speeds the junction went through: 11 times, 4 s for five lines; and the ramps, made for an
    end at rest, kept the pieces next to the moving junction off the arc, so it ended as a
    stop. After the first round only an arc from and to rest tries them: the junction is
    passed moving (at 18 mm/s)."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")  # the calls are counted in this process
    # Marlin's segmentation (fixed 1 mm chords), as `gantry plan --dialect marlin` runs it
    machine = with_segmentation_default(machine.with_changes("path", mode="G61"), "marlin")
    real = speedup.saturated_profile
    ends = []

    def counted(*args, **kwargs):
        ends.append((args[1], args[2]))
        return real(*args, **kwargs)

    monkeypatch.setattr(speedup, "saturated_profile", counted)
    items = list(interpret_events(BACKED_OFF, dialect="marlin"))
    p = plan(items, machine)
    assert all(v_in == v_out == 0.0 for v_in, v_out in ends)
    moves = [m for m in items if isinstance(m, Arc | Linear) and m.length_mm > 1e-9]
    _, vel, _ = p.curve.evaluate(np.array([p.move_start_s[len(moves) - 1]]))
    assert np.linalg.norm(vel) > 1.0  # the junction between the arcs is not a stop


# --- Tiny arcs from rest: the saturated ramps cannot be assembled; the planner must fall back ---

#: A 0.2 um arc on R 5 at F6000 (issue 15, defect 1): both ramps would be empty.
TINY_ARC = "G21 G90 G17\nG0 X0 Y-5\nG2 X-0.0002 Y-5 I0 J5 F6000\nM2\n"
#: Two short tangent G2 arcs at F10048 in/min in inches: the first one's ramp back from its moving
#: end would be empty.
TWO_SHORT_ARCS_INCH = (
    "G20 G90 G17\nG0 X0 Y-0.05\nG2 X-0.0001 Y-0.05 I0 J0.05 F10048\n"
    "G2 X-0.0002 Y-0.05 I0.0001 J0.05\nM2\n"
)


def _short_arc_programs(count: int, rng: np.random.Generator) -> list[str]:
    """Single arcs from rest on R <= 5 mm at 3000-6000 mm/min, written to 4 decimals as a CAM
    post would: mostly short ones (0.1 um to 3 um, where the ramps have no room), some
    near-full circles (a gap of up to 1 mm)."""
    out = []
    for k in range(count):
        r = float(rng.uniform(0.5, 5.0))
        feed = float(rng.uniform(3000.0, 6000.0))
        word = "G2" if rng.random() < 0.5 else "G3"
        if k % 4 == 3:
            sweep = 2 * math.pi - float(rng.uniform(1e-4, 1.0)) / r
        else:
            sweep = float(rng.uniform(1e-4, 3e-3)) / r
        th = -0.5 * math.pi + (-sweep if word == "G2" else sweep)
        x, y = r * math.cos(th), r * math.sin(th)
        out.append(
            f"G21 G90 G17\nG0 X0 Y{-r:.4f}\n{word} X{x:.4f} Y{y:.4f} I0 J{r:.4f} F{feed:.0f}\nM2\n"
        )
    return out


def _plans_within_limits(text: str, machine) -> None:
    moves = parse_program(text)
    p = plan(moves, machine)
    assert np.isfinite(p.duration_s) and p.duration_s > 0
    tr = p.sample(machine.servo.period_s)
    assert_within_limits(tr, machine, moves)
    np.testing.assert_allclose(tr.pos[-1], moves[-1].end, atol=1e-9)
    assert not tr.vel[-1].any()


def test_saturated_profile_without_room_for_its_ramps_is_none_not_an_error():
    """0.2 um from rest: no ramp fits, so there is no saturated profile (the caller falls back)."""
    r, length = 5.0, 2e-4
    acc, jerk = (SHARE * 3000.0, SHARE * 2500.0), (SHARE * 1e5, SHARE * 8e4)
    lims = tuple(CircleLimits(-0.5 * math.pi, -1.0, r, length, rev, acc, jerk) for rev in (0, 1))
    assert saturated_profile(length, 0.0, 0.0, 30.0, lims) is None


@pytest.mark.parametrize("text", [TINY_ARC, TWO_SHORT_ARCS_INCH], ids=["tiny-arc", "two-inch-arcs"])
def test_tiny_arcs_plan_within_limits(machine, text):
    _plans_within_limits(text, machine)


def test_generated_short_and_near_full_arcs_plan_within_limits(machine):
    for text in _short_arc_programs(8, np.random.default_rng(15)):
        _plans_within_limits(text, machine)


def test_low_jerk_ramps_take_a_bounded_number_of_steps(monkeypatch):
    """At the machine file's least jerk (1 mm/s^3) a ramp reaches MAX_RAMP_S: its family's
    steps grow so that at most MAX_RAMP_STEPS span it (8,000 steps of STEP_S made a full
    circle's plan take over a minute)."""
    from gantry_sim.controller.planner import saturated_ramp
    from gantry_sim.controller.planner.ramp_family import MAX_RAMP_S, RampFamily

    sizes: list[int] = []

    class Counted(RampFamily):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            sizes.append(self.grid.size)

    monkeypatch.setattr(saturated_ramp, "RampFamily", Counted)
    r = 10.0
    length = 2 * math.pi * r
    acc, jerk = (SHARE * 3000.0, SHARE * 2500.0), (SHARE * 1.0, SHARE * 1.0)
    lims = tuple(CircleLimits(0.0, 1.0, r, length, rev, acc, jerk) for rev in (False, True))
    saturated_profile(length, 0.0, 0.0, 50.0, lims)
    assert sizes and max(sizes) <= saturated_ramp.MAX_RAMP_STEPS + 2
    assert MAX_RAMP_S / saturated_ramp.MAX_RAMP_STEPS > saturated_ramp.STEP_S
