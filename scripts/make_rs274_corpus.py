"""Write the generated families of the rs274 differential corpus (deterministic, seeded).

Writes ``tests/data/rs274/programs/gen_*.ngc`` (and removes stale ``gen_*`` files); the other
programs in that folder are hand-written. After running this, regenerate the expectations with
``scripts/regen_rs274_expected.py``. Usage::

    python scripts/make_rs274_corpus.py
"""

from __future__ import annotations

import math
import random
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = ROOT / "tests" / "data" / "rs274" / "programs"
SEED = 20261122
#: plane -> (G code, first axis, second axis, normal axis, first offset, second offset)
PLANES = {
    "xy": ("G17", "X", "Y", "Z", "I", "J"),
    "xz": ("G18", "Z", "X", "Y", "K", "I"),
    "yz": ("G19", "Y", "Z", "X", "J", "K"),
}


def fmt(v: float, nd: int = 4) -> str:
    s = f"{v:.{nd}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _end_on_circle(rng: random.Random, r: float, a0: float) -> tuple[float, float]:
    """An end angle at least 0.1 rad from the start angle (no near-full-circle ambiguity)."""
    while True:
        a1 = rng.uniform(-math.pi, math.pi)
        d = (a1 - a0) % (2 * math.pi)
        if 0.1 < d < 2 * math.pi - 0.1:
            return r * math.cos(a1), r * math.sin(a1)


def centre_arcs(rng: random.Random) -> dict[str, str]:
    out = {}
    for k in range(48):
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, an, o1, o2 = PLANES[pl]
        inch = k % 4 == 3
        unit, feed = (
            ("G20", rng.choice([5, 10, 20])) if inch else ("G21", rng.choice([150, 600, 2000]))
        )
        r = round(rng.uniform(0.05, 2.0) if inch else rng.uniform(0.5, 80.0), 3)
        a0 = rng.uniform(-math.pi, math.pi)
        s1, s2 = round(rng.uniform(-5, 5), 3), round(rng.uniform(-5, 5), 3)
        c1, c2 = s1 - r * math.cos(a0), s2 - r * math.sin(a0)
        c1, c2 = round(c1, 4), round(c2, 4)
        rr = math.hypot(s1 - c1, s2 - c2)
        e1, e2 = _end_on_circle(rng, rr, math.atan2(s2 - c2, s1 - c1))
        e1, e2 = round(c1 + e1, 4), round(c2 + e2, 4)
        gcode = rng.choice(["G2", "G3"])
        helix = f" {an}{fmt(rng.uniform(-3, 3), 3)}" if k % 5 == 0 else ""
        # F goes on its own line: on the G20 line it would be executed before G20 (as mm/min)
        lines = [
            f"{unit} {g} G90",
            f"F{feed}",
            f"G0 {a1}{fmt(s1)} {a2}{fmt(s2)}",
            f"G1 {an}0",
            f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)}{helix} {o1}{fmt(c1 - s1)} {o2}{fmt(c2 - s2)}",
            "M2",
        ]
        out[f"gen_centre_{pl}_{'in' if inch else 'mm'}_{k:02d}"] = "\n".join(lines)
    return out


def r_arcs(rng: random.Random) -> dict[str, str]:
    out = {}
    for k in range(24):
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, _an, _, _ = PLANES[pl]
        chord_half = rng.uniform(1, 30)
        r = round(chord_half * rng.uniform(1.01, 3.0), 3) * rng.choice([1, -1])
        ang = rng.uniform(-math.pi, math.pi)
        e1, e2 = round(2 * chord_half * math.cos(ang), 3), round(2 * chord_half * math.sin(ang), 3)
        gcode = rng.choice(["G2", "G3"])
        lines = [
            f"G21 {g} F{rng.choice([300, 900])}",
            f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)} R{fmt(r)}",
            "M2",
        ]
        out[f"gen_r_{pl}_{gcode.lower()}_{'neg' if r < 0 else 'pos'}_{k:02d}"] = "\n".join(lines)
    return out


