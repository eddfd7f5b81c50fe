"""The interpreter's plain step (controller/gcode/plain_block.py) gives the general step's moves,
events, state and errors: random programs of plain blocks among the codes that change what a
plain block does (units, distance and feed modes, offsets, path control, cutter compensation,
canned cycles, arcs, parameters), each interpreted twice in every dialect, with and without it."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.dialects import DIALECTS, get_dialect
from gantry_sim.controller.gcode.interpreter import Interpreter, interpret_events
from gantry_sim.controller.gcode.plain_block import plain_letters, plain_motion
from gantry_sim.controller.gcode.tools import Tool

TOOLS = {1: Tool(1, 10.0, 2.0), 2: Tool(2, 25.0, 6.0)}

_coord = st.sampled_from(["0", "1", "-2.5", "10", "0.001", "-0", "+3", "12.3456", ".5", "100000"])
_feed = st.sampled_from(["100", "1500", "0", "-5", "0.5", "3000"])


@st.composite
def _plain(draw: st.DrawFn) -> str:
    """A block of G0 / G1 / none with X, Y, Z, F and E words (now and then one that is not
    plain)."""
    words = []
    g = draw(st.sampled_from(["", "G0", "G1", "G00", "G01", "G1.0", "G0 G1", "G-0"]))
    if g:
        words.append(g)
    for letter in draw(st.lists(st.sampled_from("XYZXFE"), max_size=4)):
        words.append(letter + draw(_feed if letter == "F" else _coord))
    words = draw(st.permutations(words))
    return " ".join(words)


# codes that change what a plain block does, or are refused in some dialects
_OTHER = [
    "G90",
    "G91",
    "G20",
    "G21",
    "G93",
    "G94",
    "G95 S1000",
    "M3 S1000",
    "M5",
    "S2000",
    "G92 X1 Y-2",
    "G92.1",
    "G55",
    "G54",
    "G10 L2 P1 X3",
    "G10 L2 P2 Y1",
    "G61",
    "G61.1",
    "G64 P0.01",
    "G64",
    "G17",
    "G18",
    "G80",
    "G81 X1 Y1 Z-1 R2 F100",
    "G2 X5 Y5 I2.5 J2.5 F200",
    "G3 X0 Y0 R5",
    "T1 M6",
    "T2 M6 G43 H2",
    "G49",
    "G41 D1",
    "G42 D2",
    "G40",
    "G4 P0.1",
    "M0",
    "M8",
    "M9",
    "G28",
    "G53 G0 Z5",
    "#1=2.5",
    "G1 X#1 Y[#1*2]",
    "G1 X[#5420+1]",
    "G1 X#<_feed>",
    "M220 S50",
    "G1 E5 X1",
    "G1 X1 F100 E2",
    "G92 E0",
    "G92 E2.5",
    "M82",
    "M83",
    "G1 E-1 F2400",
    "$J=G91 X1 F100",
    "N10 G1 X2",
    "G1 X1 (comment) Y2",
    "X1 X2",
    "G1 A0 X1",
]


@st.composite
def _program(draw: st.DrawFn) -> str:
    lines = ["G21 G90 G17 G94", "G0 X0 Y0 Z0"]
    for _ in range(draw(st.integers(2, 24))):
        lines.append(draw(st.one_of(_plain(), _plain(), st.sampled_from(_OTHER))))
    lines.append("M2")
    return "\n".join(lines) + "\n"


def _run(text: str, dialect: str) -> tuple[list, tuple[str, int | None] | None]:
    """The items the program made, and its error (message, line) or None."""
    items: list = []
    try:
        for item in interpret_events(text, dialect, "t.ngc", tools=dict(TOOLS)):
            items.append(item)
    except GcodeError as exc:
        return items, (str(exc), exc.line)
    return items, None


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(text=_program())
def test_the_plain_step_is_the_general_steps(dialect, text):
    fast = _run(text, dialect)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(Interpreter, "_plain_step", lambda self, block: None)
        general = _run(text, dialect)
    assert fast == general


def test_plain_blocks_take_the_plain_step(monkeypatch):
    """The plain step runs the plain blocks of the dialects it serves (and only where their
    state lets it: not under cutter compensation)."""
    taken = []
    real = Interpreter._plain_step

    def watched(self, block):
        got = real(self, block)
        taken.append((block.line, got is not None))
        return got

    monkeypatch.setattr(Interpreter, "_plain_step", watched)
    text = "G21 G90\nG0 X1 Y2\nF100\nG1 X2\nT1 M6\nG41 D1\nG1 X5\nG40\nX6 Y1\nM2\n"
    list(interpret_events(text, "linuxcnc", "t.ngc", tools=dict(TOOLS)))
    # G21 G90, T1 M6, G41, G40 and M2 are not plain; G1 X5 runs under compensation
    assert [line for line, plain in taken if plain] == [2, 3, 4, 9]
    assert [line for line, _ in taken] == list(range(1, 11))
    taken.clear()  # a printer's lines: E words, and a G92 E (not plain)
    text = "G21\nG1 X1 Y2 E0.5 F1800\nX2 E1\nG92 E0\nG0 X5 F6000\n"
    moves = list(interpret_events(text, "marlin", "t.gcode"))
    assert [line for line, plain in taken if plain] == [2, 3, 5]
    assert [m.extrudes for m in moves] == [True, True, False]
    letters = {n: "".join(sorted(plain_letters(get_dialect(n)))) for n in DIALECTS}
    assert letters == {
        "g2core": "FXYZ",
        "grbl": "FXYZ",
        "laserdyne": "FXYZ",
        "linuxcnc": "FXYZ",
        "marlin": "EFXYZ",
    }


@pytest.mark.parametrize(
    ("words", "read"),
    [
        ((("G", ("num", 1.0)), ("X", ("neg", ("num", 2.0)))), (10, {"X": -2.0})),
        ((("X", ("num", 1.0)), ("F", ("num", 5.0))), (None, {"X": 1.0, "F": 5.0})),
        ((("G", ("num", 0.0)),), (0, {})),
        ((("G", ("num", 2.0)), ("X", ("num", 1.0))), None),  # an arc
        ((("X", ("num", 1.0)), ("X", ("num", 2.0))), None),  # X twice
        ((("G", ("num", 0.0)), ("G", ("num", 1.0))), None),  # two G
        ((("X", ("par", ("num", 1.0))),), None),  # a parameter
        ((("S", ("num", 100.0)),), None),  # another letter
        ((("E", ("num", 1.0)),), None),  # E, in a dialect with no extruder
        ((("X", ("num", 2e300)),), None),  # beyond MAX_MAGNITUDE: the general step says why
    ],
)
def test_plain_motion_reads_only_plain_blocks(words, read):
    assert plain_motion(words, frozenset("XYZF")) == read
