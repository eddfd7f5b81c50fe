"""What ``gantry ballbar`` tells a person, and its G gate, from the ballbar object (plain dicts).

``format_summary`` renders the object as the few lines ballbar software shows (G per direction,
the diagnostics in their units, the test conditions); ``g_gate`` judges G against a limit;
``polar_scale``, ``polar_conditions_text`` and ``polar_figures_text`` are polar.png's scale
and text (the drawing is :func:`gantry_sim.sim.plots.save_polar_plot`).
No simulation, NumPy or matplotlib here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from gantry_sim.sim.plot_text import literal_text


def g_gate(summary: Mapping[str, Any], max_g_um: float) -> dict:
    """The "gate" object: G of each direction against ``max_g_um`` [um].

    Returns:
        {"max_g_um", "passed", "reasons"}; a reason per direction whose circular deviation G
        exceeds the limit (a G equal to the limit passes).
    """
    reasons = [
        f"{d.upper()} circular deviation G {summary[d]['circular_deviation_um']:.2f} um "
        f"> {max_g_um:g} um"
        for d in ("ccw", "cw")
        if summary[d]["circular_deviation_um"] > max_g_um
    ]
    return {"max_g_um": float(max_g_um), "passed": not reasons, "reasons": reasons}


def _num(v: float | None, fmt: str = ".2f") -> str:
    """``v`` formatted, "n/a" for None or nan, and no "-0.00" (a rounded zero has no sign)."""
    if v is None or math.isnan(v):
        return "n/a"
    text = format(v, fmt)
    return format(0.0, fmt) if float(text) == 0.0 else text


#: below this servo mismatch [ms] the summary calls the axes matched
MATCHED_MS = 0.01


def _lag_words(ms: float, a: str, b: str) -> str:
    if abs(ms) < MATCHED_MS:
        return f"matched within {MATCHED_MS:g} ms"
    return f"{a} lags {b}" if ms > 0 else f"{b} lags {a}"


def format_summary(summary: Mapping[str, Any]) -> str:
    """The human summary of a ballbar object (ends with a newline)."""
    s = summary
    a, b = s["plane"][0], s["plane"][1]
    out = [
        f"ballbar {s['plane']}  R {s['radius_mm']:g} mm  F {s['feed_mm_per_min']:g} mm/min",
    ]
    cond = s.get("conditions")
    if cond:
        c = ", ".join(f"{v:g}" for v in cond["centre_mm"])
        out += [
            f"  machine {cond['machine']}, servo period {cond['servo_period_s'] * 1e3:g} ms",
            f"  centre ({c}) mm, {' then '.join(cond['directions'])}, data arc "
            f"{cond['data_arc_deg']:g} deg from {cond['start_deg']:g} deg, lead-in "
            f"{cond['lead_in_deg']:g} deg, lead-out {cond['lead_out_deg']:g} deg",
        ]
    out.append(
        f"  {'':4} {'G um':>7} {'F max':>7} {'F min':>7}   reversal spikes um at 0/90/180/270 deg"
    )
    for d in ("ccw", "cw"):
        r = s[d]
        spikes = " ".join(f"{_num(v):>6}" for v in r["reversal_spikes_um"])
        out.append(
            f"  {d.upper():4} {r['circular_deviation_um']:7.2f} "
            f"{r['radial_deviation_um']['max']:7.2f} {r['radial_deviation_um']['min']:7.2f}   "
            f"{spikes}"
        )
    bidir = f"  bidirectional G(b) {s['bidirectional_deviation_um']:.2f} um"
    if "circular_hysteresis_um" in s:
        bidir += f", circular hysteresis H {s['circular_hysteresis_um']:.2f} um"
    out.append(bidir)
    diag = s.get("diagnostics")
    if diag:
        ms = diag["servo_mismatch_ms"]
        bl, lp = diag["backlash_um"], diag["lateral_play_um"]
        off = [
            0.5 * (s["ccw"]["centre_offset_um"][i] + s["cw"]["centre_offset_um"][i]) for i in (0, 1)
        ]
        out += [
            "diagnostics",
            f"  servo mismatch     {_num(ms, '+.3f')} ms ({_lag_words(ms, a, b)})",
            f"  squareness         {_num(diag['squareness_um_per_m'], '+.1f')} um/m",
            f"  scaling mismatch   {_num(diag['scaling_mismatch_ppm'], '+.1f')} ppm ({a} vs {b})",
            f"  backlash           {a} {_num(bl[a], '+.2f')} um  {b} {_num(bl[b], '+.2f')} um",
            f"  lateral play       {a} {_num(lp[a], '+.2f')} um  {b} {_num(lp[b], '+.2f')} um",
            f"  centre offset      {a} {_num(off[0], '+.2f')} um  {b} {_num(off[1], '+.2f')} um",
            f"  model residual     {diag['model_residual_rms_um']:.2f} um RMS at "
            f"{diag['path_speed_mm_per_min']:.0f} mm/min",
        ]
    gate = s.get("gate")
    if gate:
        verdict = "PASS" if gate["passed"] else "FAIL: " + "; ".join(gate["reasons"])
        out.append(f"gate G <= {gate['max_g_um']:g} um: {verdict}")
    return "\n".join(out) + "\n"


# ---- polar.png: its scale and its text (drawn by gantry_sim.sim.plots.save_polar_plot) ----


#: the finest polar.png division [um]: below a ballbar's resolution finer rings say nothing
MIN_UM_PER_DIV = 0.1


def polar_scale(lo_um: float, hi_um: float, divisions: int = 4) -> tuple[float, float, float]:
    """A ballbar plot's radial scale for deviations in [lo_um, hi_um]: (um per division,
    innermost ring, outermost ring) [um]. The division is 1, 2 or 5 x 10^k um, at least
    MIN_UM_PER_DIV, the finest that spans the data in at most ``divisions`` divisions; the
    rings are multiples of it, at least one division apart."""
    span = max(hi_um - lo_um, MIN_UM_PER_DIV)
    e = 10.0 ** math.floor(math.log10(span / divisions))
    for m in (1.0, 2.0, 5.0, 10.0, 20.0):
        div = m * e
        if div < MIN_UM_PER_DIV * (1 - 1e-9):
            continue
        lo, hi = math.floor(lo_um / div) * div, math.ceil(hi_um / div) * div
        if (hi - lo) / div <= divisions + 1e-9:
            return div, lo, max(hi, lo + div)
    raise AssertionError("unreachable: 20 e spans the data")  # pragma: no cover


def polar_conditions_text(summary: Mapping[str, Any]) -> str:
    """The test-conditions box: machine, plane, radius, feed, directions, centre, servo period,
    data arc and lead-in/out (from the summary's "conditions"), and no date."""
    s = summary
    c = s.get("conditions") or {}
    lines = [
        "Test conditions",
        f"machine: {literal_text(str(c.get('machine', 'n/a')))}",
        f"plane {s['plane']}, radius {s['radius_mm']:g} mm, feed {s['feed_mm_per_min']:g} mm/min",
    ]
    if c:
        centre = ", ".join(f"{v:g}" for v in c["centre_mm"])
        lines += [
            f"directions: {' then '.join(c['directions'])}; centre ({centre}) mm",
            f"servo period {c['servo_period_s'] * 1e3:g} ms",
            f"data arc {c['data_arc_deg']:g} deg from {c['start_deg']:g} deg; "
            f"lead-in {c['lead_in_deg']:g} deg, lead-out {c['lead_out_deg']:g} deg",
        ]
    return "\n".join(lines)


def polar_figures_text(summary: Mapping[str, Any]) -> str:
    """The figures printed beside the plot: G(b), ellipse and the diagnostics."""
    s = summary
    e = s["ellipse"]
    lines = [
        f"G(b) {s['bidirectional_deviation_um']:.2f} um"
        + (f", H {s['circular_hysteresis_um']:.2f} um" if "circular_hysteresis_um" in s else ""),
        f"ellipse {e['magnitude_um']:.2f} um at {e['axis_deg']:.0f} deg",
        f"  flips with direction: {'yes' if e['flips_with_direction'] else 'no'}",
    ]
    d = s.get("diagnostics")
    if d:
        a, b = s["plane"][0], s["plane"][1]
        lines += [
            f"servo mismatch {d['servo_mismatch_ms']:+.3f} ms",
            f"squareness {d['squareness_um_per_m']:+.1f} um/m",
            f"scaling {d['scaling_mismatch_ppm']:+.1f} ppm",
            f"backlash {a} {d['backlash_um'][a]:.2f}, {b} {d['backlash_um'][b]:.2f} um",
            f"lateral play {a} {d['lateral_play_um'][a]:.2f}, {b} {d['lateral_play_um'][b]:.2f} um",
        ]
    return "\n".join(lines)
