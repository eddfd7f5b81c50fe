"""Generated programs for the Marlin corpus (tests/data/marlin), one family per rule of the
README's `marlin` column: comments and PAREN_COMMENTS, `*` checksums, N words, unknown
commands, G/M/T without numbers, bare motion lines, G0-G3 with R and I/J, the arc end-point
rule, extra circles (P), planes, G5, G90/G91, G92, M82/M83, M220, F, subcodes, repeated
letters, words after a G command, units, homing, printer codes, case and number spelling.

    python scripts/marlin_corpus_programs.py OUT_DIR [--seed N] [--per-family K]

writes OUT_DIR/FAMILY_NNN.gcode (deterministic for a seed); then
``scripts/regen_marlin_expected.py --oracle ... --add OUT_DIR/*.gcode --name-prefix gen_``.
"""

from __future__ import annotations

import argparse
import math
import random
from collections.abc import Callable
from pathlib import Path

Family = Callable[[random.Random], list[str]]


def n(v: float, places: int = 3) -> str:
    s = f"{v:.{places}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def xy(rng: random.Random, lo: float = 0, hi: float = 120) -> str:
    return f"X{n(rng.uniform(lo, hi))} Y{n(rng.uniform(lo, hi))}"


def move(rng: random.Random) -> str:
    c = rng.random()
    if c < 0.25:
        return f"G0 {xy(rng)}"
    if c < 0.5:
        return f"G1 {xy(rng)} F{rng.choice((600, 1200, 3000, 4800))}"
    if c < 0.75:
        return f"G1 {xy(rng)} E{n(rng.uniform(0.1, 3), 5)}"
    return f"G1 Z{n(rng.uniform(0.2, 10))}"


def start(rng: random.Random) -> list[str]:
    return rng.choice([[], ["G21", "G90", "M82"], ["G90", "M83"], ["G28", "G92 E0"]])


def comments(rng: random.Random) -> list[str]:
    forms = [
        lambda: f"{move(rng)} ; comment {rng.randint(0, 99)}",
        lambda: f"; {move(rng)}",
        lambda: f"(setup) {move(rng)}",
        lambda: f"G1 (inline) {xy(rng)} F900",
        lambda: f"G1 X{n(rng.uniform(0, 50))} (note (nested) here) Y5",
        lambda: f"G1 X{n(rng.uniform(0, 50))} (left open Y9",
        lambda: f"G1 X{n(rng.uniform(0, 50))}) Y{n(rng.uniform(0, 50))}",
        lambda: f"G1 X{n(rng.uniform(0, 50))} E) Y3",
        lambda: f"G1 X{n(rng.uniform(0, 50))}\\{rng.randint(0, 9)} Y7",
        lambda: f"G1 X\\{rng.randint(0, 9)}{rng.randint(0, 9)} Y\\ 4",
        lambda: "(a whole comment line)",
        lambda: ";LAYER:1",
        lambda: f"G1 X{n(rng.uniform(0, 50))} ; (mixed ) Y8",
        lambda: f"G1 X(1)2{rng.randint(0, 9)} Y1",
        lambda: "( )G1 X3 Y3",
        lambda: f"G1 Y{rng.randint(1, 40)} ;(x",
    ]
    return start(rng) + [rng.choice(forms)() for _ in range(rng.randint(4, 9))]


def checksum_line(body: str) -> str:
    cs = 0
    for ch in body:
        cs ^= ord(ch)
    return f"{body}*{cs}"


def checksums(rng: random.Random) -> list[str]:
    out = []
    for k in range(rng.randint(4, 9)):
        body = f"N{k + 1} {move(rng)}"
        c = rng.random()
        if c < 0.5:
            out.append(checksum_line(body))
        elif c < 0.65:
            out.append(f"{body}*{rng.randint(0, 255)}")  # a wrong checksum: not checked
        elif c < 0.75:
            out.append(f"{body} (a * in a comment) Y{rng.randint(1, 9)}")
        elif c < 0.85:
            out.append(f"{move(rng)}*{rng.randint(0, 255)} X{rng.randint(1, 9)}")
        else:
            out.append(body)
    return out


