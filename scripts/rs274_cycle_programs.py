"""Generated canned-cycle programs (issue 11) for the rs274 differential corpus.

Every line opens with ``N<line number>`` so that ``scripts/regen_rs274_expected.py`` takes each
motion's line and the failing block from rs274's own output. Families:

- ``gen_cyc_NNN``: one cycle of G73, G74, G81-G89 per program (each code equally often), in a
  random plane (G17/G18/G19), retract mode (G98/G99), distance mode (G90/G91), unit (G20/G21),
  with L repeats, modal repeats on following lines (new positions, sometimes new R, bottom, P or
  Q), a change to another cycle, and G80 or a G0/G1 to end the series; the spindle is started as
  the cycle needs (M3 for G84, M4 for G74), now and then not, which rs274 refuses.
- ``gen_cyc_err_NNN``: each error rs274 gives for a cycle (R, bottom, P, Q or I/J/K missing, R
  below the bottom, L0, negative or fractional L, Q <= 0, zero feed, G93, words no cycle uses).

Used by ``scripts/make_rs274_corpus.py``; deterministic for a given seed.
"""

from __future__ import annotations

import random

CYCLES = ("G73", "G74", "G81", "G82", "G83", "G84", "G85", "G86", "G87", "G88", "G89")
#: plane -> (G code, first in-plane axis, second in-plane axis, drilling axis)
PLANES = (("G17", "X", "Y", "Z"), ("G18", "Z", "X", "Y"), ("G19", "Y", "Z", "X"))
#: G87's offset letters (first axis, second axis, counterbore top) per plane
G87_LETTERS = {"G17": ("I", "J", "K"), "G18": ("K", "I", "J"), "G19": ("J", "K", "I")}


def _n(v: float) -> str:
    s = f"{v:.3f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def numbered(lines: list[str]) -> str:
    return "\n".join(f"N{k} {ln}" for k, ln in enumerate(lines, 1))


def _extra(rng: random.Random, cyc: str, plane: str, u: float, first: bool) -> str:
    """The words a cycle needs besides position, R and bottom."""
    words = []
    if cyc in ("G73", "G83") and (first or rng.random() < 0.3):
        words.append(f"Q{_n(rng.uniform(0.3, 3.0) * u)}")
    if cyc in ("G82", "G86", "G88", "G89") and (first or rng.random() < 0.3):
        words.append(f"P{_n(rng.choice((0, 0.1, 0.25, 0.5, 1.5)))}")
    if cyc == "G87" and (first or rng.random() < 0.3):
        a, b, top = G87_LETTERS[plane]
        words += [f"{a}{_n(rng.uniform(-3, 3) * u)}", f"{b}{_n(rng.uniform(-3, 3) * u)}"]
        words.append(f"{top}{_n(rng.uniform(-6, 2) * u)}")
    return " ".join(words)


def _spindle(rng: random.Random, cyc: str) -> str:
    if rng.random() < 0.08:
        return rng.choice(("M5", "M3 S800", "M4 S800"))  # sometimes wrong for the cycle
    return {"G74": "M4 S500", "G84": "M3 S500"}.get(cyc, rng.choice(("M3 S1200", "M4 S900")))


def cycle_program(rng: random.Random, cyc: str) -> list[str]:
    plane, la, lb, lc = rng.choice(PLANES)
    inch = rng.random() < 0.2
    u = 0.04 if inch else 1.0
    incremental = rng.random() < 0.35
    feed = rng.choice((50, 120, 300, 800)) * (0.05 if inch else 1.0)
    height = rng.uniform(4, 25) * u
    start = {la: rng.uniform(-30, 30) * u, lb: rng.uniform(-30, 30) * u, lc: height}
    lines = [
        f"{'G20' if inch else 'G21'} G90 {plane} F{_n(feed)}",
        "G0 " + " ".join(f"{a}{_n(start[a])}" for a in "XYZ"),
        _spindle(rng, cyc),
    ]
    for k in range(rng.randint(1, 3)):
        cyc_k = cyc if k == 0 or rng.random() < 0.7 else rng.choice(CYCLES)
        mode = rng.choice(("G98", "G99", ""))
        first = k == 0 or cyc_k != cyc
        if incremental:
            r = rng.uniform(-height * 0.9, 3 * u) if rng.random() < 0.8 else rng.uniform(1, 5) * u
            bottom = -rng.uniform(0.5, 8) * u
            pos = f"{la}{_n(rng.uniform(-8, 8) * u)} {lb}{_n(rng.uniform(-8, 8) * u)}"
            dist = "G91"
        else:
            r = rng.uniform(0.2, 5) * u
            bottom = rng.uniform(-9, 0) * u
            pos = f"{la}{_n(rng.uniform(-30, 30) * u)} {lb}{_n(rng.uniform(-30, 30) * u)}"
            dist = "G90"
        if rng.random() < 0.04:
            bottom = r + rng.uniform(0.5, 2) * u  # R below the bottom: rs274 refuses
        repeats = f" L{rng.randint(2, 4)}" if rng.random() < 0.35 else ""
        words = [
            mode,
            dist,
            cyc_k,
            pos,
            f"{lc}{_n(bottom)}",
            f"R{_n(r)}",
            _extra(rng, cyc_k, plane, u, first),
        ]
        lines.append(" ".join(w for w in words if w) + repeats)
        for _ in range(rng.randint(0, 3)):  # modal repeats at new positions
            step = 8 if incremental else 30
            moved = [
                f"{a}{_n(rng.uniform(-step, step) * u)}" for a in (la, lb) if rng.random() < 0.8
            ]
            if rng.random() < 0.25:
                moved.append(f"{lc}{_n(bottom - rng.uniform(0, 2) * u)}")
            if rng.random() < 0.2:
                moved.append(f"R{_n(r + rng.uniform(0, 2) * u)}")
            extra = _extra(rng, cyc_k, plane, u, False)
            rep = f" L{rng.randint(2, 3)}" if rng.random() < 0.2 else ""
            lines.append(
                " ".join(moved or [f"{la}{_n(0.0)}"]) + (f" {extra}" if extra else "") + rep
            )
        if rng.random() < 0.3:
            lines.append(
                rng.choice(("G80", "G90 G0 " + f"{lc}{_n(height + 5 * u)}", "G90 G1 X1 Y2"))
            )
    lines += ["G80", "G90 G0 " + " ".join(f"{a}0" for a in "XY"), "M2"]
    return lines


