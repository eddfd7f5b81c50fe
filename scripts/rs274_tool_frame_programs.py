"""Generated programs for tool offsets and frames (issue 10), for the rs274 corpus.

Families (every line opens with ``N<line number>``, see ``scripts/rs274_language_programs.py``):

- ``gen_tofs_*``: tool changes and offsets mixed with motion: T, M6, M61, G43 (with and without
  H, on the change's line and later), G43.1 X/Y/Z, G43.2 H, G49, G10 L1/L10/L11 (X, Y, Z, R),
  G28/G30/G28.1 and G53 with an offset in effect, under G92/G52 offsets and rotated systems.
- ``gen_turn_*``: XZ and YZ arcs (helical too) in systems turned by quarter turns (G10 L2 R90,
  R180, R-90, R270), which LinuxCNC runs in the turned principal plane, with G92 offsets and
  system changes between them.
- ``gen_frame_*``: frames: G92, G52 and the G92 family together with G10 L2 R, G10 L20 (in
  rotated systems too), G54..G59.3 changes, G28/G30 naming some axes, G53, arcs (XY only while
  a rotation is in effect: gantry-sim refuses XZ/YZ arcs in a turned system).

rs274 -g reads its built-in tool table (tests/data/rs274/rs274_default_tools.tbl: tools 1-3);
T4 appears now and then and must be refused on its line. Deterministic for a given seed.
"""

from __future__ import annotations

import random

from rs274_language_programs import SYSTEMS, _axes, _n, numbered


def _move(rng: random.Random, rotated: bool) -> list[str]:
    c = rng.random()
    if c < 0.35:
        return [f"G0 {_axes(rng, 3)}"]
    if c < 0.7:
        return [f"G1 {_axes(rng, 3)} F{rng.choice((150, 400))}"]
    plane = "G17" if rotated else rng.choice(("G17", "G18", "G19"))
    i1, i2 = {"G17": ("I", "J"), "G18": ("K", "I"), "G19": ("J", "K")}[plane]
    r = rng.uniform(2, 8)
    a = rng.choice((0.0, 0.5, -0.7))
    return [f"{plane} G{rng.choice((2, 3))} {i1}{_n(r)} {i2}{_n(a)} F300", "G17"]


def _tool_line(rng: random.Random) -> str:
    t = rng.choice((0, 1, 2, 3, 1, 2, 3)) if rng.random() > 0.03 else 4
    c = rng.random()
    if c < 0.15:
        return f"T{t} M6"
    if c < 0.25:
        return f"T{t} M6 G43"
    if c < 0.35:
        return f"M61 Q{t}"
    if c < 0.42:
        return f"M61 Q{t} G43"
    if c < 0.55:
        return rng.choice(("G43", f"G43 H{t}", "G49"))
    if c < 0.65:
        return f"G43.1 {_axes(rng, 2)}"
    if c < 0.72:
        return f"G43.2 H{t}"
    if c < 0.8:
        return f"T{t}"
    level = rng.choice((1, 10, 11))
    words = _axes(rng, 2)
    if rng.random() < 0.3:
        words += f" R{_n(rng.uniform(0.5, 3))}"
    return f"G10 L{level} P{max(t, 1)} {words}"


def _frame_line(rng: random.Random, state: dict[str, bool]) -> list[str]:
    c = rng.random()
    if c < 0.16:
        return [f"G92 {_axes(rng, 3)}"]
    if c < 0.26:
        return [f"G52 {_axes(rng, 3)}"]
    if c < 0.32:
        return [rng.choice(("G92.1", "G92.2", "G92.3"))]
    if c < 0.46:
        p = rng.randint(0, 9)
        extra = ""
        if rng.random() < 0.5:
            extra = f" R{rng.choice((0, 20, 30, 90, -45, 180))}"
            state["rotated"] = True
        return [f"G10 L2 P{p} {_axes(rng, 3)}{extra}"]
    if c < 0.56:
        return [f"G10 L20 P{rng.randint(0, 9)} {_axes(rng, 3)}"]
    if c < 0.66:
        return [rng.choice(SYSTEMS)]
    if c < 0.72:
        return [f"G53 G{rng.choice((0, 1))} {_axes(rng, 2)} F200"]
    if c < 0.78:
        return [rng.choice(("G28.1", "G30.1"))]
    g = rng.choice(("G28", "G30"))
    return [g if rng.random() < 0.3 else f"{g} {_axes(rng, 2)}"]


def tool_offsets(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 G17"]
        state = {"rotated": False}
        for _ in range(rng.randint(6, 14)):
            c = rng.random()
            if c < 0.45:
                lines.append(_tool_line(rng))
            elif c < 0.65:
                lines += _frame_line(rng, state)
            else:
                lines += _move(rng, state["rotated"])
        lines += ["G0 X1 Y2 Z3", "M2"]
        out[f"gen_tofs_{k:03d}"] = numbered(lines)
    return out


def frames(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 G17"]
        if rng.random() < 0.3:
            lines.append("G20")
        state = {"rotated": False}
        for _ in range(rng.randint(6, 14)):
            if rng.random() < 0.55:
                lines += _frame_line(rng, state)
            else:
                lines += _move(rng, state["rotated"])
        lines += ["G0 X1 Y2 Z3", "M2"]
        out[f"gen_frame_{k:03d}"] = numbered(lines)
    return out


def turned_arcs(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 G17"]
        for _ in range(rng.randint(4, 9)):
            c = rng.random()
            if c < 0.25:
                r = rng.choice((90, 180, -90, 270, 0, 450))
                lines.append(f"G10 L2 P{rng.choice((0, 1, 2))} {_axes(rng, 3)} R{r}")
            elif c < 0.35:
                lines.append(rng.choice(("G54", "G55", f"G92 {_axes(rng, 2)}", "G92.1")))
            elif c < 0.45:
                lines.append(f"G0 {_axes(rng, 3)}")
            else:
                plane = rng.choice(("G18", "G19"))
                i1, i2 = {"G18": ("K", "I"), "G19": ("J", "K")}[plane]
                a1, a2 = {"G18": ("Z", "X"), "G19": ("Y", "Z")}[plane]
                r = rng.uniform(2, 8)
                end = ""
                if rng.random() < 0.5:  # a half circle, sometimes with a helix along the normal
                    end = f" {a2}[#<_{a2.lower()}>+{_n(2 * r)}]"
                    if rng.random() < 0.5:
                        normal = "Y" if plane == "G18" else "X"
                        end += f" {normal}{_n(rng.uniform(-5, 5))}"
                g = rng.choice((2, 3))
                lines += [f"{plane} G{g}{end} {i1}0 {i2}{_n(r)} F300", "G17"]
                _ = a1
        lines += ["G0 X1 Y2 Z3", "M2"]
        out[f"gen_turn_{k:03d}"] = numbered(lines)
    return out


def tool_frame_programs(seed: int) -> dict[str, str]:
    rng = random.Random(seed)
    programs = {**tool_offsets(rng, 120), **frames(rng, 120)}
    return {**programs, **turned_arcs(random.Random(seed + 1), 60)}  # own stream: above kept