def line_numbers(rng: random.Random) -> list[str]:
    forms = [
        lambda: f"N{rng.randint(0, 99999)} {move(rng)}",
        lambda: f"N-{rng.randint(1, 99)} {move(rng)}",
        lambda: f"N+{rng.randint(1, 99)} {move(rng)}",
        lambda: f"N{rng.randint(1, 99)}.5 {move(rng)}",
        lambda: f"N {rng.randint(1, 99)} {move(rng)}",
        lambda: f"N{rng.randint(1, 99)}G1 X{rng.randint(0, 50)}",
        lambda: f"{move(rng)} N{rng.randint(1, 99)}",
        lambda: f"N{rng.randint(1, 99)}",
        lambda: f"N{rng.randint(1, 9)} M110 N{rng.randint(1, 9)}",
    ]
    return start(rng) + [rng.choice(forms)() for _ in range(rng.randint(4, 9))]


UNKNOWN_G = ("G392", "G40", "G43 H1", "G49", "G52 X5", "G64 P0.01", "G81 R1 Z-1", "G93",
             "G94", "G10", "G11", "G29", "G34", "G60", "G61", "G76", "G98", "G99", "G97",
             "G53", "G1000")  # fmt: skip
UNKNOWN_LINES = ("% start", "%", "PRINT_START BED=60", "EXCLUDE_OBJECT_DEFINE NAME=a",
                 "/G1 X40", "#1=2", "O100 sub", "o100 endsub", "5", "P5", "S1000",
                 "M73 P10 R3", "M900 K0.04", "M862.3 P \"MK3S\"", "M486 S0", "M1001",
                 "\tG1 X33", "T[next_extruder]", "[G1 X5]", "@pause")  # fmt: skip


def unknown(rng: random.Random) -> list[str]:
    out = start(rng)
    for _ in range(rng.randint(4, 8)):
        c = rng.random()
        if c < 0.35:
            out.append(move(rng))
        elif c < 0.65:
            g = rng.choice(UNKNOWN_G)
            out.append(f"{g} X{rng.randint(0, 60)} Y{rng.randint(0, 60)} F{rng.randint(100, 900)}")
        else:
            out.append(rng.choice(UNKNOWN_LINES))
    return [*out, move(rng)]


def no_number(rng: random.Random) -> list[str]:
    forms = ["G X5 Y5", "G", "M", "T", "M X5", "T X5", "G F100", "g", "G.5 X5",
             "G-1 X5", "G 1 X7", "M 107", "G1X5", "G0X-3Y4", "T0", "T1", "G1 X5 G"]  # fmt: skip
    out = start(rng)
    for _ in range(rng.randint(4, 8)):
        out.append(rng.choice(forms) if rng.random() < 0.6 else move(rng))
    return [*out, move(rng)]


def bare(rng: random.Random) -> list[str]:
    out = start(rng)
    for _ in range(rng.randint(3, 6)):
        out.append(rng.choice(("G0", "G1", "G1 F1500", "G0 F6000")) + f" {xy(rng)}")
        for _ in range(rng.randint(1, 3)):
            c = rng.random()
            if c < 0.4:
                out.append(xy(rng))
            elif c < 0.55:
                out.append(f"Z{n(rng.uniform(0, 5))}")
            elif c < 0.7:
                out.append(f"X{rng.randint(0, 50)} E{n(rng.uniform(0, 3), 4)}")
            elif c < 0.8:
                out.append(f"F{rng.randint(100, 5000)}")
            elif c < 0.9:
                out.append(f"X{rng.randint(0, 50)} F{rng.randint(100, 5000)}")
            else:
                out.append(f"{xy(rng)} I3 J4")
    return out


def _on_circle(cx: float, cy: float, r: float, a: float) -> tuple[float, float]:
    return cx + r * math.cos(a), cy + r * math.sin(a)


def arcs_ij(rng: random.Random) -> list[str]:
    sx, sy = rng.uniform(30, 90), rng.uniform(30, 90)
    out = [*start(rng), f"G1 X{n(sx)} Y{n(sy)} F{rng.choice((600, 1800, 3000))}"]
    for _ in range(rng.randint(2, 5)):
        r = rng.uniform(0.5, 30)
        a0 = rng.uniform(0, 2 * math.pi)
        cx, cy = sx - r * math.cos(a0), sy - r * math.sin(a0)
        a1 = a0 + rng.uniform(-2 * math.pi, 2 * math.pi)
        ex, ey = _on_circle(cx, cy, r, a1)
        g = rng.choice(("G2", "G3"))
        i, j = cx - sx, cy - sy
        c = rng.random()
        if c < 0.6:
            words = f"X{n(ex)} Y{n(ey)} I{n(i)} J{n(j)}"
        elif c < 0.7:
            words = f"I{n(i)} J{n(j)}"  # full circle, no axis word
            ex, ey = sx, sy
        elif c < 0.8:
            words = f"X{n(sx)} Y{n(sy)} I{n(i)} J{n(j)}"  # end = start: full circle
            ex, ey = sx, sy
        elif c < 0.9:
            words = f"X{n(ex)} Y{n(ey)} I{n(i)} J{n(j)} Z{n(rng.uniform(0, 5))}"  # helix
        else:
            words = f"X{n(ex)} Y{n(ey)} I{n(i)} J{n(j)} E{n(rng.uniform(0.1, 2), 4)} K3"
        if rng.random() < 0.2:
            words += f" F{rng.randint(300, 3000)}"
        out.append(f"{g} {words}")
        sx, sy = float(n(ex)), float(n(ey))
    return out


