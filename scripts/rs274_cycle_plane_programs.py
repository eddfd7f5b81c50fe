"""Canned cycles in every plane, systematically, for the rs274 differential corpus.

A review suspected that the cycles (the tapping cycles G74/G84 above all) misplace axes in the
XZ (G18) and YZ (G19) planes. ``gen_cycpl_*`` runs every cycle gantry-sim supports (G73, G74,
G81-G89; G76 is refused, see ``own_refused_thread_cycle``) in G17, G18 and G19, with G98 and
G99, G90 and G91, from a start above R and one below R, each with an L repeat, modal repeats
at new positions, a new R/bottom/P/Q, and G80 (G74 from above R without L: rs274 refuses
L on G74). In-plane coordinates are distinct and uneven
(mm), so a swap of two axes shows in every move. ``gen_cycpl_err_*``: what rs274 refuses in
the XZ and YZ planes (bottom word missing, R below the bottom, wrong spindle direction, G87's
top letter missing, Q0, P missing).

Every line opens with ``N<line number>`` (lines come from rs274's own output). No randomness:
the family is the same whatever the seed. Used by ``scripts/make_rs274_corpus.py``.
"""

from __future__ import annotations

from rs274_cycle_programs import G87_LETTERS, PLANES, numbered

CYCLES = ("G73", "G74", "G81", "G82", "G83", "G84", "G85", "G86", "G87", "G88", "G89")
#: start point per (plane drilling axis is the third letter): in-plane (a, b) [mm]
_START_AB = (7.3, -4.1)
#: drilling-axis start level [mm]: above R ("hi") or below R ("lo": rs274 rapids up to R first)
_START_C = {"hi": 12.5, "lo": 1.5}


def _extra(cyc: str, plane: str, incremental: bool, second: bool) -> str:
    """P, Q or G87's I/J/K words (mm, s); ``second``: the values of a later block."""
    if cyc in ("G73", "G83"):
        return "Q0.9" if second else "Q1.7"
    if cyc in ("G82", "G86", "G88", "G89"):
        return "P0.25" if second else "P0.5"
    if cyc == "G87":
        a, b, top = G87_LETTERS[plane]
        # top: above the bottom, absolute (G90) or from the bottom (G91)
        t = 2.2 if incremental else -1.1
        return f"{a}{-1.3 if second else 1.6} {b}{0.7 if second else -0.9} {top}{t}"
    return ""


def _spindle(cyc: str) -> str:
    return "M4 S500" if cyc == "G74" else "M3 S500"


def plane_program(
    cyc: str, plane_row: tuple[str, str, str, str], mode: str, dist: str, start: str
) -> list[str]:
    """One cycle in one plane, retract mode, distance mode and start level."""
    plane, la, lb, lc = plane_row
    inc = dist == "G91"
    at = {la: _START_AB[0], lb: _START_AB[1], lc: _START_C[start]}
    lines = [
        f"G21 G90 {plane} F137",
        "G0 " + " ".join(f"{a}{at[a]:g}" for a in "XYZ"),
        _spindle(cyc),
    ]
    # rs274 2.9 refuses an L word on G74 (not in its list of cycles that take one): the "lo"
    # G74 programs check that refusal, the "hi" ones run G74 without repeats
    l3, l2 = ("", "") if cyc == "G74" and start == "hi" else (" L3", " L2")
    if inc:  # increments; R from the start level, the bottom from R
        r = -6.5 if start == "hi" else 3.0
        first = f"{la}2.5 {lb}-1.5 {lc}-7.25 R{r:g}"
        again = f"{la}-3.5 {lb}0.75"
        newer = f"{la}1.25 {lc}-5.5 R{r + 1:g}"
    else:
        first = f"{la}3.5 {lb}-2.25 {lc}-2.75 R4.5"
        again = f"{la}-6.5 {lb}5.25"
        newer = f"{lb}-8.5 {lc}-4.25 R5.5"
    words = (mode, dist, cyc, first, _extra(cyc, plane, inc, False))
    lines.append(" ".join(w for w in words if w) + l3)
    lines.append(again)
    lines.append(" ".join(w for w in (newer, _extra(cyc, plane, inc, True)) if w) + l2)
    lines += ["G80", "G90 G0 X0 Y0 Z15", "M2"]
    return lines


def _errors() -> dict[str, list[str]]:
    """Programs rs274 refuses, per non-XY plane (drilling along Y in G18, X in G19)."""
    out: dict[str, list[str]] = {}
    for plane, la, lb, lc in PLANES[1:]:
        head = [f"G21 {plane} F100", f"G0 {lc}10"]
        i_a, i_b, _top = G87_LETTERS[plane]
        cases = {
            "no_bottom": [f"G81 {la}1 {lb}2 R2"],
            "r_below": [f"G81 {la}1 {lb}2 {lc}3 R1"],
            "g84_ccw": ["M4 S500", f"G84 {la}1 {lb}2 {lc}-1 R2"],
            "g74_cw": ["M3 S500", f"G74 {la}1 {lb}2 {lc}-1 R2"],
            "g84_off": [f"G84 {la}1 {lb}2 {lc}-1 R2"],
            "g87_no_top": ["M3 S500", f"G87 {la}1 {lb}2 {lc}-1 R2 {i_a}1 {i_b}1"],
            "g83_q0": [f"G83 {la}1 {lb}2 {lc}-1 R2 Q0"],
            "g82_no_p": [f"G82 {la}1 {lb}2 {lc}-1 R2"],
        }
        for name, body in cases.items():
            out[f"gen_cycpl_err_{plane.lower()}_{name}"] = [*head, *body, "M2"]
    return out


def cycle_plane_programs() -> dict[str, str]:
    """name -> program text (without the final newline)."""
    out: dict[str, str] = {}
    for cyc in CYCLES:
        for row in PLANES:
            for mode in ("G98", "G99"):
                for dist in ("G90", "G91"):
                    for start in ("hi", "lo"):
                        name = f"gen_cycpl_{cyc.lower()}_{row[0].lower()}_{mode.lower()}_{dist.lower()}_{start}"
                        out[name] = numbered(plane_program(cyc, row, mode, dist, start))
    for name, lines in _errors().items():
        out[name] = numbered(lines)
    return out
