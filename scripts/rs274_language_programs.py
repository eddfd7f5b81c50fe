"""Generated programs for the wider LinuxCNC language (issue 10), for the rs274 corpus.

Every line opens with ``N<line number>`` so that ``scripts/regen_rs274_expected.py`` can take
each motion's line from rs274's own output (O-word loops make prefixes meaningless). Families:
offsets (G92 family, G10 L2/L20 with R, G54-G59.3, G53, G28/G30 with stored points, units),
named and predefined parameters with every operator and function, and O-word control flow.
Used by ``scripts/make_rs274_corpus.py``; deterministic for a given seed.
"""

from __future__ import annotations

import random

SYSTEMS = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
FUNCS = ("ABS", "ACOS", "ASIN", "COS", "EXP", "FIX", "FUP", "LN", "ROUND", "SIN", "SQRT", "TAN")
OPS = ("+", "-", "*", "/", "MOD", "**", "EQ", "NE", "GT", "GE", "LT", "LE", "AND", "OR", "XOR")
PREDEFINED = ("_x", "_y", "_z", "_metric", "_imperial", "_absolute", "_incremental", "_feed",
              "_coord_system", "_plane", "_motion_mode", "_line", "_vmajor", "_ijk_absolute_mode",
              "_current_tool", "_spindle_on", "_flood", "_mist", "_units_per_minute")  # fmt: skip


def _n(v: float) -> str:
    s = f"{v:.3f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def numbered(lines: list[str]) -> str:
    return "\n".join(f"N{k} {ln}" for k, ln in enumerate(lines, 1))


def _axes(rng: random.Random, k: int = 2) -> str:
    return " ".join(f"{a}{_n(rng.uniform(-20, 20))}" for a in rng.sample("XYZ", rng.randint(1, k)))


def _motion(rng: random.Random, xy_only: bool) -> list[str]:
    c = rng.random()
    if c < 0.3:
        return [f"G0 {_axes(rng, 3)}"]
    if c < 0.6:
        return [f"G1 {_axes(rng, 3)} F{rng.choice((100, 250, 600))}"]
    plane = "G17" if xy_only else rng.choice(("G17", "G18", "G19"))
    (i1, i2) = {"G17": ("I", "J"), "G18": ("K", "I"), "G19": ("J", "K")}[plane]
    r = rng.uniform(2, 8)
    return [f"{plane} G{rng.choice((2, 3))} {i1}{_n(r)} {i2}0 F300", "G17"]


