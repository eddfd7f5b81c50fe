"""Seeded CAM-like programs for the scaling benchmarks: N motion blocks of one of three kinds.

    python benchmarks/programs.py KIND N [--seed S] > part.ngc   (KIND: arcs, poly, mixed, finish)

Kinds (work coordinates [mm], linuxcnc dialect, XY plane unless stated, 4 decimals, IJ
incremental as G91.1 is the default):

* ``arcs``: a tangent chain of G2/G3 arcs, R 2-20 mm, each sweeping 10-60 degrees, the side of
  every arc drawn at random -- so the curvature jumps at every junction, with S-bends (the side
  flips) and radius changes on the same side. F3000.
* ``poly``: a G1 polyline as CAM writes a smooth curve: segments 0.05-0.5 mm, each turning
  0.5-5 degrees, the same way for runs of 10-60 segments. F3000.
* ``mixed``: pocket-like contours of 4-30 blocks each: G0 over (near the last contour), G1
  plunge at F600, then G1 lines (1-15 mm) and G2/G3 arcs (R 2-20 mm, sweep 20-180 degrees,
  one in five helical, going down), each meeting the one before at a corner of 20-160 degrees,
  at F800-F4000; G0 retract to Z5.
* ``finish``: a 3-D finishing raster as CAM writes it for a ball-nose pass, in G18 with
  G64 P0.001 (the shape of the 1,905-line program of issue 12): rows along X of G1 moves
  0.2-0.5 mm long over a wavy surface z(x, y) (up to 3 mm deep, slopes up to about 25 degrees),
  alternating direction, 0.4 mm apart in Y, F1500.
* ``adaptive``: adaptive clearing as FreeCAD writes it (its grbl posts of pulley pockets): loops
  of G1 chords of 0.05-0.12 mm round circles of R 0.4-1 mm, sweeping 220-300 degrees, whose
  centres advance 0.2 mm a loop, each loop reached from the one before by two short G0 moves at
  the cutting depth (a stop at each end: the window cuts' case); F420.

N counts the motion blocks after the opening G0 (which is not counted). Every program stays
inside BOX, well within the bundled machine's travel (X +-300, Y +-200, Z +-75): each arc's
whole circle lies inside, and the polyline turns back towards the middle near an edge.
"""

from __future__ import annotations

import argparse
import math
import random
import sys

#: the half-extents of the box the programs stay in [mm]
BOX = (240.0, 140.0, 50.0)
KINDS = ("arcs", "poly", "mixed", "finish", "adaptive")
Z_SAFE = 5.0


def _num(v: float) -> str:
    """``v`` with 4 decimals, trailing zeros dropped ("-0" written as "0")."""
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def _r4(v: float) -> float:
    """``v`` as the program will say it (the next block starts from the written point)."""
    return float(_num(v))


class _Pen:
    """Position [mm] and heading [rad] in XY of the tool while writing, and the written blocks."""

    def __init__(self, rng: random.Random, x: float, y: float, z: float) -> None:
        self.rng = rng
        self.x, self.y, self.z = x, y, z
        self.heading = 0.0
        self.blocks: list[str] = []

    def line(self, x: float, y: float, feed: str = "") -> None:
        x, y = _r4(x), _r4(y)
        if (x, y) != (self.x, self.y):
            self.heading = math.atan2(y - self.y, x - self.x)
        self.blocks.append(f"G1 X{_num(x)} Y{_num(y)}{feed}")
        self.x, self.y = x, y

    def arc(self, radius: float, sweep: float, ccw: bool, dz: float = 0.0, feed: str = "") -> None:
        """An arc leaving along the current heading, turning left (ccw) or right."""
        side = 1.0 if ccw else -1.0
        cx = self.x - side * radius * math.sin(self.heading)
        cy = self.y + side * radius * math.cos(self.heading)
        end = math.atan2(self.y - cy, self.x - cx) + side * sweep
        x, y = _r4(cx + radius * math.cos(end)), _r4(cy + radius * math.sin(end))
        zword = ""
        if dz:
            self.z = _r4(self.z + dz)
            zword = f" Z{_num(self.z)}"
        g = "G3" if ccw else "G2"
        ij = f"I{_num(cx - self.x)} J{_num(cy - self.y)}"
        self.blocks.append(f"{g} X{_num(x)} Y{_num(y)}{zword} {ij}{feed}")
        self.x, self.y = x, y
        self.heading = end + side * math.pi / 2

    def circle_fits(self, radius: float, ccw: bool) -> bool:
        side = 1.0 if ccw else -1.0
        cx = self.x - side * radius * math.sin(self.heading)
        cy = self.y + side * radius * math.cos(self.heading)
        return abs(cx) + radius <= BOX[0] and abs(cy) + radius <= BOX[1]

    def fitting_arc(self, r_min: float, r_max: float) -> tuple[float, bool]:
        """A random radius and side whose full circle stays inside BOX (towards the middle when
        nothing random fits)."""
        for _ in range(50):
            radius, ccw = self.rng.uniform(r_min, r_max), self.rng.random() < 0.5
            if self.circle_fits(radius, ccw):
                return radius, ccw
        left = -math.sin(self.heading) * -self.x + math.cos(self.heading) * -self.y
        return r_min, left > 0


