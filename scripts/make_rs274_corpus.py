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

from rs274_comp_programs import comp_programs
from rs274_cycle_plane_programs import cycle_plane_programs
from rs274_cycle_programs import cycle_programs
from rs274_language_programs import language_programs
from rs274_tool_frame_programs import tool_frame_programs

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


#: spiral tolerance S of LinuxCNC's centre-format radius check, per unit [program unit]
SPIRAL_ABS = {"mm": 0.02 * math.sqrt(2), "in": 0.002 * math.sqrt(2)}


def mismatch_random(rng: random.Random) -> dict[str, str]:
    """Centre-format arcs at random orientations whose end radius is near a LinuxCNC threshold.

    The margin to the threshold (computed from the written, rounded numbers) is at least 1 %, so
    rs274's verdict does not hinge on floating-point rounding.
    """
    out = {}
    k = 0
    while k < 40:
        unit = "in" if k % 3 == 2 else "mm"
        s_abs = SPIRAL_ABS[unit]
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, an, o1, o2 = PLANES[pl]
        regime = k % 4  # 0, 1: absolute S; 2: relative 0.1 %; 3: absolute 100 S
        scale = 1.0 if unit == "mm" else 0.1
        r1 = {
            0: rng.uniform(1, 20),
            1: rng.uniform(1, 20),
            2: rng.uniform(40, 2000),
            3: rng.uniform(3000, 8000),
        }[regime] * scale
        thr = {0: s_abs, 1: s_abs, 2: 0.001 * r1, 3: 100 * s_abs}[regime]
        d = thr * rng.choice([0.9, 0.97, 1.03, 1.1]) * rng.choice([1, -1] if regime < 2 else [1])
        a0, a1_ = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        i, j = round(-r1 * math.cos(a0), 4), round(-r1 * math.sin(a0), 4)
        e1 = round(i + (r1 + d) * math.cos(a1_), 4)
        e2 = round(j + (r1 + d) * math.sin(a1_), 4)
        r1w, r2w = math.hypot(i, j), math.hypot(e1 - i, e2 - j)
        err = abs(r2w - r1w)
        real_thr = {0: s_abs, 1: s_abs, 2: 0.001 * max(r1w, r2w), 3: 100 * s_abs}[regime]
        if abs(err - real_thr) < 0.01 * real_thr or math.hypot(e1, e2) < 0.01:
            continue
        gcode = rng.choice(["G2", "G3"])
        helix = f" {an}{fmt(rng.uniform(-5, 5), 3)}" if k % 5 == 4 else ""
        head = ["G20", "F10"] if unit == "in" else ["G21", "F500"]
        lines = [
            *head,
            g,
            f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)}{helix} {o1}{fmt(i)} {o2}{fmt(j)}",
            "M2",
        ]
        out[f"gen_mismatch_rand_{unit}_{pl}_{k:02d}"] = "\n".join(lines)
        k += 1
    return out


def r_short_random(rng: random.Random) -> dict[str, str]:
    """R-format arcs at random orientations with |R| just below or above half the chord."""
    out = {}
    for k in range(24):
        unit = "in" if k % 2 else "mm"
        tol = 0.00005 if unit == "in" else 0.00127
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, _an, _o1, _o2 = PLANES[pl]
        chord = rng.uniform(1, 40) * (1.0 if unit == "mm" else 0.1)
        ang = rng.uniform(-math.pi, math.pi)
        e1, e2 = round(chord * math.cos(ang), 4), round(chord * math.sin(ang), 4)
        half = math.hypot(e1, e2) / 2
        short = tol * rng.choice([0.2, 0.5, 0.9, 1.1, 1.5, 3.0])
        r = (half - short) * rng.choice([1, -1])
        gcode = rng.choice(["G2", "G3"])
        head = ["G20", "F10"] if unit == "in" else ["G21", "F500"]
        lines = [*head, g, f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)} R{fmt(r, 9)}", "M2"]
        out[f"gen_r_short_rand_{unit}_{pl}_{k:02d}"] = "\n".join(lines)
    return out