def arcs_r(rng: random.Random) -> list[str]:
    sx, sy = rng.uniform(30, 90), rng.uniform(30, 90)
    out = [*start(rng), f"G0 X{n(sx)} Y{n(sy)}", "G1 F1200"]
    for _ in range(rng.randint(2, 5)):
        ex, ey = sx + rng.uniform(-30, 30), sy + rng.uniform(-30, 30)
        chord = math.hypot(ex - sx, ey - sy)
        c = rng.random()
        if c < 0.6:
            r = chord / 2 + rng.uniform(0, 20)
        elif c < 0.75:
            r = chord / 2 * rng.uniform(0.3, 0.99)  # too small: Marlin makes a half circle
        else:
            r = chord / 2
        if rng.random() < 0.4:
            r = -r
        g = rng.choice(("G2", "G3"))
        extra = rng.choice(("", "", f" Z{n(rng.uniform(0, 5))}", f" E{n(rng.uniform(0, 2), 4)}"))
        out.append(f"{g} X{n(ex)} Y{n(ey)} R{n(r)}{extra}")
        sx, sy = float(n(ex)), float(n(ey))
    if rng.random() < 0.3:
        out.append(f"G2 X{n(sx + 5)} Y{n(sy)} R0.001")
    return out


def arc_end(rng: random.Random) -> list[str]:
    """Ends off the start radius: by a slicer's rounding, by millimetres, straight out."""
    sx, sy = rng.uniform(40, 80), rng.uniform(40, 80)
    out = [f"G0 X{n(sx)} Y{n(sy)}", "G1 F900"]
    for _ in range(rng.randint(2, 4)):
        r = rng.uniform(2, 25)
        a0 = rng.uniform(0, 2 * math.pi)
        cx, cy = sx - r * math.cos(a0), sy - r * math.sin(a0)
        a1 = a0 + rng.uniform(-3, 3)
        c = rng.random()
        if c < 0.35:
            rr = r + rng.uniform(-0.005, 0.005)
        elif c < 0.7:
            rr = r + rng.uniform(-3, 3)
        else:
            rr, a1 = r * rng.uniform(1.2, 2.5), a0 + 0.5  # well off the circle
        ex, ey = _on_circle(cx, cy, rr, a1)
        g = rng.choice(("G2", "G3"))
        out.append(f"{g} X{n(ex, 4)} Y{n(ey, 4)} I{n(cx - sx, 4)} J{n(cy - sy, 4)}")
        sx, sy = float(n(ex, 4)), float(n(ey, 4))
    return out


def arc_p(rng: random.Random) -> list[str]:
    sx, sy = rng.uniform(40, 80), rng.uniform(40, 80)
    out = [f"G0 X{n(sx)} Y{n(sy)}", "G1 F2400"]
    for _ in range(rng.randint(1, 3)):
        r = rng.uniform(1, 8)
        a0 = rng.uniform(0, 2 * math.pi)
        cx, cy = sx - r * math.cos(a0), sy - r * math.sin(a0)
        a1 = a0 + rng.uniform(-3, 3)
        ex, ey = _on_circle(cx, cy, r, a1)
        p = rng.choice(("P1", "P2", "P0", "P3", "P1"))
        tail = rng.choice(("", f" Z{n(rng.uniform(0, 4))}"))
        if rng.random() < 0.2:
            out.append(f"G{rng.choice((2, 3))} I{n(cx - sx)} J{n(cy - sy)} {p}{tail}")
            ex, ey = sx, sy
        else:
            words = f"X{n(ex)} Y{n(ey)} I{n(cx - sx)} J{n(cy - sy)}"
            out.append(f"G{rng.choice((2, 3))} {words} {p}{tail}")
        sx, sy = float(n(ex)), float(n(ey))
    return out


