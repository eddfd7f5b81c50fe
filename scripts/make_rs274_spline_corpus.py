"""Write the spline corpus (G5, G5.1, G5.2/G5.3) and record what LinuxCNC does with it.

Writes ``tests/data/rs274_splines/programs/*.ngc`` (``gen_*``: seeded, deterministic; ``err_*``:
the refusals measured with rs274; the other hand-written ones probe one rule each; ``own_*``:
whole programs in the style of real ones, a NURBS outline with weights and orders
(``own_nurbs_outline``) and an engraving of many small G5.1 curves written with parameters and
expressions (``own_g51_engraving``, seeded); every program is our own text), then for every
program:

* ``raw/NAME.txt``: ``rs274 -g NAME.ngc`` (exit status, stdout, stderr): rs274 prints each
  spline as ``NURBS_FEED(k, ...)`` with k its number of control points, and the error text;
* ``expected/NAME.json``: ``nurbs_feeds`` (the k of each NURBS_FEED, in order), and what
  LinuxCNC's ``gcode`` module gives (``scripts/rs274_spline_probe.py``): every straight feed and
  traverse as a row [line, "feed" or "traverse", x, y, z] in the machine's work frame [mm]
  (inch output times 25.4;
  ``R(rotation) (p + g92) + g5x``), where a spline is LinuxCNC's own NURBS evaluated at
  u = j * umax / (15 k) (gcodemodule.cc, NURBS_FEED), and the error (line, message) if any.

LinuxCNC's interpreter is not safe to run in parallel: both tools run under
``flock /tmp/rs274.lock``, one program at a time. Needs ``rs274`` and ``/usr/bin/python3`` with
LinuxCNC's module (Debian ``linuxcnc-uspace``). Usage::

    python scripts/make_rs274_spline_corpus.py
"""

from __future__ import annotations

import json
import math
import random
import re
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "rs274_splines"
PROBE = ROOT / "scripts" / "rs274_spline_probe.py"
SEED = 20261123
INCH_MM = 25.4

#: A leaf-shaped outline cut as four NURBS curves (G5.2 ... G5.3): orders 3 and 4 (L), weights
#: above and below 1 (P), control points on continuation lines without a G word, a first line
#: with its weight, Z plunges and a spindle between the curves.
OWN_NURBS_OUTLINE = """(own program: a leaf outline of NURBS curves with weights, orders 3 and 4)
G21 G90 G17
G0 Z25
M3 S12000
G0 X-2 Y0
G0 Z3
G1 Z-2.5 F150
F700

(upper edge, order 3, the middle points pulled in by a weight of 2)
G5.2 X4.5   Y6.25   P1   L3
     X12.75 Y10.5   P2
     X22    Y9.75   P2
     X30.5  Y4      P1
     X34    Y0      P1
G5.3

(lower edge back to the stem, order 4, one light point)
G5.2 X29    Y-5.5   P1   L4
     X20.25 Y-9.25  P0.6
     X10    Y-8     P1.5
     X3.5   Y-3.75  P1
     X-2    Y0      P1
G5.3

G0 Z3
G0 X1 Y0
G1 Z-1.5 F150
F700

(the midrib: a flat curve of order 3, all weights equal)
G5.2 X9     Y1.25   P1   L3
     X18    Y1.5    P1
     X27    Y0.5    P1
     X31    Y0      P1
G5.3

(a vein, a single span of order 3 with a heavy middle point)
G5.2 P1 L3
     X16    Y5.5    P3
     X21    Y7      P1
G5.3

G0 Z25
M5
M2
"""

