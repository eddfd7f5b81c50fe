"""polar.png and the human summary of `gantry ballbar`, on synthetic traces (no simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gantry_sim.sim.circular.diagnostics import diagnostics_json, fit_diagnostics
from gantry_sim.sim.circular.figures import analyse_circle, ballbar_json
from gantry_sim.sim.circular.summary import format_summary, g_gate, polar_scale
from gantry_sim.sim.plots import polar_figure, save_polar_plot

R = 10.0  # mm
V = 50.0  # mm/s
CONDITIONS = {
    "machine": "my_mill.toml",
    "centre_mm": [1.0, 2.0, 0.0],
    "directions": ["CCW", "CW"],
    "servo_period_s": 0.00025,
    "data_arc_deg": 360.0,
    "start_deg": 45.0,
    "lead_in_deg": 180.0,
    "lead_out_deg": 180.0,
}


def lagging(sense: float, tau_a: float = 1.0e-3, tau_b: float = 0.2e-3) -> np.ndarray:
    """(N, 2) [mm]: each axis tau late on the R circle (a servo mismatch of tau_a - tau_b)."""
    phi = math.radians(45.0) + sense * np.linspace(0.0, 2 * math.pi, 3600, endpoint=False)
    w = V / R
    return np.column_stack(
        (R * np.cos(phi - sense * w * tau_a), R * np.sin(phi - sense * w * tau_b))
    )


@pytest.fixture(scope="module")
def bb():
    ccw = analyse_circle(lagging(1.0), np.zeros(2), R, "ccw")
    cw = analyse_circle(lagging(-1.0), np.zeros(2), R, "cw")
    diag = fit_diagnostics([ccw.nominal, cw.nominal], R, V)
    extra = {"diagnostics": diagnostics_json(diag, "XY"), "conditions": CONDITIONS}
    return ccw, cw, ballbar_json("XY", R, V * 60.0, cw, ccw, extra)


@pytest.mark.parametrize(
    "lo,hi,expected",
    [
        (-3.6, 3.7, (2.0, -4.0, 4.0)),
        (0.0, 0.3, (0.1, 0.0, 0.3)),
        (-12.0, 30.0, (20.0, -20.0, 40.0)),
    ],
)
def test_polar_scale_examples(lo, hi, expected):
    assert polar_scale(lo, hi) == pytest.approx(expected)


@given(
    st.floats(-500, 500, allow_nan=False),
    st.floats(0.1, 1000, allow_nan=False),
)
def test_polar_scale_is_the_finest_nice_division_that_spans_the_data(lo, span):
    hi = lo + span
    div, first, last = polar_scale(lo, hi)
    mantissa = div / 10 ** math.floor(math.log10(div) + 1e-9)
    assert min(abs(mantissa - m) for m in (1, 2, 5)) < 1e-6
    assert first <= lo + 1e-9 and last >= hi - 1e-9
    assert (last - first) / div <= 4 + 1e-6
    assert math.isclose(first / div, round(first / div), abs_tol=1e-6)


def test_polar_figure_states_scale_nominal_circle_traces_and_conditions(bb):
    ccw, cw, summary = bb
    fig = polar_figure(ccw, cw, summary)
    texts = "\n".join(t.get_text() for t in fig.texts)
    div, _, _ = polar_scale(
        float(min(ccw.nominal.dev_um.min(), cw.nominal.dev_um.min(), 0.0)),
        float(max(ccw.nominal.dev_um.max(), cw.nominal.dev_um.max(), 0.0)),
    )
    assert f"scale {div:g} um/div" in texts
    for fact in (
        "machine: my_mill.toml",
        "plane XY, radius 10 mm, feed 3000 mm/min",
        "directions: CCW then CW; centre (1, 2, 0) mm",
        "servo period 0.25 ms",
        "data arc 360 deg from 45 deg; lead-in 180 deg, lead-out 180 deg",
        "servo mismatch +0.800 ms",
    ):
        assert fact in texts
    ax = fig.axes[0]
    assert np.allclose(np.diff(ax.get_yticks()), div)
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels[0] == "nominal circle R 10 mm (0 um)"
    assert np.all(ax.get_lines()[0].get_ydata() == 0.0)
    assert any(lb.startswith("CCW  G =") for lb in labels)
    assert any(lb.startswith("CW  G =") for lb in labels)


def test_polar_png_is_the_same_for_the_same_test(bb, tmp_path):
    """No date and no software stamp in the plot: the same test gives the same bytes."""
    ccw, cw, summary = bb
    save_polar_plot(tmp_path / "a.png", ccw, cw, summary)
    save_polar_plot(tmp_path / "b.png", ccw, cw, summary)
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_summary_reads_in_ballbar_units(bb):
    _, _, summary = bb
    text = format_summary({**summary, "gate": g_gate(summary, 0.01)})
    assert text.startswith("ballbar XY  R 10 mm  F 3000 mm/min\n")
    assert "servo mismatch     +0.800 ms (X lags Y)" in text
    assert "squareness         +0.0 um/m" in text
    assert "machine my_mill.toml" in text and "servo period 0.25 ms" in text
    assert "gate G <= 0.01 um: FAIL: CCW circular deviation G" in text
    assert "-0.00" not in text


def test_gate_passes_at_the_limit(bb):
    _, _, summary = bb
    g = max(summary[d]["circular_deviation_um"] for d in ("ccw", "cw"))
    assert g_gate(summary, g)["passed"] is True
    assert g_gate(summary, g * 0.999)["passed"] is False


def test_a_perfect_circle_still_gets_a_readable_scale(tmp_path, recwarn):
    """No deviation at all: one 0.1 um division (no finer rings, no empty radial range)."""
    assert polar_scale(0.0, 0.0) == pytest.approx((0.1, 0.0, 0.1))
    assert polar_scale(-0.01, 0.02) == pytest.approx((0.1, -0.1, 0.1))
    phi = math.radians(45.0) + np.linspace(0.0, 2 * math.pi, 720, endpoint=False)
    pts = np.column_stack((R * np.cos(phi), R * np.sin(phi)))
    ccw = analyse_circle(pts, np.zeros(2), R, "ccw")
    cw = analyse_circle(pts[::-1], np.zeros(2), R, "cw")
    save_polar_plot(tmp_path / "p.png", ccw, cw, ballbar_json("XY", R, 3000.0, cw, ccw))
    assert (tmp_path / "p.png").stat().st_size > 0
    assert [str(w.message) for w in recwarn] == []