def planes(rng: random.Random) -> list[str]:
    out = ["G0 X50 Y50 Z20", "G1 F1000"]
    for _ in range(rng.randint(2, 4)):
        plane = rng.choice(("G17", "G18", "G19"))
        a, b, off = {"G17": ("X", "Y", "IJ"), "G18": ("Z", "X", "KI"),
                     "G19": ("Y", "Z", "JK")}[plane]  # fmt: skip
        r = rng.uniform(2, 10)
        words = f"{a}{n(rng.uniform(-3, 3))} {b}{n(rng.uniform(-3, 3))}"
        if rng.random() < 0.5:
            out += ["G91", plane, f"G{rng.choice((2, 3))} {off[0]}{n(r)} {off[1]}0", "G90"]
        else:  # (an R arc off the XY plane is not kept: Marlin takes its centre from X/Y)
            out += [plane, "G91", f"G{rng.choice((2, 3))} {words} {off[0]}{n(r)}", "G90"]
    return [*out, "G17"]


def g5(rng: random.Random) -> list[str]:
    out = [*start(rng), f"G0 X{rng.randint(20, 60)} Y{rng.randint(20, 60)}", "G1 F1500"]
    for _ in range(rng.randint(1, 4)):
        c = rng.random()
        end = xy(rng, 10, 110)
        pq = f"P{n(rng.uniform(-20, 20))} Q{n(rng.uniform(-20, 20))}"
        ij = f"I{n(rng.uniform(-20, 20))} J{n(rng.uniform(-20, 20))}"
        if c < 0.5:
            out.append(f"G5 {ij} {pq} {end}")
        elif c < 0.7:
            out.append(f"G5 {pq} {end}")  # I J omitted
        elif c < 0.8:
            out.append(f"G5 {ij} {pq} {end} E{n(rng.uniform(0.1, 3), 4)}")
        elif c < 0.9:
            out.append(f"G5 {ij} {pq} {end} Z{n(rng.uniform(0, 3))}")
        else:
            out.append(rng.choice(("G5", f"G5 {end}", f"G5 I0 J0 P0 Q0 {end}")))
    return out


def modes(rng: random.Random) -> list[str]:
    out = []
    for _ in range(rng.randint(5, 10)):
        c = rng.random()
        if c < 0.12:
            out.append(rng.choice(("G90", "G91")))
        elif c < 0.22:
            out.append(rng.choice(("M82", "M83")))
        elif c < 0.35:
            out.append(rng.choice(("G92 E0", f"G92 E{n(rng.uniform(-5, 5))}",
                                   f"G92 X{n(rng.uniform(-20, 20))}", "G92 X0 Y0",
                                   f"G92 Z{n(rng.uniform(0, 5))} E0", "G92")))  # fmt: skip
        elif c < 0.45:
            out.append(f"G1 E{n(rng.uniform(-3, 3), 4)} F2400")
        else:
            out.append(f"G1 X{n(rng.uniform(-20, 40))} Y{n(rng.uniform(-20, 40))} "
                       f"E{n(rng.uniform(-2, 4), 4)}")  # fmt: skip
    return [*out, move(rng)]


def m220(rng: random.Random) -> list[str]:
    out = [*start(rng), f"G1 F{rng.randint(300, 6000)}"]
    for _ in range(rng.randint(5, 9)):
        c = rng.random()
        if c < 0.3:
            out.append(rng.choice((f"M220 S{rng.randint(1, 300)}", "M220 B", "M220 R",
                                   f"M220 B S{rng.randint(10, 200)}", "M220",
                                   f"M220 S{rng.randint(1, 300)}.5")))  # fmt: skip
        elif c < 0.45:
            out.append(f"G2 X{rng.randint(40, 60)} Y{rng.randint(40, 60)} R30")
        else:
            out.append(move(rng))
    return out


def feeds(rng: random.Random) -> list[str]:
    forms = ["G1 X{x} F0", "G1 X{x} F-100", "G1 F0", "G0 X{x} F{f}", "G1 X{x} F{f}.5",
             "F{f}", "G1 X{x} F", "G1 X{x} F1e3", "G1 F{f} X{x}", "G1 X{x}"]  # fmt: skip
    out = [*start(rng), "G1 F1000"]
    for _ in range(rng.randint(4, 8)):
        form = rng.choice(forms)
        out.append(form.format(x=n(rng.uniform(0, 100)), f=rng.randint(60, 9000)))
    return out