#: hand-written programs rs274 refuses (or accepts in a way worth pinning), by what they probe
HAND: dict[str, str] = {
    "err_g5_i_without_j": "G21 G1 F100 X1\nG5 I1 P1 Q1 X5 Y0\nM2\n",
    "err_g5_without_pq": "G21 G1 F100 X1\nG5 I1 J1 X5 Y0\nM2\n",
    "err_g5_p_only": "G21 G1 F100 X1\nG5 I1 J1 P1 X5 Y0\nM2\n",
    "err_g51_p_word": "G21 G1 F100 X1\nG5.1 I1 J1 P1 X5 Y0\nM2\n",
    "err_g51_without_j": "G21 G1 F100 X1\nG5.1 I1 X5 Y0\nM2\n",
    "err_g5_no_axes": "G21 G1 F100 X1\nG5 I1 J1 P1 Q1\nM2\n",
    "err_g5_z_word": "G21 G1 F100 X1\nG5 I1 J1 P1 Q1 X4 Y1 Z1\nM2\n",
    "err_g5_plane_xz": "G21 G18 G1 F100 X1\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n",
    "err_g51_plane_yz": "G21 G19 G1 F100 X1\nG5.1 I1 J1 X4 Y1\nM2\n",
    "err_g5_cutter_comp": "G21 G1 F100 X1\nG41.1 D1 G1 X2 Y1\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n",
    "err_g5_inverse_time_no_f": "G21 G93 G1 X1 F1\nG5 I1 J1 P1 Q1 X4 Y1\nM2\n",
    "err_g5_k_word": "G21 G1 F100 X1\nG5 I1 J1 K1 P1 Q1 X4 Y1\nM2\n",
    "err_g5_not_modal": "G21 G1 F100 X1\nG5 I1 J1 P1 Q1 X5 Y0\nX9 Y0 P1 Q1\nM2\n",
    "err_nurbs_axes_after_g53": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 L3\nX3 Y0 P1\nX4 Y1 P1\nG5.3\nX5\nM2\n",
    "err_nurbs_no_weight": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 L3\nX3 Y0\nG5.3\nM2\n",
    "err_nurbs_p_alone": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 L3\nP2\nG5.3\nM2\n",
    "err_nurbs_g53_after_g1": "G21 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 Y0 P1\nG1 X7\nG5.3\nM2\n",
    "err_nurbs_g53_alone": "G21 G1 F100 X1\nG5.3\nM2\n",
    "err_nurbs_x_only": "G21 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 P1\nG5.3\nM2\n",
    "err_nurbs_g53_with_g1": "G21 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 Y0 P1\nG5.3 G1 X5\nM2\n",
    "err_nurbs_too_few_points": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 L5\nX3 Y0 P1\nX4 Y0 P1\nG5.3\nM2\n",
    "err_nurbs_p_without_xy_later": "G21 G1 F100 X1\nG5.2 X2 Y1 P1\nG5.2 P3\nX3 Y0 P1\nG5.3\nM2\n",
    "g5_modal_motion_stays": "G21 G1 F100 X1\nG5 I1 J1 P1 Q1 X5 Y0\nX9 Y0\nM2\n",
    "g5_without_ij_first": "G21 G1 F100 X1\nG5 P1 Q1 X5 Y0\nM2\n",
    "g5_mirror_across_g1": "G21 G1 F100 X1\nG5 I1 J1 P1 Q2 X5 Y0\nG1 X6\nG5 P1 Q1 X9 Y1\nM2\n",
    "g5_only_x": "G21 G1 F100 X1\nG5 I1 J1 P1 Q1 X4\nM2\n",
    "nurbs_first_weight_from_p_line": "G21 G1 F100 X1\nG5.2 P2 L4\nX2 Y1 P1\nX3 Y0 P1\nX4 Y1 P1\nG5.3\nM2\n",
    "nurbs_first_point_without_p": "G21 G1 F100 X1\nG5.2 X2 Y1\nX3 Y0 P2\nG5.3\nM2\n",
    "nurbs_l2_keeps_order_3": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 L2\nX3 Y0 P1\nG5.3\nM2\n",
    "nurbs_feed_set_midway": "G21 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 Y0 P1\nF200\nX4 Y1 P1\nG5.3\nM2\n",
    "nurbs_plane_xz_reads_xy": "G21 G18 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 Y0 P1\nG5.3\nM2\n",
    "nurbs_z_word_ignored": "G21 G1 F100 X1\nG5.2 X2 Y1 P1 Z3\nX3 Y0 P1\nG5.3\nM2\n",
    "nurbs_incremental": "G21 G91 G1 F100 X1\nG5.2 X2 Y1 P1\nX3 Y0 P1\nG5.3\nG1 X1\nM2\n",
    "g5_two_segments_mirrored": "G21 G90 G17\nG0 X1 Y-1\nG5 I2 J1 P-1 Q2 X4 Y2 F450\nG5 P-1 Q2 X6 Y5\nM2\n",
    "g51_one_curve": "G21 G90 G17\nG0 X3 Y-2\nG5.1 X7 I1 J5 F450\nM2\n",
    "nurbs_two_curves_weights": (
        "G21 G90 G17 F450\nG0 X1 Y1\nG5.2 X1 Y4 P1 L3\nX4 Y5 P2\nX5 Y1 P1\nX2 Y0 P0.5\nG5.3\n"
        "G0 X8 Y1\nG5.2 X9 Y3 P2 L4\nX11 Y4 P1\nX12 Y1 P1\nX10 Y0 P3\nG5.3\nM2\n"
    ),
    "own_nurbs_outline": OWN_NURBS_OUTLINE,
}


