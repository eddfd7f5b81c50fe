"""Cutter radius compensation G41/G42 (tool table diameter), G41.1/G42.1 (D diameter), G40.

The tool-centre path LinuxCNC 2.9's rs274 makes (interp_convert.cc convert_straight_comp1/2,
convert_arc_comp1/2 and interp_queue.cc, read for reference; checked against ``rs274 -g`` by the
corpus, gen_comp_* and comp_* programs), in the XY plane:

- The entry move (the first G0/G1/G2/G3 after G41/G42) ends one tool radius to the side of its
  programmed end, perpendicular to the move (a line) or along the arc's radius (an arc); it must
  be longer than the tool radius.
- Each later move is offset by the radius. Before it, the previous move is finished: at an
  outside (convex) corner a G1 adds an arc about the programmed corner (a G0 a straight
  traverse), at an inside (concave) corner the previous move is shortened to where the tool
  touches both (a move reversed by that, or an arc extended past its sweep, is a gouge: error).
- A move is held until the next one decides its end (rs274's canon queue), so moves appear one
  block late, and each carries the line of the block that released it, as ``rs274 -g`` prints
  it; G40, M0/M1/M2/M30/M60 finish the held move at the tool's current point. The move after
  G40 must be a line (it leaves from the offset point).

Everything is in the program frame [mm]; moves are placed in the work frame when released.
XZ (lathe) compensation and R-format entry arcs are refused with a message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.frames import NO_OFFSETS, Frame, to_work
from gantry_sim.controller.moves import Arc, Dwell, Linear, Move, Rapid, Vec3

_SMALL = 0.05  # rs274 TOLERANCE_CONCAVE_CORNER [rad]
_EQUAL = 1e-6  # rs274 TOLERANCE_EQUAL
_GOUGE = "cannot be reached by the tool without gouging"


@dataclass
class _Held:
    """One queued move: kind "rapid" / "linear" / "arc", program frame [mm]."""

    kind: str
    line: int
    end: list[float]
    feed: float
    frame: Frame
    direction: tuple[float, float] = (0.0, 0.0)  # lines: the programmed direction
    center: tuple[float, float] = (0.0, 0.0)  # arcs
    turn: int = 0  # arcs: signed turns, > 0 counter-clockwise
    sweep: float = 0.0  # arcs: rs274's original_turns (0: the endpoint may move freely)


def find_turn(x1: float, y1: float, cx: float, cy: float, turn: int, x2: float, y2: float) -> float:
    """Signed swept angle [rad] from (x1, y1) to (x2, y2) about (cx, cy) (rs274 find_turn)."""
    if turn == 0:
        return 0.0
    a = math.atan2(y1 - cy, x1 - cx)
    b = math.atan2(y2 - cy, x2 - cx)
    if turn > 0:
        if b <= a:
            b += 2 * math.pi
        return b - a + (turn - 1) * 2 * math.pi
    if a <= b:
        a += 2 * math.pi
    return b - a + (turn + 1) * 2 * math.pi


@dataclass
class CutterComp:
    """The compensation state and its queue (one per interpreter)."""

    side: str | None = None  # "left" / "right" / None (G40)
    radius: float = 0.0  # [mm], >= 0
    first: bool = True
    arc_not_allowed: bool = False
    current: Vec3 = (0.0, 0.0, 0.0)  # the tool centre, program frame [mm]
    programmed: Vec3 = (0.0, 0.0, 0.0)
    queue: list[_Held] = field(default_factory=list)
    endpoint: tuple[float, float] | None = None  # where the held move starts (rs274 endpoint)
    released_end: Vec3 = (0.0, 0.0, 0.0)  # work frame: where the last released move ended
    inch: bool = False
    resync: bool = False  # G40 left the tool off the programmed point; M6 re-reads it
    line: int = 0  # the block being run: a released move carries it, as rs274 -g prints

    @property
    def holding(self) -> bool:
        """A move is held back (compensation on, past its entry move)."""
        return bool(self.queue)

    def hold_dwell(self, line: int, seconds: float) -> None:
        """G4 while a move is held: the dwell follows it (released with it)."""
        self.queue.append(_Held("dwell", line, [0.0, 0.0, 0.0], seconds, NO_OFFSETS))

    @property
    def active(self) -> bool:
        return self.side is not None and self.radius > 0.0

    def turn_on(self, side: str, diameter_mm: float, plane: str) -> None:
        if plane != "XY":
            raise GcodeError(
                f"{plane} (G18) cutter radius compensation is not supported: gantry-sim "
                "compensates in the XY plane (G17); XZ compensation is a lathe's"
            )
        if self.side is not None:
            raise GcodeError("cannot turn cutter radius compensation on when it is already on")
        radius = diameter_mm / 2.0
        if radius < 0.0:  # rs274: a negative diameter swaps the side
            radius, side = -radius, "right" if side == "left" else "left"
        self.side, self.radius = side, radius

    def turn_off(self) -> list[Move | Dwell]:
        out: list[Move | Dwell] = []
        if self.active and not self.first:
            out = self.flush_at(self.current[0], self.current[1])
            self.arc_not_allowed = True
        self.side, self.first = None, True
        return out

    # -- the queue ---------------------------------------------------------------------------

    def _hold(self, item: _Held) -> None:
        self.queue.append(item)

    def release(self) -> list[Move | Dwell]:
        """rs274 dequeue_canons: every held move, in order, as moves in the work frame."""
        out: list[Move | Dwell] = []
        for q in self.queue:
            start = self.released_end
            if q.kind == "dwell":  # feed holds the seconds
                out.append(Dwell(self.line, start, q.feed))
                continue
            end = to_work((q.end[0], q.end[1], q.end[2]), q.frame)
            if q.kind == "rapid":
                out.append(Rapid(self.line, start, end))
            elif q.kind == "linear":
                out.append(Linear(self.line, start, end, q.feed))
            else:
                out.append(self._arc(q, start, end))
            self.released_end = end
        self.queue.clear()
        self.endpoint = None
        return out

    def _arc(self, q: _Held, start: Vec3, end: Vec3) -> Arc:
        f = q.frame
        c = to_work((q.center[0], q.center[1], start[2]), f)
        c = (c[0], c[1], start[2])
        sweep = find_turn(start[0], start[1], c[0], c[1], q.turn, end[0], end[1])
        return Arc(
            self.line,
            start,
            end,
            q.feed,
            "XY",
            "ccw" if q.turn > 0 else "cw",
            c,
            math.hypot(start[0] - c[0], start[1] - c[1]),
            abs(q.turn),
            abs(sweep),
        )

    def flush_at(self, x: float, y: float) -> list[Move | Dwell]:
        """rs274 move_endpoint_and_flush: end every held move at (x, y), then release them."""
        unit = 25.4 if self.inch else 1.0
        for q in self.queue:
            if q.kind == "dwell":
                continue
            if q.kind == "arc":
                cx, cy = q.center
                r1 = math.hypot(q.end[0] - cx, q.end[1] - cy)
                r2 = math.hypot(x - cx, y - cy)
                if self.endpoint is not None:
                    ex, ey = self.endpoint
                    l2 = find_turn(ex, ey, cx, cy, q.turn, x, y)
                    limit = abs(q.sweep) + (0.001 if self.inch else 0.0254)
                    if q.sweep != 0.0 and abs(l2) > limit:
                        raise GcodeError(f"arc move in concave corner {_GOUGE}")
                if abs(r1 - r2) > 0.01 * unit:
                    raise GcodeError("cutter compensation made an arc with mismatched radii")
            elif self.endpoint is not None:
                dx, dy = q.direction
                # a move cut back to exactly its start (a corner of exactly the tool radius) is
                # accepted by rs274; 1e-9 mm absorbs the float noise of that boundary
                dot = dx * (x - self.endpoint[0]) + dy * (y - self.endpoint[1])
                if dot < -1e-9 * math.hypot(dx, dy):
                    what = "traverse" if q.kind == "rapid" else "feed"
                    raise GcodeError(f"straight {what} in concave corner {_GOUGE}")
            q.end[0], q.end[1] = x, y
        out = self.release()
        self.endpoint = (x, y)
        return out