def subcodes(rng: random.Random) -> list[str]:
    forms = ["G91.1", "G90.1", "G1.5 X{x}", "G0.1 Y{x}", "G28.1", "G92.1 X{x}", "G91.2",
             "G1.0 X{x}", "G2.5 X{x} Y20 R15", "G21.1", "G17.1", "G4.5 P1", "M83.5",
             "G92.9 E0", "G90.5"]  # fmt: skip
    out = ["G1 X20 Y20 F1200"]
    for _ in range(rng.randint(4, 8)):
        if rng.random() < 0.6:
            out.append(rng.choice(forms).format(x=n(rng.uniform(5, 60))))
        else:
            out.append(move(rng))
    return [*out, f"G1 X{rng.randint(0, 30)}"]


def repeated(rng: random.Random) -> list[str]:
    forms = ["G1 X{a} X{b}", "G1 X{a} Y{b} Y{a}", "G0 Z8 F", "G1 Y1 0", "G1 X{a}.5.5",
             "G1 X", "G1 X{a} E", "G1 X{a} Y{b} I1 J2 R3", "G1 X{a} F{f} F{g}",
             "G1 E1 E2", "G1 X-{a} X+{b}", "G1 X{a}Y{b}Z1", "G1 X--5", "G1 X{a} Y"]  # fmt: skip
    out = [*start(rng), "G1 F1200"]
    for _ in range(rng.randint(4, 8)):
        v = dict(a=n(rng.uniform(0, 60)), b=n(rng.uniform(0, 60)), f=rng.randint(100, 3000),
                 g=rng.randint(100, 3000))  # fmt: skip
        out.append(rng.choice(forms).format(**v))
    return out


def after_g(rng: random.Random) -> list[str]:
    forms = ["G90 M107", "G0 G90 X{a}", "G91 G0 Z{c}", "G17 G2 X{a} I5", "G1 G2 X{a} Y{b} I5",
             "G90 X{a}", "G21 G1 X{a}", "G92 G1 X{a}", "M82 G1 X{a} E2", "G1 X{a} M107",
             "G1 X{a} G91", "G0 X{a} T1", "G1 X{a} S255", "G1 X{a} G0 Y{b}", "G4 G1 X{a}",
             "G90 G91 X{a}", "M83 G91"]  # fmt: skip
    out = [*start(rng), "G1 X10 Y10 F1800"]
    for _ in range(rng.randint(4, 8)):
        v = dict(a=n(rng.uniform(0, 60)), b=n(rng.uniform(0, 60)), c=n(rng.uniform(0, 5)))
        out.append(rng.choice(forms).format(**v) if rng.random() < 0.7 else move(rng))
    return [*out, f"G1 X{rng.randint(0, 30)} Y{rng.randint(0, 30)}"]


def units(rng: random.Random) -> list[str]:
    out = []
    for _ in range(rng.randint(4, 8)):
        c = rng.random()
        if c < 0.25:
            out.append(rng.choice(("G20", "G21")))
        elif c < 0.4:
            out.append(
                f"G2 X{n(rng.uniform(0, 3))} Y{n(rng.uniform(0, 3))} R{n(rng.uniform(2, 4))}"
            )
        elif c < 0.5:
            out.append(rng.choice(("G91", "G90", "G92 X0 Y0", "G92 E0", "M83")))
        else:
            out.append(f"G1 X{n(rng.uniform(0, 4))} Y{n(rng.uniform(0, 4))} "
                       f"E{n(rng.uniform(0, 0.1), 4)} F{rng.randint(10, 100)}")  # fmt: skip
    return [*out, "G21", move(rng)]


def homing(rng: random.Random) -> list[str]:
    forms = ["G28", "G28 X", "G28 Y", "G28 Z", "G28 X Y", "G28 X0 Y0", "G28 Z0", "G28 W",
             "G28 R0", "G28 O", "G28 X5"]  # fmt: skip
    out = []
    for _ in range(rng.randint(4, 8)):
        c = rng.random()
        if c < 0.3:
            out.append(rng.choice(forms))
        elif c < 0.45:
            out.append(rng.choice(("G92 X10 Y10", "G92 Z5", "G91", "G90", "M220 S50")))
        else:
            out.append(move(rng))
    return [*out, move(rng)]


