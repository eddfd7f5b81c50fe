"""The grbl dialect against grbl 1.1h itself: tests/data/grbl/corpus.jsonl holds programs and
what grbl's own gcode.c did with them (built for the host; tests/data/grbl/README.md), made
by scripts/regen_grbl_expected.py. For each program, gantry-sim must refuse the line grbl first
answered with ``error:N``, with the same N, and make the same motions before it: kind, end
point, feed, and for arcs direction, plane, centre, radius and swept angle. grbl computes in
float32, so lengths agree to 1e-4 mm + 1e-5 relative, and the swept angle to 1e-4 rad or
1e-3 mm of arc."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.moves import Arc, Linear, Move, Rapid

CORPUS = Path(__file__).parent / "data" / "grbl" / "corpus.jsonl"
ROWS = [json.loads(line) for line in CORPUS.read_text().splitlines()]
#: the corpus may grow, not shrink unnoticed
MIN_PROGRAMS = 920


def _close(a: float, b: float, abs_tol: float = 1e-4, rel: float = 1e-5) -> bool:
    return abs(a - b) <= abs_tol + rel * max(abs(a), abs(b))


def _vclose(u, v) -> bool:
    return all(_close(a, b) for a, b in zip(u, v, strict=True))


def _gantry(text: str, lines: set[int]) -> tuple[list[Move], tuple[int, int | None] | None]:
    """The dialect's motions up to its first refused line, and that line and grbl code;
    ``lines``: those on which grbl moved."""
    moves: list[Move] = []
    try:
        for m in interpret(text, dialect="grbl", file="p.gcode"):
            # grbl moves nothing on a G0/G1 line without axis words; rs274 (and here) a move
            # of length 0
            if not (isinstance(m, Rapid | Linear) and m.start == m.end and m.line not in lines):
                moves.append(m)
    except GcodeError as exc:
        code = re.search(r"\(grbl error (\d+)\)$", exc.message)
        return moves, (exc.line or 0, int(code.group(1)) if code else None)
    return moves, None


def _differences(want: dict, got: Move) -> list[str]:
    kind = {Rapid: "rapid", Linear: "linear", Arc: "arc"}.get(type(got), type(got).__name__)
    if (want["line"], want["kind"]) != (got.line, kind):
        return [f"line {want['line']} {want['kind']} against line {got.line} {kind}"]
    out = []
    if not _vclose(want["end"], got.end):
        out.append(f"end {want['end']} against {got.end}")
    if "feed" in want and not _close(want["feed"], got.feed_mm_per_min, 1e-3):
        out.append(f"feed {want['feed']} against {got.feed_mm_per_min}")
    if isinstance(got, Arc):
        if (want["direction"], want["plane"]) != (got.direction, got.plane):
            out.append(f"{want['direction']} {want['plane']} against {got.direction} {got.plane}")
        if not _vclose(want["center"], got.center) or not _close(want["radius"], got.radius):
            out.append(f"centre {want['center']} R{want['radius']} against {got.center} "
                       f"R{got.radius}")  # fmt: skip
        gap = abs(want["angle"] - got.angle)
        if gap > 1e-4 and gap * got.radius > 1e-3:
            out.append(f"swept angle {want['angle']} against {got.angle} rad")
    return out


def test_the_corpus_is_whole() -> None:
    assert len(ROWS) >= MIN_PROGRAMS
    assert len({r["name"] for r in ROWS}) == len(ROWS)
    refused = sum(r["first_error"] is not None for r in ROWS)
    arcs = sum(any(m["kind"] == "arc" for m in r["motions"]) for r in ROWS)
    assert refused >= 100 and arcs >= 100  # both halves of the dialect are exercised


@pytest.mark.parametrize("row", ROWS, ids=[r["name"] for r in ROWS])
def test_the_grbl_dialect_reads_each_program_as_grbl_does(row: dict) -> None:
    moves, refused = _gantry(row["program"], {m["line"] for m in row["motions"]})
    want_error = tuple(row["first_error"]) if row["first_error"] else None
    assert refused == want_error, (refused, want_error)
    want = row["motions"]
    assert len(moves) == len(want), [(m.line, type(m).__name__) for m in moves]
    for w, got in zip(want, moves, strict=True):
        assert not _differences(w, got), _differences(w, got)
    assert all(math.isfinite(x) for m in moves for x in m.end)
