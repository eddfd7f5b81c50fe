"""Generated cutter-compensation programs (issue 11) for the rs274 differential corpus.

Every line opens with ``N<line number>`` (rs274 prints the N of the block that releases a held
compensated move, which is the line gantry-sim gives it too). Families:

- ``gen_comp_NNN``: random XY contours of lines and arcs (I/J and, after the entry, R format;
  G2 and G3; inside and outside corners) under G41/G42 with a D-word diameter (G41.1/G42.1) or a
  tool of rs274's default table (G41/G42 D1-D3, or the tool in the spindle), entered with a line
  or an I/J arc, with G0 and Z-only moves among them, left with G40 and a line; units G20/G21,
  G90/G91. Gouges and tools too big for an arc occur naturally; rs274 refuses those.
- ``gen_comp_err_NNN``: each refusal rs274 gives while compensation is on or being turned on.

Used by ``scripts/make_rs274_corpus.py``; deterministic for a given seed.
"""

from __future__ import annotations

import math
import random


def _n(v: float) -> str:
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def numbered(lines: list[str]) -> str:
    return "\n".join(f"N{k} {ln}" for k, ln in enumerate(lines, 1))


def _segment(
    rng: random.Random, x: float, y: float, u: float, r_ok: bool
) -> tuple[str, float, float]:
    """One contour move from (x, y): a line or an arc; returns (words, end x, end y)."""
    if rng.random() < 0.55:
        ex, ey = x + rng.uniform(-25, 25) * u, y + rng.uniform(-25, 25) * u
        if rng.random() < 0.3:  # axis-parallel, as most real parts
            ey = y if rng.random() < 0.5 else ey
            ex = x if ey != y else ex
        return f"G1 X{_n(ex)} Y{_n(ey)}", ex, ey
    radius = rng.uniform(4, 20) * u
    a0 = rng.uniform(0, 2 * math.pi)
    cx, cy = x - radius * math.cos(a0), y - radius * math.sin(a0)
    a1 = a0 + rng.uniform(0.3, 2.5) * rng.choice((1, -1))
    ex, ey = cx + radius * math.cos(a1), cy + radius * math.sin(a1)
    g = rng.choice(("G2", "G3"))
    if r_ok and rng.random() < 0.3:
        return f"{g} X{_n(ex)} Y{_n(ey)} R{_n(radius)}", ex, ey
    return f"{g} X{_n(ex)} Y{_n(ey)} I{_n(cx - x)} J{_n(cy - y)}", ex, ey


def comp_program(rng: random.Random) -> list[str]:
    inch = rng.random() < 0.2
    u = 0.04 if inch else 1.0
    lines = [
        f"{'G20' if inch else 'G21'} G17 G90 G40 F{_n(rng.choice((300, 800)) * (0.04 if inch else 1))}"
    ]
    x, y = rng.uniform(-20, 20) * u, rng.uniform(-20, 20) * u
    lines.append(f"G0 X{_n(x)} Y{_n(y)} Z{_n(5 * u)}")
    lines.append(f"G1 Z{_n(-1 * u)}")
    side = rng.choice(("G41", "G42"))
    c = rng.random()
    if c < 0.65:
        lines.append(f"{side}.1 D{_n(rng.uniform(0.5, 8) * u)}")
    elif c < 0.85:
        lines.append(f"{side} D{rng.randint(1, 3)}")
    else:
        lines += [f"T{rng.randint(1, 3)} M6", side]
    words, x, y = _segment(rng, x, y, u, False)
    lines.append(words)  # the entry move
    for _ in range(rng.randint(2, 7)):
        r = rng.random()
        if r < 0.08:
            lines.append(f"G0 Z{_n(rng.uniform(-1, 3) * u)}")
        elif r < 0.14:
            ex, ey = x + rng.uniform(-10, 10) * u, y + rng.uniform(-10, 10) * u
            lines.append(f"G0 X{_n(ex)} Y{_n(ey)}")
            x, y = ex, ey
        else:
            words, x, y = _segment(rng, x, y, u, True)
            lines.append(words)
    lines.append("G40" if rng.random() < 0.5 else f"G40 G1 X{_n(x + 5 * u)} Y{_n(y + 5 * u)}")
    lines += [f"G0 Z{_n(5 * u)}", "G0 X0 Y0", "M2"]
    return lines


