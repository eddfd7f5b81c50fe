"""Inputs for the contract fuzzing (tests/test_fuzz_contract.py, scripts/fuzz_contract.py):
hypothesis strategies for valid programs, hostile programs, hostile machine files and hostile
option values, and the contract every ``gantry`` call must keep whatever it is given:

exit 0, 1 or 2 (3 is a bug); on 2, a ``FILE:LINE: error: MESSAGE`` or ``FILE: error: MESSAGE``
line on stderr; never a traceback; within a time bound.

Calls run in-process (``gantry_sim.sim.cli.main``), which is what the console script runs.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import time
from dataclasses import dataclass

from hypothesis import strategies as st

from gantry_sim.sim.cli import main

TRACEBACK = "Traceback (most recent call last)"
ERROR_LINE = re.compile(r"^[^\n]+?(:\d+)?: error: \S")


@dataclass(frozen=True)
class Outcome:
    argv: tuple[str, ...]
    status: int
    stderr: str
    seconds: float

    def violation(self, limit_s: float) -> str | None:
        """What breaks the contract, or None."""
        if self.status not in (0, 1, 2):
            return f"exit {self.status}"
        if TRACEBACK in self.stderr:
            return "traceback"
        if self.status == 2 and not any(ERROR_LINE.match(x) for x in self.stderr.splitlines()):
            return "exit 2 without a FILE[:LINE]: error: line"
        if self.seconds > limit_s:
            return f"took {self.seconds:.1f} s > {limit_s:g} s"
        return None


def call(argv: list[str]) -> Outcome:
    """Run ``gantry argv`` in-process and record what it did."""
    out, err = io.StringIO(), io.StringIO()
    t0 = time.monotonic()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse's usage errors
            status = exc.code if isinstance(exc.code, int) else 2
    return Outcome(tuple(argv), status, err.getvalue(), time.monotonic() - t0)


# --- valid programs: short moves and arcs near the origin, everything well inside the travel ---

_coord = st.floats(-20, 20, allow_nan=False).map(lambda v: round(v, 3))
_feed = st.sampled_from([300, 600, 1200, 2400, 3000, 4500, 6000])


@st.composite
def _arc(draw, at: tuple[float, float]) -> tuple[str, tuple[float, float]]:
    """A G2/G3 on a circle of radius 6..20 mm through ``at`` (end point computed on it)."""
    r = draw(st.floats(6, 20))
    phi0 = draw(st.floats(0, 2 * math.pi))
    sweep = draw(st.floats(math.radians(20), math.radians(330)))
    ccw = draw(st.booleans())
    cx, cy = at[0] - r * math.cos(phi0), at[1] - r * math.sin(phi0)
    phi1 = phi0 + (sweep if ccw else -sweep)
    end = (round(cx + r * math.cos(phi1), 4), round(cy + r * math.sin(phi1), 4))
    i, j = round(cx - at[0], 4), round(cy - at[1], 4)
    code = "G3" if ccw else "G2"
    return f"{code} X{end[0]} Y{end[1]} I{i} J{j} F{draw(_feed)}", end


@st.composite
def valid_programs(draw, max_moves: int = 4) -> str:
    lines = ["G21 G90 G17"]
    at = (0.0, 0.0)
    for _ in range(draw(st.integers(1, max_moves))):
        kind = draw(st.sampled_from(["G0", "G1", "arc"]))
        if kind == "arc" and math.hypot(*at) < 60:
            line, at = draw(_arc(at))
        else:  # (an arc drawn too far out for its radius is a G1: "arc" is no code)
            kind = "G1" if kind == "arc" else kind
            at = (draw(_coord), draw(_coord))
            feed = f" F{draw(_feed)}" if kind == "G1" else ""
            line = f"{kind} X{at[0]} Y{at[1]}{feed}"
        lines.append(line)
    lines.append("M2")
    return "\n".join(lines) + "\n"


# --- hostile programs -----------------------------------------------------------------------

_NUMBERS = st.sampled_from(
    ["0", "-0", "1", "-1", "0.0001", "1e3", "1e308", "nan", "inf", "99999999", "-1000000",
     "0.000000001", "3.14159", "+5", "1.2.3", ".", "-", "360", "1000000000000000000000"]
)  # fmt: skip
_WORD = st.builds(
    lambda letter, num: f"{letter}{num}",
    st.sampled_from(list("GMXYZIJKRFSTPQNLOABCDEHUVW")),
    _NUMBERS,
)
_TOKENS = st.one_of(
    _WORD,
    st.sampled_from(
        ["G0", "G1", "G2", "G3", "G17", "G18", "G19", "G20", "G21", "G90", "G91", "G93", "G94",
         "M2", "M30", "%", "(comment", "(ok)", ";x", "#1=5", "#1", "[1+2]", "[#1*2]", "sin[30]",
         "o100 sub", "o100 endsub", "o100 call", "\t", " ", "/", "*", "\x00", "\x7f", "é", "\r",
         "G2 X1 Y0 I0.5", "G3 I0 J0", "G1 X1e3", "F0", "F-1"]
    ),
)  # fmt: skip


@st.composite
def hostile_programs(draw) -> bytes:
    lines = []
    for _ in range(draw(st.integers(0, 6))):
        toks = draw(st.lists(_TOKENS, max_size=6))
        lines.append(" ".join(toks))
    text = "\n".join(lines)
    if draw(st.booleans()):
        text += "\nM2\n"
    data = text.encode("utf-8")
    if draw(st.integers(0, 9)) == 0:
        data += draw(st.binary(max_size=16))
    return data


# --- hostile machine files ------------------------------------------------------------------

_SECTIONS = {
    "limits": ["max_velocity_mm_per_s", "max_acceleration_mm_per_s2", "max_jerk_mm_per_s3"],
    "travel": ["min_mm", "max_mm"],
    "segmentation": ["method", "chord_tolerance_mm", "segment_length_mm"],
    "servo": ["period_s", "kp_N_per_mm", "kd_N_s_per_mm", "ff_velocity", "ff_acceleration",
              "ff_friction", "ff_gravity", "max_following_error_mm"],
    "sim": ["model", "physics_timestep_s", "work_origin_joint_mm"],
    "bogus": ["x"],
}  # fmt: skip
_SCALARS = st.sampled_from(
    ["0", "-1", "1", "0.5", "2", "1e-300", "1e-20", "1e-9", "1e-6", "1e308", "nan", "inf",
     "-inf", "1" + "0" * 400, "true", '"text"', '"chord"', '"fixed"', '"gantry.xml"',
     '"missing.xml"', "0.001", "0.0005", "1000", "3000", "100000", "1e6", "[]", "{}"]
)  # fmt: skip
_VALUES = st.one_of(
    _SCALARS,
    st.lists(_SCALARS, min_size=0, max_size=4).map(lambda v: "[" + ", ".join(v) + "]"),
    st.lists(_SCALARS, min_size=3, max_size=3).map(lambda v: "[" + ", ".join(v) + "]"),
)


@st.composite
def hostile_machine_files(draw) -> str:
    parts = []
    for section in draw(st.lists(st.sampled_from(sorted(_SECTIONS)), max_size=3, unique=True)):
        parts.append(f"[{section}]")
        for key in draw(st.lists(st.sampled_from(_SECTIONS[section]), max_size=3, unique=True)):
            parts.append(f"{key} = {draw(_VALUES)}")
    if draw(st.integers(0, 9)) == 0:
        parts.append(draw(st.sampled_from(["[limits", "x = = 1", "\x00", "[servo]\n[servo]"])))
    return "\n".join(parts) + "\n"


# --- hostile option values ------------------------------------------------------------------

_OPTION_VALUES = st.sampled_from(
    ["0", "-1", "1", "5", "50", "1e-300", "1e-20", "1e308", "nan", "inf", "-inf", "", ",",
     "5,,10", "abc", "1" + "0" * 400, "0.5", "100", "3000", "24000", "1e9", "-0", "5,nan",
     "0x10", "2", "3"]
)  # fmt: skip
#: per command, options that take a value (the program/--out/--machine are added by the caller)
OPTIONS = {
    "parse": ["--dialect"],
    "plan": ["--dialect", "--max-sim-s"],
    "run": ["--dialect", "--max-error-um", "--max-sim-s", "--max-physics-steps"],
    "ballbar": ["--plane", "--radius", "--feed", "--max-sim-s"],
    "tune": ["--plane", "--radii", "--tolerance-um", "--feed-resolution", "--max-sim-s"],
    "sweep": ["--feed-override", "--max-accel", "--max-jerk", "--workers", "--max-sim-s"],
}


@st.composite
def hostile_options(draw, command: str) -> list[str]:
    argv: list[str] = []
    for opt in draw(st.lists(st.sampled_from(OPTIONS[command]), max_size=3, unique=True)):
        value = draw(st.one_of(_OPTION_VALUES, st.sampled_from(["XY", "YZ", "XQ", "marlin"])))
        argv += [opt, value] if not value.startswith("-") else [f"{opt}={value}"]
    return argv
