"""The programs run under LinuxCNC's planner and ours (benchmarks/linuxcnc_peer.py, bench_peer.py).

    python benchmarks/peer_programs.py [OUTDIR]        (default: benchmarks/peer/)

Writes ``NAME.MODE.ngc`` for every program and path-control mode, deterministically (the same
bytes on every run; tests/test_peer_programs.py checks the committed files). Every program is
G21 G90 in mm, F in mm/min, and starts from rest at X0 Y0 Z0. Modes (the program's first line):

* ``g64``: ``G64 P0.01``, blend within 0.01 mm. LinuxCNC 2.9 also sets its naive-CAM
  tolerance Q to P when Q is not given (rs274 -g prints SET_NAIVECAM_TOLERANCE(0.0100)).
* ``g64q0``: ``G64 P0.01 Q0``, the same blend tolerance with LinuxCNC's naive-CAM merge off
  (written for the polyline programs only: elsewhere there is nothing to merge).
* ``g61``: ``G61``, exact path (stops at corners).

Programs:

* ``circle_g3``: a circle R10 as one G3 at F3000.
* ``circle_360``: the same circle as 360 G1 segments (4 decimals) at F3000.
* ``zigzag``: 20 moves of 5 mm turning 30 degrees, then a square (bench_blend.zigzag).
* ``surface``: a polyline raster in XZ (G18) of 2,000 moves of 0.2 mm at F2000
  (bench_blend.surface).
* ``pocket``: a CAM-like pocketing program, 1,986 blocks at F1200: a grid of 32 small pockets,
  each cut as six concentric rounded rectangles offset inwards by 0.5 mm, their sides joined
  by tangent corner arcs of R3 down to R0.5, the rings joined by 0.5 mm linking lines; G0
  between pockets, G1 plunge at F300.
* ``s_chain``: 20 tangent R5 half circles alternating G3/G2 at F6000 (the curvature flips sign
  at every junction, the tangent does not).
* ``noisy_poly``: the first 1,000 blocks of the generated polyline of
  ``benchmarks/programs.py`` (``poly``, 0.05-0.5 mm G1 moves turning 0.5-5 degrees, the turn's
  sign kept for 10-60 moves, seed 1, 4 decimals) at F3000: a noisy CAM polyline, whose local
  curvature jumps from move to move.
* ``drill``: a grid of 3 x 4 holes 12 mm apart, G81 3 mm deep from R1 at F300 (G99: back to R),
  the spindle speed set anew before each row and coolant on around it: rapids between the
  holes (their corners blend in G64), and machine commands LinuxCNC runs at rest.
"""

from __future__ import annotations

import random
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:  # run as a script: import the sibling benchmark module
    sys.path.insert(0, str(HERE.parent))

from benchmarks.bench_blend import polygon, surface, zigzag  # noqa: E402
from benchmarks.programs import GENERATORS  # noqa: E402

#: mode tag -> the program's path-control words
MODES = {"g64": "G64 P0.01", "g64q0": "G64 P0.01 Q0", "g61": "G61"}
#: the programs made of consecutive straight moves, also written in ``g64q0``
NAIVE_CAM_PROGRAMS = ("circle_360", "surface", "noisy_poly")
OUT = HERE / "peer"


def _num(v: float) -> str:
    """``v`` with 4 decimals, trailing zeros dropped ("-0" written as "0")."""
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def circle_g3() -> str:
    return "G21 G90 G17 {mode}\nG0 X10 Y0\nF3000\nG3 X10 Y0 I-10 J0\nM2\n"


def s_chain(n: int = 20, r: float = 5.0, feed: float = 6000.0) -> str:
    """``n`` half circles of radius ``r`` along +X from X-100, alternating G3 and G2: each ends
    where the next starts, moving along the same tangent (+-Y)."""
    x0 = -100.0
    out = [
        f"G{3 if k % 2 == 0 else 2} X{_num(x0 + 2 * r * (k + 1))} Y0 I{_num(r)} J0\n"
        for k in range(n)
    ]
    return f"G21 G90 G17 {{mode}}\nG0 X{_num(x0)} Y0\nF{feed:g}\n{''.join(out)}M2\n"