def offsets(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 G17"]
        rotated = False
        for _ in range(rng.randint(5, 12)):
            c = rng.random()
            if c < 0.12:
                lines.append(f"G92 {_axes(rng, 3)}")
            elif c < 0.18:
                lines.append(rng.choice(("G92.1", "G92.2", "G92.3")))
            elif c < 0.30:
                p = rng.randint(0, 9)
                extra = ""
                if rng.random() < 0.4:
                    extra = f" R{rng.choice((0, 15, 30, 90, -45))}"
                    rotated = True
                lines.append(f"G10 L2 P{p} {_axes(rng, 3)}{extra}")
            elif c < 0.36:
                lines.append(f"G10 L20 P{rng.randint(0, 9)} {_axes(rng, 2)}")
            elif c < 0.46:
                lines.append(rng.choice(SYSTEMS))
            elif c < 0.52:
                lines.append(f"G53 G{rng.choice((0, 1))} {_axes(rng, 2)} F200")
            elif c < 0.58:
                lines.append(rng.choice(("G28.1", "G30.1")))
            elif c < 0.66:
                g = rng.choice(("G28", "G30"))
                lines.append(g if rng.random() < 0.5 else f"{g} {_axes(rng, 2)}")
            elif c < 0.70:
                lines.append(rng.choice(("G20", "G21")))
            elif c < 0.73:
                lines.append(rng.choice(("G91", "G90")))
            else:
                lines += _motion(rng, xy_only=rotated)
        lines.append("G0 X1 Y2 Z3")
        lines.append("M2")
        out[f"gen_lang_offsets_{k:03d}"] = numbered(lines)
    return out


def _expr(rng: random.Random, depth: int = 0) -> str:
    c = rng.random()
    if depth > 2 or c < 0.3:
        return _n(rng.uniform(0.1, 9))
    if c < 0.5:
        f = rng.choice(FUNCS)
        arg = {"ACOS": "0.5", "ASIN": "0.25", "LN": "2.5", "SQRT": "7"}.get(
            f, _expr(rng, depth + 1)
        )
        return f"{f}[{arg}]"
    if c < 0.55:
        return f"ATAN[{_expr(rng, depth + 1)}]/[{_expr(rng, depth + 1)}]"
    op = rng.choice(OPS)
    b = _expr(rng, depth + 1) if op not in ("/", "MOD", "**") else _n(rng.uniform(1, 3))
    return f"[{_expr(rng, depth + 1)} {op} {b}]"


def parameters(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 F400"]
        names: list[str] = []
        for _ in range(rng.randint(4, 9)):
            c = rng.random()
            if c < 0.3:
                name = rng.choice(("a", "depth", "_g", "_safe_z", "b2"))
                lines.append(f"#<{name}>={_expr(rng)}")
                names.append(name)
            elif c < 0.45:
                lines.append(f"#{rng.randint(1, 40)}={_expr(rng)}")
            elif c < 0.75:
                src = rng.choice(
                    [f"#<{n}>" for n in names] + [f"#<{rng.choice(PREDEFINED)}>", "#1", "#5420"]
                )
                lines.append(
                    f"G{rng.choice((0, 1))} {rng.choice('XYZ')}[{src}*{_n(rng.uniform(0.1, 2))}]"
                )
            elif c < 0.85:
                name = rng.choice(("a", "nope", "_g"))
                lines.append(f"G0 X[EXISTS[#<{name}>]*5+{_expr(rng)}]")
            else:
                lines.append(f"G1 X{_expr(rng)} Y{_expr(rng)}")
        lines.append("M2")
        out[f"gen_lang_params_{k:03d}"] = numbered(lines)
    return out


def control(rng: random.Random, count: int) -> dict[str, str]:
    out = {}
    for k in range(count):
        lines = ["G21 G90 F500"]
        sub = rng.random() < 0.6
        if sub:
            name = rng.choice(("100", "<pocket>", "<a1>"))
            lines += [
                f"o{name} sub",
                "G1 X[#1] Y[#2]",
                f"o{name} if [#1 GT #2]",
                f"o{name} return [#1-#2]",
                f"o{name} endif",
                "G0 Z#3",
                f"o{name} endsub [#1+#2]",
            ]
        for j in range(rng.randint(2, 5)):
            c = rng.random()
            tag = str(200 + j)
            if c < 0.25 and sub:
                args = " ".join(f"[{_n(rng.uniform(-5, 5))}]" for _ in range(rng.randint(0, 3)))
                lines += [f"o{name} call {args}", "G0 X#<_value>"]
            elif c < 0.45:
                n = rng.randint(0, 4)
                lines += [
                    f"#<i>={0}",
                    f"o{tag} while [#<i> LT {n}]",
                    "G91 G1 X1",
                    "G90",
                    "#<i>=[#<i>+1]",
                    f"o{tag} if [#<i> EQ {rng.randint(1, 4)}]",
                    f"o{tag} {rng.choice(('break', 'continue'))}",
                    f"o{tag} endif",
                    f"o{tag} endwhile",
                ]
            elif c < 0.6:
                lines += [
                    f"o{tag} repeat [{rng.randint(0, 3)}]",
                    "G91 G0 Y2",
                    "G90",
                    f"o{tag} endrepeat",
                ]
            elif c < 0.75:
                lines += [
                    "#<j>=0",
                    f"o{tag} do",
                    "G91 G0 Z-1",
                    "G90",
                    "#<j>=[#<j>+1]",
                    f"o{tag} while [#<j> LT {rng.randint(0, 3)}]",
                ]
            else:
                v = _n(rng.uniform(-3, 3))
                lines += [
                    f"o{tag} if [{v} GT 0]",
                    "G0 X10",
                    f"o{tag} elseif [{v} LT -1]",
                    "G0 X-10",
                    f"o{tag} else",
                    "G0 Y5",
                    f"o{tag} endif",
                ]
        lines.append("M2")
        out[f"gen_lang_control_{k:03d}"] = numbered(lines)
    return out


def language_programs(seed: int) -> dict[str, str]:
    rng = random.Random(seed)
    return {**offsets(rng, 150), **parameters(rng, 80), **control(rng, 80)}