def random_programs(rng: random.Random) -> dict[str, str]:
    """Mixed valid programs: planes, G90/G91, G90.1/G91.1, modal continuation, P, helices, F."""
    out = {}
    for k in range(30):
        pos = [0.0, 0.0, 0.0]
        lines = [rng.choice(["G21", "g21", "G21 G94"]) + f" F{rng.choice([200, 500, 1500])}"]
        incr = absc = False
        motion = None
        plane = "xy"
        for _ in range(rng.randint(3, 8)):
            words = []
            if rng.random() < 0.25:
                incr = not incr
                words.append("G91" if incr else "G90")
            if rng.random() < 0.2:
                absc = not absc
                words.append("G90.1" if absc else "G91.1")
            if rng.random() < 0.3:
                plane = rng.choice(["xy", "xz", "yz"])
                words.append(PLANES[plane][0])
            _g, a1, a2, an, o1, o2 = PLANES[plane]
            ax = {"X": 0, "Y": 1, "Z": 2}
            kind = rng.choice(["G0", "G1", "G2", "G3", "G2", "G3"])
            if kind != motion or rng.random() < 0.5:
                words.append(kind)
            motion = kind
            if kind in ("G0", "G1"):
                end = [round(c + rng.uniform(-20, 20), 3) for c in pos]
                axes = [a for a in "XYZ" if rng.random() < 0.7] or ["X"]
                for a in axes:
                    v = end[ax[a]] - pos[ax[a]] if incr else end[ax[a]]
                    words.append(f"{a}{fmt(v)}")
                for a in "XYZ":
                    if a not in axes:
                        end[ax[a]] = pos[ax[a]]
            else:
                r = round(rng.uniform(0.5, 25), 3)
                t0, t1 = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
                c1 = round(pos[ax[a1]] - r * math.cos(t0), 4)
                c2 = round(pos[ax[a2]] - r * math.sin(t0), 4)
                rr = math.hypot(pos[ax[a1]] - c1, pos[ax[a2]] - c2)
                end = list(pos)
                full = rng.random() < 0.1
                if not full:
                    d = (t1 - t0) % (2 * math.pi)
                    if d < 0.1 or d > 2 * math.pi - 0.1:
                        t1 = t0 + 1.0
                    end[ax[a1]] = round(c1 + rr * math.cos(t1), 4)
                    end[ax[a2]] = round(c2 + rr * math.sin(t1), 4)
                if rng.random() < 0.3:
                    end[ax[an]] = round(pos[ax[an]] + rng.uniform(-5, 5), 3)
                for a in (a1, a2, an):
                    if end[ax[a]] != pos[ax[a]] or (a != an and not full and rng.random() < 0.5):
                        v = end[ax[a]] - pos[ax[a]] if incr else end[ax[a]]
                        words.append(f"{a}{fmt(v)}")
                off1 = c1 if absc else c1 - pos[ax[a1]]
                off2 = c2 if absc else c2 - pos[ax[a2]]
                words.append(f"{o1}{fmt(off1)} {o2}{fmt(off2)}")
                if rng.random() < 0.2:
                    words.append(f"P{rng.choice([2, 3])}")
            if rng.random() < 0.2:
                words.append(f"F{rng.choice([100, 300, 800])}")
            text = " ".join(words)
            if rng.random() < 0.15:
                text = text.lower()
            if rng.random() < 0.15:
                text += rng.choice([" (note)", " ; note"])
            lines.append(text)
            pos = end
        lines.append(rng.choice(["M2", "M30", "m2"]))
        out[f"gen_mixed_{k:02d}"] = "\n".join(lines)
    return out


def sweep_extremes(rng: random.Random) -> dict[str, str]:
    """Arcs that sweep almost nothing or almost a full turn, and huge-R arcs over short chords."""
    out = {}
    for k in range(24):
        pl = ["xy", "xz", "yz"][k % 3]
        g, a1, a2, _an, o1, o2 = PLANES[pl]
        gcode = rng.choice(["G2", "G3"])
        if k < 12:  # centre format, end a small angle before/after the start (>= 0.001 mm away)
            r = round(rng.uniform(2, 200), 3)
            t0 = rng.uniform(-math.pi, math.pi)
            delta = rng.choice([1, -1]) * max(0.002 / r, rng.choice([1e-3, 1e-2, 0.05]))
            i, j = round(-r * math.cos(t0), 4), round(-r * math.sin(t0), 4)
            rr = math.hypot(i, j)
            t_start = math.atan2(-j, -i)
            e1 = round(i + rr * math.cos(t_start + delta), 4)
            e2 = round(j + rr * math.sin(t_start + delta), 4)
            move = f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)} {o1}{fmt(i)} {o2}{fmt(j)}"
        else:  # R format, |R| much larger than the chord
            chord = rng.choice([0.01, 0.05, 0.5, 3.0])
            ang = rng.uniform(-math.pi, math.pi)
            e1, e2 = round(chord * math.cos(ang), 4), round(chord * math.sin(ang), 4)
            big_r = rng.choice([100, 1000, 10000, 50000]) * rng.choice([1, -1])
            move = f"{gcode} {a1}{fmt(e1)} {a2}{fmt(e2)} R{big_r}"
        out[f"gen_sweep_extreme_{pl}_{k:02d}"] = "\n".join([f"G21 {g} F600", move, "M2"])
    return out


def main() -> int:
    rng = random.Random(SEED)
    progs: dict[str, str] = {}
    families = (
        centre_arcs,
        r_arcs,
        mismatch,
        r_too_small,
        turns,
        contours,
        mismatch_random,
        r_short_random,
        random_programs,
        sweep_extremes,
    )
    for family in families:
        fam = family(rng)
        assert not set(fam) & set(progs), "duplicate program names"
        progs.update(fam)
    lang = language_programs(SEED + 10)  # its own stream: the families above stay as they were
    assert not set(lang) & set(progs), "duplicate program names"
    progs.update(lang)
    cycles = cycle_programs(SEED + 20)  # canned cycles (issue 11): a stream of their own
    assert not set(cycles) & set(progs), "duplicate program names"
    progs.update(cycles)
    cycle_planes = cycle_plane_programs()  # every cycle in every plane (no randomness)
    assert not set(cycle_planes) & set(progs), "duplicate program names"
    progs.update(cycle_planes)
    comp = comp_programs(SEED + 30)  # cutter compensation (issue 11)
    assert not set(comp) & set(progs), "duplicate program names"
    progs.update(comp)
    tool_frame = tool_frame_programs(SEED + 40)  # tool offsets and frames (issue 10)
    assert not set(tool_frame) & set(progs), "duplicate program names"
    progs.update(tool_frame)
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