def fmt(v: float, nd: int = 3) -> str:
    s = f"{v:.{nd}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _frame_lines(rng: random.Random, k: int) -> list[str]:
    """Offsets for some programs: a G55 with an XY rotation, or a G92 shift (never both: rs274's
    interpreter and canonical layer disagree there, see tests/test_rs274_corpus.py)."""
    kind = k % 4
    if kind == 1:
        x, y, r = rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-90, 90)
        return [f"G10 L2 P2 X{fmt(x)} Y{fmt(y)} Z0 R{fmt(r, 2)}", "G55"]
    if kind == 2:
        return ["G0 X3 Y-2", f"G92 X{fmt(rng.uniform(-9, 9))} Y{fmt(rng.uniform(-9, 9))}"]
    return []


def bezier_programs(rng: random.Random) -> dict[str, str]:
    out = {}
    for k in range(48):
        inch = k % 5 == 4
        unit = 0.04 if inch else 1.0
        lines = ["G20" if inch else "G21", "G17 G90", *_frame_lines(rng, k)]
        lines.append(f"G0 X{fmt(rng.uniform(-5, 5) * unit)} Y{fmt(rng.uniform(-5, 5) * unit)}")
        lines.append(f"F{rng.choice([100, 600, 1500]) if not inch else rng.choice([4, 20, 60])}")
        if k % 6 == 3:
            lines.append("G91")
        for j in range(rng.randint(2, 5)):
            roll = rng.random()
            x, y = (rng.uniform(-20, 20) * unit for _ in range(2))
            i, jj, p, q = (rng.uniform(-8, 8) * unit for _ in range(4))
            if roll < 0.15 and j > 0:
                lines.append(f"G1 X{fmt(x)} Y{fmt(y)}")
            elif roll < 0.35:
                lines.append(f"G5.1 X{fmt(x)} Y{fmt(y)} I{fmt(i)} J{fmt(jj)}")
            elif roll < 0.6 and j > 0:
                lines.append(f"G5 X{fmt(x)} Y{fmt(y)} P{fmt(p)} Q{fmt(q)}")  # mirror
            else:
                lines.append(f"G5 X{fmt(x)} Y{fmt(y)} I{fmt(i)} J{fmt(jj)} P{fmt(p)} Q{fmt(q)}")
        lines.append("G1 X0 Y0" if k % 6 != 3 else "G1 X1")
        out[f"gen_bezier_{k:03d}"] = "\n".join([*lines, "M2", ""])
    return out


def nurbs_programs(rng: random.Random) -> dict[str, str]:
    out = {}
    for k in range(36):
        inch = k % 6 == 5
        unit = 0.04 if inch else 1.0
        lines = ["G20" if inch else "G21", "G17 G90", *_frame_lines(rng, k)]
        x0, y0 = rng.uniform(-5, 5) * unit, rng.uniform(-5, 5) * unit
        lines += [f"G0 X{fmt(x0)} Y{fmt(y0)}", f"F{20 if inch else 800}"]
        order = rng.choice([3, 3, 4, 4, 5])
        n = rng.randint(order, order + 5)
        lword = f" L{order}" if order > 3 or k % 2 else ""
        first = k % 3
        if first == 1:
            lines.append(f"G5.2 P{fmt(rng.uniform(0.5, 3), 2)}{lword}")
            lword = ""
        x, y = x0, y0
        for j in range(n - 1):
            x += rng.uniform(1, 6) * unit
            y = rng.uniform(-8, 8) * unit
            w = fmt(rng.uniform(0.5, 3), 2)
            head = "G5.2 " if j == 0 else ""
            lines.append(f"{head}X{fmt(x)} Y{fmt(y)} P{w}{lword if j == 0 else ''}")
        lines += ["G5.3", f"G1 X{fmt(x + 2 * unit)}", "M2", ""]
        out[f"gen_nurbs_{k:03d}"] = "\n".join(lines)
    return out