def tangent_arcs(n: int, rng: random.Random) -> tuple[str, list[str]]:
    pen = _Pen(rng, 20.0, 0.0, -2.0)
    pen.heading = math.pi / 2
    while len(pen.blocks) < n:
        radius, ccw = pen.fitting_arc(2.0, 20.0)
        pen.arc(
            radius, math.radians(rng.uniform(10.0, 60.0)), ccw, feed="" if pen.blocks else " F3000"
        )
    return "G0 X20 Y0 Z-2", pen.blocks


def polyline(n: int, rng: random.Random) -> tuple[str, list[str]]:
    pen = _Pen(rng, 0.0, 0.0, -2.0)
    turn_sign, run = 1.0, 0
    while len(pen.blocks) < n:
        if run <= 0:
            turn_sign, run = rng.choice((-1.0, 1.0)), rng.randint(10, 60)
        if abs(pen.x) > BOX[0] - 20 or abs(pen.y) > BOX[1] - 20:  # steer back to the middle
            off = math.remainder(math.atan2(-pen.y, -pen.x) - pen.heading, 2 * math.pi)
            if abs(off) > math.radians(10):
                turn_sign, run = math.copysign(1.0, off), max(run, 5)
        heading = pen.heading + turn_sign * math.radians(rng.uniform(0.5, 5.0))
        step = rng.uniform(0.05, 0.5)
        x, y = pen.x + step * math.cos(heading), pen.y + step * math.sin(heading)
        pen.line(x, y, "" if pen.blocks else " F3000")
        pen.heading = heading  # the intended heading, not the rounded chord's
        run -= 1
    return "G0 X0 Y0 Z-2", pen.blocks


def mixed(n: int, rng: random.Random) -> tuple[str, list[str]]:
    pen = _Pen(rng, 0.0, 0.0, Z_SAFE)
    while len(pen.blocks) < n:
        left = n - len(pen.blocks)
        if left < 4:  # too few for a contour: short moves along X at the current height
            for _ in range(left):
                x = max(-BOX[0], min(BOX[0], pen.x + rng.uniform(-5.0, 5.0)))
                pen.line(x, pen.y, " F1000")
            break
        x = _r4(max(-BOX[0] + 40, min(BOX[0] - 40, pen.x + rng.uniform(-30.0, 30.0))))
        y = _r4(max(-BOX[1] + 40, min(BOX[1] - 40, pen.y + rng.uniform(-30.0, 30.0))))
        pen.blocks.append(f"G0 X{_num(x)} Y{_num(y)}")
        pen.x, pen.y = x, y
        pen.z = _r4(-rng.uniform(1.0, 30.0))
        pen.blocks.append(f"G1 Z{_num(pen.z)} F600")
        pen.heading = rng.uniform(-math.pi, math.pi)
        feed = f" F{rng.choice((800, 1200, 1500, 2000, 3000, 4000))}"
        for _ in range(min(rng.randint(4, 30), left - 3)):
            pen.heading += math.radians(rng.uniform(20.0, 160.0)) * rng.choice((-1.0, 1.0))
            if rng.random() < 0.5:
                length = rng.uniform(1.0, 15.0)
                x = pen.x + length * math.cos(pen.heading)
                y = pen.y + length * math.sin(pen.heading)
                if abs(x) > BOX[0] or abs(y) > BOX[1]:  # head back to the middle instead
                    pen.heading = math.atan2(-pen.y, -pen.x)
                    x = pen.x + length * math.cos(pen.heading)
                    y = pen.y + length * math.sin(pen.heading)
                pen.line(x, y, feed)
            else:
                radius, ccw = pen.fitting_arc(2.0, 20.0)
                dz = -rng.uniform(0.2, 3.0) if rng.random() < 0.2 and pen.z > 3.5 - BOX[2] else 0.0
                pen.arc(radius, math.radians(rng.uniform(20.0, 180.0)), ccw, dz, feed)
            feed = ""
        pen.blocks.append(f"G0 Z{_num(Z_SAFE)}")
        pen.z = Z_SAFE
    return "G0 X0 Y0 Z5", pen.blocks