ERRORS = (
    ("missing R", ["G21 F100", "G0 Z10", "G81 X1 Y1 Z-2"]),
    ("missing Z", ["G21 F100", "G0 Z10", "G81 X1 Y1 R2"]),
    ("missing X in G19", ["G21 F100 G19", "G0 X10", "G81 Y1 Z1 R2"]),
    ("missing Y in G18", ["G21 F100 G18", "G0 Y10", "G81 Z1 X1 R2"]),
    ("missing P", ["G21 F100", "G0 Z10", "M3 S1000", "G82 X1 Z-2 R1"]),
    ("missing P G89", ["G21 F100", "G0 Z10", "G89 X1 Z-2 R1"]),
    ("missing P G86", ["G21 F100", "G0 Z10", "M3", "G86 X1 Z-2 R1"]),
    ("missing P G88", ["G21 F100", "G0 Z10", "M3", "G88 X1 Z-2 R1"]),
    ("missing Q", ["G21 F100", "G0 Z10", "G83 X1 Z-2 R1"]),
    ("missing Q G73", ["G21 F100", "G0 Z10", "G73 X1 Z-2 R1"]),
    ("missing I", ["G21 F100", "G0 Z10", "M3", "G87 X1 Z-2 R1 J1 K-1"]),
    ("missing J", ["G21 F100", "G0 Z10", "M3", "G87 X1 Z-2 R1 I1 K-1"]),
    ("missing K", ["G21 F100", "G0 Z10", "M3", "G87 X1 Z-2 R1 I1 J1"]),
    ("R below Z", ["G21 F100", "G0 Z10", "G81 X1 Z2 R1"]),
    ("R below Z G91", ["G21 F100", "G0 Z10", "G91 G81 X1 Z2 R-3"]),
    ("L0", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 L0"]),
    ("negative L", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 L-2"]),
    ("fractional L", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 L1.5"]),
    ("Q zero", ["G21 F100", "G0 Z10", "G83 X1 Z-2 R1 Q0"]),
    ("Q negative", ["G21 F100", "G0 Z10", "G73 X1 Z-2 R1 Q-1"]),
    ("zero feed", ["G21", "G0 Z10", "G81 X1 Z-2 R1"]),
    ("inverse time", ["G21 G93", "G0 Z10", "G81 X1 Z-2 R1 F10"]),
    ("P on G81", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 P1"]),
    ("Q on G81", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 Q1"]),
    ("I on G81", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1 I1"]),
    ("P on G84", ["G21 F100", "G0 Z10", "M3", "G84 X1 Z-2 R1 P1"]),
    ("R alone", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1", "R3"]),
    ("axes with G80", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1", "G80 X3"]),
    ("spindle off G86", ["G21 F100", "G0 Z10", "G86 X1 Z-2 R1 P1"]),
    ("spindle off G87", ["G21 F100", "G0 Z10", "G87 X1 Z-2 R1 I1 J1 K-1"]),
    ("spindle off G88", ["G21 F100", "G0 Z10", "G88 X1 Z-2 R1 P1"]),
    ("spindle off G84", ["G21 F100", "G0 Z10", "G84 X1 Z-2 R1"]),
    ("spindle cw G74", ["G21 F100", "G0 Z10", "M3", "G74 X1 Z-2 R1"]),
    ("spindle ccw G84", ["G21 F100", "G0 Z10", "M4", "G84 X1 Z-2 R1"]),
    ("R again after G0", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1", "G0 X5", "G81 X3"]),
    ("repeat after G80", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1", "G80", "X3"]),
    ("G53 with cycle", ["G21 F100", "G0 Z10", "G53 G81 X1 Z-2 R1"]),
    ("L2 G83 then L0", ["G21 F100", "G0 Z10", "G91 G83 X1 Z-2 R-8 Q0.5 L2", "X2 L0"]),
    ("second cycle no P", ["G21 F100", "G0 Z10", "G81 X1 Z-2 R1", "G82 X3"]),
    ("modal then Q0", ["G21 F100", "G0 Z10", "G73 X1 Z-2 R1 Q1", "X3 Q0"]),
)


def cycle_programs(seed: int) -> dict[str, str]:
    rng = random.Random(seed)
    out: dict[str, str] = {}
    for k in range(220):
        out[f"gen_cyc_{k:03d}"] = numbered(cycle_program(rng, CYCLES[k % len(CYCLES)]))
    for k, (_, lines) in enumerate(ERRORS):
        out[f"gen_cyc_err_{k:03d}"] = numbered([*lines, "M2"])
    return out