def drill(rows: int = 3, cols: int = 4, pitch: float = 12.0) -> str:
    """``rows`` x ``cols`` G81 holes ``pitch`` mm apart, row by row, with S before each row."""
    out = ["G0 Z5\n", "M3 S8000\n", "M8\n"]
    for r in range(rows):
        if r:
            out.append(f"S{8000 + 1000 * r}\n")
        for c in range(cols):
            x, y = _num(pitch * c), _num(pitch * r)
            out.append(f"G99 G81 X{x} Y{y} Z-3 R1 F300\n" if c == 0 else f"X{x} Y{y}\n")
        out.append("G80\n")
    out += ["G0 Z5\n", "M9\n", "M5\n"]
    return f"G21 G90 G17 {{mode}}\n{''.join(out)}M2\n"


def _ring(cx: float, cy: float, a: float, b: float, r: float) -> list[str]:
    """A rounded rectangle centred on (cx, cy), half sides ``a`` x ``b``, corner radius ``r``,
    cut clockwise (climb milling inside a pocket) from the middle of its left side and back."""
    x0, x1, y0, y1 = cx - a, cx + a, cy - b, cy + b
    return [
        f"G1 X{_num(x0)} Y{_num(y1 - r)}\n",
        f"G2 X{_num(x0 + r)} Y{_num(y1)} I{_num(r)} J0\n",
        f"G1 X{_num(x1 - r)} Y{_num(y1)}\n",
        f"G2 X{_num(x1)} Y{_num(y1 - r)} I0 J{_num(-r)}\n",
        f"G1 X{_num(x1)} Y{_num(y0 + r)}\n",
        f"G2 X{_num(x1 - r)} Y{_num(y0)} I{_num(-r)} J0\n",
        f"G1 X{_num(x0 + r)} Y{_num(y0)}\n",
        f"G2 X{_num(x0)} Y{_num(y0 + r)} I0 J{_num(r)}\n",
        f"G1 X{_num(x0)} Y{_num(cy)}\n",
    ]


def pocket(cols: int = 8, rows: int = 4, feed: float = 1200.0) -> str:
    """A grid of ``cols`` x ``rows`` pockets 8 x 7 mm, 0.5 mm deep, 12 mm apart, each cut as six
    rings from the outside in (ring k: half sides 4 - 0.5 k by 3.5 - 0.5 k, corner radius
    3 - 0.5 k), each ring's start linked to the next one's by a 0.5 mm line inwards."""
    blocks = []
    for j in range(rows):
        for i in range(cols):
            cx, cy = -42.0 + 12.0 * i, -18.0 + 12.0 * j
            blocks.append(f"G0 Z1\nG0 X{_num(cx - 4.0)} Y{_num(cy)}\nG1 Z-0.5 F300\nF{feed:g}\n")
            for k in range(6):
                if k:  # the linking line to this ring's start
                    blocks.append(f"G1 X{_num(cx - 4.0 + 0.5 * k)} Y{_num(cy)}\n")
                blocks += _ring(cx, cy, 4.0 - 0.5 * k, 3.5 - 0.5 * k, 3.0 - 0.5 * k)
    return f"G21 G90 G17 {{mode}}\n{''.join(blocks)}G0 Z1\nM2\n"


def noisy_poly(n: int = 1000) -> str:
    """The first ``n`` blocks of ``benchmarks/programs.py``'s polyline of 10,000 blocks, seed 1
    (its 10,000-block program's own moves, so the bench's figures and this one's agree)."""
    rng = random.Random("1:poly:10000")
    head, blocks = GENERATORS["poly"](10_000, rng)
    return f"G21 G90 G17 {{mode}}\n{head}\n" + "\n".join(blocks[:n]) + "\nM2\n"


def programs() -> dict[str, str]:
    """Program name -> its text with ``{mode}`` where the path-control words go."""
    return {
        "circle_g3": circle_g3(),
        "circle_360": polygon(360),
        "zigzag": zigzag(20),
        "surface": surface(2000),
        "pocket": pocket(),
        "s_chain": s_chain(),
        "drill": drill(),
        "noisy_poly": noisy_poly(),
    }


def modes(name: str) -> tuple[str, ...]:
    """The mode tags ``name`` is written in: ``g64q0`` only where LinuxCNC's naive-CAM merge
    can act (consecutive straight moves)."""
    return ("g64", "g64q0", "g61") if name in NAIVE_CAM_PROGRAMS else ("g64", "g61")


def files() -> dict[str, str]:
    """File name (``NAME.MODE.ngc``) -> its text, for every program and its modes."""
    return {
        f"{name}.{tag}.ngc": text.format(mode=MODES[tag])
        for name, text in programs().items()
        for tag in modes(name)
    }


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    out.mkdir(parents=True, exist_ok=True)
    for name, text in files().items():
        (out / name).write_text(text)
    print(f"{len(files())} programs written to {out}")


if __name__ == "__main__":
    main()
