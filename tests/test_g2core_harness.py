"""The g2core dialect against g2core's own arc and parser code: tests/data/g2core/
arc_harness_output.txt holds what g2core's gcode_parser.cpp and plan_arc.cpp (built for the
host; tests/data/g2core/README.md) did with each line of 33 small programs, and every line's
reading here must agree with it: refused where g2core answered with an error status, and the
tool where g2core's planner left it (a straight move's end, an arc's last segment's end), where
the dialect follows the firmware (the sections left out, and why, are in SKIPPED)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.moves import Vec3

DATA = Path(__file__).parent / "data" / "g2core" / "arc_harness_output.txt"

#: sections where the dialect departs from the firmware on purpose, with the reason
SKIPPED = {
    "D1 G2 end==start": "seed 000: an explicit end equal to the start moves nothing",
    "D2 G3 end==start": "seed 000 (as D1)",
    "D2b G3 helix same XY": "seed 000 (as D1)",
    "D3 G3 end==start P1": "seed 000 (as D1)",
    "D1b G2 end==start P1": "seed 000 (as D1)",
    "D4 P adds turns": "seed 000: P1 is the programmed arc, P must be a whole number >= 1",
    "D8 G90.1 with G92": "the firmware's machine-position centres are not modelled",
    "near-equal CW": "seed 000's end == start rule (an end 1e-6 mm away)",
    "D17 G93 without F (real cm_set_feed_rate, cm_straight_feed)": (
        "the first G93 move without F is refused here (g2core reads mm/min as minutes)"
    ),
}

#: single lines where the dialect departs from the firmware on purpose (the section's last)
SKIPPED_LINES = {
    "G2 X20 Y0 I5 K3": "seed 000: an illegal offset (K on a G17 arc) is an error",
}

#: g2core's STAT_COMMAND_REJECTED_BY_ALARM: the line after an alarm, which gantry never reaches
_REJECTED_BY_ALARM = 204
#: statuses that refuse nothing: STAT_NOOP (a block deleted by ``/``), STAT_COMPLETE
_NOT_REFUSED = frozenset((0, 3, 4))
#: lines g2core runs, but answers with an error status nothing on the line overwrote
REPORTED_BUT_RUN = {
    "G94": "the F 0 given to a block started in G93: cm_set_feed_rate's status, feed set to 0",
}
#: where the planner left the tool: a straight move's end, an arc's last segment's end
_PLANNED = re.compile(r"(?:line to|last) \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)")


def _sections() -> list[tuple[str, list[tuple[str, bool, Vec3]]]]:
    """(title, [(line, refused, where the planner left the tool after it)]) per section of the
    harness output (the model position line closes a line's answer); lines g2core rejected only
    because of an earlier alarm are left out."""
    sections: list[tuple[str, list[tuple[str, bool, Vec3]]]] = []
    line, status, tool = "", 0, (0.0, 0.0, 0.0)
    for text in DATA.read_text().splitlines():
        if text.startswith("######## "):
            sections.append((text[9:], []))
            tool = (0.0, 0.0, 0.0)
        elif text.startswith("["):
            line, status = text[1:-1], 0
        elif text.strip().startswith("STATUS "):
            status = int(text.split()[1])
        elif (found := _PLANNED.search(text)) is not None:
            x, y, z = (float(v) for v in found.groups())
            tool = (x, y, z)
        elif "model position" in text and status != _REJECTED_BY_ALARM:
            refused = status not in _NOT_REFUSED and line not in REPORTED_BUT_RUN
            sections[-1][1].append((line, refused, tool))
    return sections


SECTIONS = [s for s in _sections() if s[0] not in SKIPPED]


def test_the_data_file_holds_every_section() -> None:
    assert len(_sections()) == 33 and len(SECTIONS) == 33 - len(SKIPPED)


@pytest.mark.parametrize(("title", "lines"), SECTIONS, ids=[s[0] for s in SECTIONS])
def test_g2core_dialect_reads_each_line_as_g2core(
    title: str, lines: list[tuple[str, bool, Vec3]]
) -> None:
    """Each line refused where g2core refused it, and the tool where g2core's planner left it
    (gantry reads on past a refused line, as g2core does: ``errors``), to g2core's float
    rounding, which grows with the coordinates (1000 mm: 0.0024 mm off after 248 segments)."""
    text = "".join(f"{line}\n" for line, _, _ in lines)
    errors: list[GcodeError] = []
    moves = list(interpret(text, "g2core", errors=errors))
    refused = {e.line for e in errors}
    where: Vec3 = (0.0, 0.0, 0.0)
    for k, (line, g2core_refused, position) in enumerate(lines, start=1):
        ends = [m.end for m in moves if m.line == k]
        where = ends[-1] if ends else where
        if line in SKIPPED_LINES:
            continue
        assert (k in refused) == g2core_refused, (title, line, errors)
        tolerance = 1e-4 + 5e-6 * max(abs(c) for c in position)
        assert where == pytest.approx(position, abs=tolerance), (title, line)