def printer(rng: random.Random) -> list[str]:
    codes = ["M104 S{t}", "M109 S{t}", "M140 S60", "M190 S60", "M106 S255", "M106", "M107",
             "M84", "M18", "M17", "M84 X Y", "M204 S{a}", "M204 P{a} T{a}", "M205 X8 Y8",
             "M201 X{a} Y{a}", "M203 X200 Y200", "M400", "G4 P{p}", "G4 S1", "G4", "M105",
             "M114", "M115", "M117 Printing...", "M118 hello", "M155 S2", "M221 S95",
             "M200 D0", "M92 E93", "M302 S0", "M500", "M501", "M503", "M31", "M300 S440 P200",
             "M80", "M81", "M85 S0", "M111 S0", "M120", "M121", "M42 P13 S255", "M0",
             "M1", "M226 P1", "M600", "M906 X800", "M593 F40", "M569 S1 X"]  # fmt: skip
    out = ["G21", "G90", "M82"]
    for _ in range(rng.randint(5, 10)):
        if rng.random() < 0.5:
            out.append(rng.choice(codes).format(t=rng.randint(180, 240),
                                                a=rng.randint(500, 3000), p=rng.randint(0, 500)))  # fmt: skip
        else:
            out.append(move(rng))
    return [*out, move(rng)]


def lowercase(rng: random.Random) -> list[str]:
    out = [move(rng).lower() if rng.random() < 0.7 else move(rng) for _ in range(rng.randint(4, 8))]
    out.append(rng.choice(("g2 x50 y50 r20", "m220 s50", "g92 e0", "m83", "g91", "g90")))
    return [*out, move(rng).lower()]


def numbers(rng: random.Random) -> list[str]:
    forms = ["G1 X.5 Y-.5", "G1 X+5 Y+.25", "G1 X5. Y6.", "G1 X1e1", "G1 X0x10", "G1 X1,5",
             "G1 X 10 Y 5", "G1 X\t7", "G1 X007.500", "G1 X-0 Y-0.0", "G1 X99999.9",
             "G1 X0.0000001", "G1 X1.23456789", "G1 X12345678", "G1 Y3 X", "G1 X5E2",
             "G1 X.", "G1 X-", "G1 X+-3", "G1 X3/2"]  # fmt: skip
    out = ["G1 F3000"]
    for _ in range(rng.randint(4, 8)):
        out.append(rng.choice(forms) if rng.random() < 0.7 else move(rng))
    return [*out, f"G1 X{rng.randint(0, 30)}"]


def spaces(rng: random.Random) -> list[str]:
    forms = ["   G1 X{a}", "G1   X{a}    Y{b}", "G1X{a}Y{b}", "G1 X{a} ", "  ", "",
             " ; only a comment", "G1\tX{a}", " X{a}", "\r", "G0X{a}Y{b}Z1F1200"]  # fmt: skip
    out = ["G1 F1500"]
    for _ in range(rng.randint(4, 8)):
        v = dict(a=n(rng.uniform(0, 60)), b=n(rng.uniform(0, 60)))
        out.append(rng.choice(forms).format(**v) if rng.random() < 0.7 else move(rng))
    return [*out, move(rng)]


FAMILIES: dict[str, Family] = {
    "comments": comments, "checksums": checksums, "line_numbers": line_numbers,
    "unknown": unknown, "no_number": no_number, "bare": bare, "arcs_ij": arcs_ij,
    "arcs_r": arcs_r, "arc_end": arc_end, "arc_p": arc_p, "planes": planes, "g5": g5,
    "modes": modes, "m220": m220, "feeds": feeds, "subcodes": subcodes,
    "repeated": repeated, "after_g": after_g, "units": units, "homing": homing,
    "printer": printer, "lowercase": lowercase, "numbers": numbers, "spaces": spaces,
}  # fmt: skip


def programs(seed: int = 66, per_family: int = 14) -> dict[str, str]:
    out = {}
    for fam, make in FAMILIES.items():
        rng = random.Random(f"{seed}:{fam}")
        for k in range(per_family):
            out[f"{fam}_{k:03d}"] = "\n".join(make(rng)) + "\n"
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--seed", type=int, default=66)
    ap.add_argument("--per-family", type=int, default=14)
    args = ap.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in programs(args.seed, args.per_family).items():
        (out / f"{name}.gcode").write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