def finish(n: int, rng: random.Random) -> tuple[str, list[str]]:
    width = 40.0  # row length [mm]

    def z(x: float, y: float) -> float:
        return -1.5 + 1.5 * math.sin(x / 6.0) * math.cos(y / 9.0)

    blocks: list[str] = [f"G1 Z{_num(z(0.0, 0.0))} F1500"]
    x, y, forward = 0.0, 0.0, True
    while len(blocks) < n:
        step = rng.uniform(0.2, 0.5)
        nx = x + step if forward else x - step
        if not 0.0 <= nx <= width:  # end of the row: step over in Y, turn back
            y = _r4(y + 0.4)
            forward = not forward
            blocks.append(f"G1 Y{_num(y)} Z{_num(z(x, y))}")
            continue
        x = _r4(nx)
        blocks.append(f"G1 X{_num(x)} Z{_num(z(x, y))}")
    return "G18 G64 P0.001 G0 X0 Y0 Z5", blocks


def adaptive(n: int, rng: random.Random) -> tuple[str, list[str]]:
    step_over = 0.2  # the loops' centres advance this far [mm]
    cx = cy = 0.0
    heading = 0.0  # the direction the loops advance in [rad]
    blocks: list[str] = []
    x, y = 0.0, 0.0
    feed = " F420"  # on the first G1 (modal after it)
    while len(blocks) < n:
        if abs(cx) > BOX[0] - 20 or abs(cy) > BOX[1] - 20:  # steer back to the middle
            heading = math.atan2(-cy, -cx)
        heading += math.radians(rng.uniform(-3.0, 3.0))
        cx, cy = cx + step_over * math.cos(heading), cy + step_over * math.sin(heading)
        r = rng.uniform(0.4, 1.0)
        a = heading - math.radians(rng.uniform(100.0, 130.0))  # the loop starts behind, right
        stop = a + math.radians(rng.uniform(220.0, 300.0))
        sx, sy = _r4(cx + r * math.cos(a)), _r4(cy + r * math.sin(a))
        # the link: lift-free rapids to the loop's start, through a point just off the cut
        mx, my = _r4(0.5 * (x + sx) + 0.02), _r4(0.5 * (y + sy) + 0.02)
        blocks.append(f"G0 X{_num(mx)} Y{_num(my)}")
        blocks.append(f"G0 X{_num(sx)} Y{_num(sy)}")
        x, y = sx, sy
        while a < stop and len(blocks) < n:
            a += rng.uniform(0.05, 0.12) / r  # chords of 0.05-0.12 mm
            x, y = _r4(cx + r * math.cos(a)), _r4(cy + r * math.sin(a))
            blocks.append(f"G1 X{_num(x)} Y{_num(y)}{feed}")
            feed = ""
    return "G0 X0 Y0 Z-2", blocks[:n]


GENERATORS = {
    "arcs": tangent_arcs,
    "poly": polyline,
    "mixed": mixed,
    "finish": finish,
    "adaptive": adaptive,
}


def program(kind: str, n: int, seed: int = 1) -> str:
    """The program text: ``n`` motion blocks of ``kind`` (see the module docstring), seeded."""
    rng = random.Random(f"{seed}:{kind}:{n}")
    head, blocks = GENERATORS[kind](n, rng)
    assert len(blocks) == n, (kind, n, len(blocks))
    title = f"(benchmark program: {kind}, {n} blocks, seed {seed})"
    return "\n".join([title, "G21 G17 G90 G94", head, *blocks, "M2", ""])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=KINDS)
    ap.add_argument("blocks", type=int)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    sys.stdout.write(program(args.kind, args.blocks, args.seed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