def mismatch(rng: random.Random) -> dict[str, str]:
    """End radius r + d for centre-format arcs, around LinuxCNC's spiral thresholds."""
    out = {}
    cases_mm = [
        (1, 0.028),
        (1, 0.0285),
        (5, 0.028),
        (5, 0.029),
        (50, 0.049),
        (50, 0.051),
        (1000, 1.0),
        (1000, 1.001),
        (4000, 2.828),
        (4000, 2.829),
        (3, -0.028),
        (3, -0.0286),
    ]
    cases_in = [
        (0.1, 0.0028),
        (0.1, 0.00285),
        (5, 0.0049),
        (5, 0.0051),
        (400, 0.2828),
        (400, 0.2829),
    ]
    for unit, cases in (("mm", cases_mm), ("in", cases_in)):
        for k, (r, d) in enumerate(cases):
            pl = ["xy", "xz", "yz"][k % 3]
            g, a1, _a2, _an, o1, _o2 = PLANES[pl]
            gcode = rng.choice(["G2", "G3"])
            head = "G20\nF10" if unit == "in" else "G21 F500"
            lines = [f"{head} {g}", f"{gcode} {a1}{fmt(2 * r + d)} {o1}{fmt(r)}", "M2"]
            tag = f"r{fmt(r)}_d{fmt(d, 5)}".replace(".", "p").replace("-", "m")
            out[f"gen_mismatch_{unit}_{tag}"] = "\n".join(lines)
    return out


def r_too_small(rng: random.Random) -> dict[str, str]:
    out = {}
    for unit, deltas, half in (
        ("mm", [0.0005, 0.001, 0.00126, 0.0013, 0.002, 0.01], 7.5),
        ("in", [0.00002, 0.000049, 0.000051, 0.0001], 0.75),
    ):
        for d in deltas:
            gcode = rng.choice(["G2", "G3"])
            sign = rng.choice(["", "-"])
            head = "G20\nF10" if unit == "in" else "G21 F500"
            lines = [f"{head} G17", f"{gcode} X{fmt(2 * half)} R{sign}{fmt(half - d, 6)}", "M2"]
            out[f"gen_r_short_{unit}_{fmt(d, 6).replace('.', 'p')}"] = "\n".join(lines)
    return out


def turns(rng: random.Random) -> dict[str, str]:
    out = {}
    for k in range(15):
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, an, o1, _o2 = PLANES[pl]
        p = rng.choice([2, 3, 4, 5])
        r = round(rng.uniform(1, 20), 2)
        a = rng.uniform(-math.pi, math.pi)
        e1, e2 = round(r + r * math.cos(a), 4), round(r * math.sin(a), 4)
        if abs(e1) < 1e-3 and abs(e2) < 1e-3:
            e1, e2 = 0.0, 0.0
        gcode = rng.choice(["G2", "G3"])
        helix = f" {an}{fmt(rng.uniform(-10, 10), 2)}" if k % 2 else ""
        lines = [
            f"G21 {g} F700",
            f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)}{helix} {o1}{fmt(r)} P{p}",
            "M2",
        ]
        out[f"gen_turns_{pl}_p{p}_{k:02d}"] = "\n".join(lines)
    return out


def contours(rng: random.Random) -> dict[str, str]:
    """Incremental (G91) chains of lines and semicircles, some with absolute centres."""
    out = {}
    for k in range(16):
        lines = ["G21 G17 G91 F800" + (" G90.1" if k % 4 == 0 else "")]
        x = y = 0.0
        for _ in range(rng.randint(3, 6)):
            kind = rng.choice(["G1", "G2", "G3", "R"])
            dx, dy = round(rng.uniform(-10, 10), 2), round(rng.uniform(-10, 10), 2)
            if kind == "G1":
                lines.append(f"G1 X{fmt(dx)} Y{fmt(dy)}")
            elif kind == "R":
                lines.append(
                    f"{rng.choice(['G2', 'G3'])} X{fmt(dx)} Y{fmt(dy)} R{fmt(math.hypot(dx, dy))}"
                )
            else:
                i, j = dx / 2, dy / 2
                ci, cj = (x + i, y + j) if k % 4 == 0 else (i, j)
                lines.append(f"{kind} X{fmt(dx)} Y{fmt(dy)} I{fmt(ci)} J{fmt(cj)}")
            x, y = x + dx, y + dy
        lines.append("M2")
        out[f"gen_contour_g91_{k:02d}"] = "\n".join(lines)
    return out


def main() -> int:
    rng = random.Random(SEED)
    progs: dict[str, str] = {}
    for family in (centre_arcs, r_arcs, mismatch, r_too_small, turns, contours):
        fam = family(rng)
        assert not set(fam) & set(progs), "duplicate program names"
        progs.update(fam)
    PROGRAMS.mkdir(parents=True, exist_ok=True)
    for old in PROGRAMS.glob("gen_*.ngc"):
        if old.stem not in progs:
            old.unlink()
    for name, text in sorted(progs.items()):
        (PROGRAMS / f"{name}.ngc").write_text(text + "\n")
    print(f"wrote {len(progs)} generated programs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