ERRORS = (
    ["G21 F100", "G41.1 D2", "G1 X0.5 Y0"],  # entry shorter than the tool radius
    ["G21 F100", "G41.1 D2", "G1 X10", "G17 G18", "G1 X20"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G18 G1 X20"],  # plane change while on
    ["G21 F100", "G41.1 D2", "G1 X10", "G42.1 D2"],  # on when on
    ["G21 F100", "G41.1"],  # no D
    ["G21 F100", "G19 G41.1 D2"],  # YZ plane
    ["G21 F100", "G41.1 D2 L3"],  # L without G18
    ["G21 F100", "G41 D1.5"],  # D not a whole number
    ["G21 F100", "G41 D-1"],
    ["G21 F100", "G41 D7"],  # no such tool
    ["G21 F100", "G41.1 D2", "G1 X10", "G81 X5 Z-1 R1"],  # canned cycle while on
    ["G21 F100", "G41.1 D2", "G1 X10", "G28"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G53 G0 X0"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G92 X0"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G55"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G99"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G1 X20", "G40", "G2 X30 I5"],  # arc after G40
    ["G21 F100", "G41.1 D8", "G1 X10", "G1 X20", "G3 X20 Y4 J2"],  # tool bigger than the arc
    ["G21 F100", "G41.1 D4", "G1 X10", "G1 X20", "G1 X21 Y20", "G1 X19 Y0"],  # gouge
    ["G21 F100", "G41.1 D6", "G1 X10 Y0", "G1 X20", "G1 X20.5 Y2", "G1 X40 Y2"],
    ["G21 F100", "G41.1 D2", "G3 X10 Y0 I5 J0", "G1 X20"],  # arc entry
    ["G21 F100", "G41.1 D2", "G3 X1 Y0 I0.5 J0", "G1 X20"],  # arc entry too short
    ["G21 F100", "G42.1 D2", "G1 X10", "G1 Y10", "G1 X0", "G1 Y0", "G40 G1 X-5 Y-5"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G1 Y10", "G1 X0", "G1 Y0", "G40 G1 X-5 Y-5"],
    ["G21 F100", "G41.1 D2", "G1 X10", "G2 X20 Y0 R5", "G1 X30", "M0", "G1 Y10", "G40 G0 X0"],
    ["G21 F100", "G41.1 D-2", "G1 X10", "G1 Y10", "G1 X0", "G40 G1 Y0"],  # negative diameter
    ["G20 F10", "G41 D1", "G1 X1", "G1 Y1", "G3 X0 Y2 I-1", "G1 X-1", "G40 G1 X-2"],
    ["G21 F100", "G41.1 D2", "G0 X10", "G0 X20 Y5", "G0 X30 Y0", "G40 G0 X0"],  # G0 corners
    ["G21 F100", "G91 G41.1 D2", "G1 X10", "G1 Y10", "G3 X-10 Y10 I-10", "G40 G1 X-5"],
    ["G21 F100", "G42.1 D3", "G1 X10", "G2 X30 Y0 I10", "G3 X50 Y0 I10", "G1 X60", "G40 G1 X70"],
)


def comp_programs(seed: int) -> dict[str, str]:
    rng = random.Random(seed)
    out: dict[str, str] = {}
    for k in range(200):
        out[f"gen_comp_{k:03d}"] = numbered(comp_program(rng))
    for k, lines in enumerate(ERRORS):
        out[f"gen_comp_err_{k:03d}"] = numbered([*lines, "M2"])
    for k in range(40):  # the same contours written in G91 (and G0 entries / exits)
        lines = comp_program(rng)
        out[f"gen_comp_inc_{k:03d}"] = numbered(_incremental(lines, rng))
    return out


def _incremental(lines: list[str], rng: random.Random) -> list[str]:
    """The contour part of a program in G91: X/Y words become steps from the last point."""
    out: list[str] = []
    x = y = 0.0
    inc = False
    for ln in lines:
        words = ln.split()
        if words[0].startswith("G4") and not inc and words[0] != "G40":
            inc = True
            out.append("G91 " + ln)
            continue
        if words[0] == "G40":
            inc = False
            out.append("G90 " + ln)
            continue
        if inc and words[0] in ("G0", "G1", "G2", "G3"):
            new = [words[0]]
            for w in words[1:]:
                if w[0] == "X":
                    v = float(w[1:])
                    new.append(f"X{_n(v - x)}")
                    x = v
                elif w[0] == "Y":
                    v = float(w[1:])
                    new.append(f"Y{_n(v - y)}")
                    y = v
                else:
                    new.append(w)
            if new[0] == "G1" and rng.random() < 0.1:
                new[0] = "G0"
            out.append(" ".join(new))
            continue
        for w in words:
            if w[0] == "X":
                x = float(w[1:])
            elif w[0] == "Y":
                y = float(w[1:])
        out.append(ln)
    return out