def engraving_program(rng: random.Random) -> str:
    """Closed rings of small quadratic G5.1 curves (plus a few G01 edges), every coordinate an
    expression of numbered parameters (scale, offsets, heights, feed) as a text-engraving
    generator writes them: integer design units times a small scale, no units word."""
    lines = [
        "G54 G92.1",
        "(own program: rings of quadratic G5.1 curves, coordinates as expressions of parameters)",
        "#1=0.2     (clearance height)",
        "#2=0.05    (engraving depth)",
        "#3=0.00275 (scale: design units to program units)",
        "#4=180.0   (feed)",
        "#5=4.0     (X offset)",
        "#6=-1.5    (Y offset)",
    ]

    def xy(x: int, y: int) -> str:
        return f"X [{x}*#3+#5] Y [{y}*#3+#6]"

    for ring in range(18):
        cx, cy = 900 + 1500 * (ring % 6), 900 + 1700 * (ring // 6)
        radius = rng.randint(320, 700)
        lobes, depth = rng.choice([2, 3, 4, 5]), rng.uniform(0.05, 0.3)
        n = rng.randint(7, 13)
        pts = []
        for j in range(n):
            t = 2 * math.pi * j / n + rng.uniform(-0.1, 0.1)
            r = radius * (1 + depth * math.cos(lobes * t))
            pts.append((round(cx + r * math.cos(t)), round(cy + r * math.sin(t))))
        lines += [f"(ring {ring + 1})", "G00 Z #1", f"G00 {xy(*pts[0])}", "G01 Z [0-#2] F#4"]
        for j in range(n):
            (x0, y0), (x1, y1) = pts[j], pts[(j + 1) % n]
            if rng.random() < 0.12:
                lines.append(f"G01 {xy(x1, y1)} (edge)")
                continue
            # control point: the chord's middle pushed away from the ring's centre
            mx, my = (x0 + x1) / 2 - cx, (y0 + y1) / 2 - cy
            bulge = 1 + rng.uniform(0.04, 0.25)
            i, jj = round(cx + mx * bulge - x0), round(cy + my * bulge - y0)
            lines.append(f"G5.1 X[{x1}*#3+#5] Y[{y1}*#3+#6] I[{i}*#3] J[{jj}*#3]")
    lines += ["G00 Z #1", "M2", ""]
    return "\n".join(lines)


def run_locked(args: list[str]) -> subprocess.CompletedProcess:
    """Run one LinuxCNC tool under the lock, in a scratch folder: rs274 and the gcode module
    write their parameter file (rs274ngc.var and its .bak) into the working directory."""
    with tempfile.TemporaryDirectory() as scratch:
        return subprocess.run(
            ["flock", "/tmp/rs274.lock", *args],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=scratch,
        )


def to_work(move: dict) -> list[float]:
    p = [c * INCH_MM for c in move["p"]]
    g5x = [c * INCH_MM for c in move["g5x"]]
    g92 = [c * INCH_MM for c in move["g92"]]
    x, y, z = (p[i] + g92[i] for i in range(3))
    t = math.radians(move["rotation_deg"])
    if t != 0.0:
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
    return [x + g5x[0], y + g5x[1], z + g5x[2]]


def rs274_error(stderr: str, text: str, module_error: dict | None) -> dict | None:
    """rs274 -g's error: its message and the failing block's text (the last two lines of its
    stderr), placed on the program line with that text. (The module's own line for an error
    found while reading a block is the next line's, so rs274 -g's block text decides.)"""
    if module_error is None:
        return None
    tail = [ln for ln in stderr.splitlines() if ln.strip() and "executing" not in ln]
    message, block = tail[-2].strip(), tail[-1].strip()
    lines = [ln.strip() for ln in text.splitlines()]
    if block not in lines or message != module_error["message"]:
        raise SystemExit(f"cannot place rs274's error {message!r} at {block!r}: {module_error}")
    return {"line": lines.index(block) + 1, "message": message}


def record(name: str, path: Path) -> None:
    g = run_locked(["rs274", "-g", str(path)])
    raw = f"exit {g.returncode}\n--- stdout\n{g.stdout}--- stderr\n{g.stderr}"
    (DATA / "raw" / f"{name}.txt").write_text(raw)
    feeds = [int(m) for m in re.findall(r"NURBS_FEED\((\d+),", g.stdout)]
    probe = run_locked(["/usr/bin/python3", str(PROBE), str(path)])
    if probe.returncode != 0:
        raise SystemExit(f"{name}: probe failed: {probe.stderr}")
    found = json.loads(probe.stdout.strip().splitlines()[-1])
    moves = [[m["line"], m["kind"], *to_work(m)] for m in found["moves"]]
    version = run_locked(["dpkg-query", "-W", "-f", "${Version}", "linuxcnc-uspace"]).stdout
    expected = {
        "origin": f"LinuxCNC {version}: rs274 -g and the gcode module (scripts/{PROBE.name})",
        "nurbs_feeds": feeds,
        "error": rs274_error(g.stderr, path.read_text(), found["error"]),
        "moves": moves,
    }
    rows = ",\n".join(json.dumps(row) for row in moves)
    head = json.dumps({k: v for k, v in expected.items() if k != "moves"})[:-1]
    (DATA / "expected" / f"{name}.json").write_text(f'{head}, "moves": [\n{rows}\n]}}\n')


def main() -> None:
    rng = random.Random(SEED)
    programs = {**HAND, **bezier_programs(rng), **nurbs_programs(rng)}
    programs["own_g51_engraving"] = engraving_program(random.Random(SEED + 1))
    for sub in ("programs", "raw", "expected"):
        (DATA / sub).mkdir(parents=True, exist_ok=True)
        for stale in (DATA / sub).glob("*"):
            stale.unlink()
    for name, text in programs.items():
        path = DATA / "programs" / f"{name}.ngc"
        path.write_text(text)
        record(name, path)
    print(f"{len(programs)} programs recorded in {DATA}")


if __name__ == "__main__":
    main()
