"""Any text gives moves or a GcodeError with a line, never another exception (seeded fuzzing)."""

from __future__ import annotations

import random

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.controller.gcode.dialects import DIALECTS
from gantry_sim.controller.gcode.interpreter import parse_program

ALPHABET = "GXYZIJKRPFMNST0123456789.-+ #[]=()/;%EQHOabc*\t"
VALUES = (0, 1, 2, 3, 17, 18, 19, 20, 21, 90, 91, 90.1, 91.1, -1, 0.5, 0.0001, 1e6, 5)


def _only_gcode_errors(text: str, dialect: str) -> None:
    try:
        parse_program(text, dialect=dialect)
    except GcodeError as exc:
        assert exc.line is not None and exc.message


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_random_characters(dialect: str) -> None:
    rng = random.Random(20261122)
    for _ in range(1500):
        line = "".join(rng.choice(ALPHABET) for _ in range(rng.randint(1, 40)))
        _only_gcode_errors(f"F10 G1\nG0 X1\n{line}\nM2\n", dialect)


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_random_words(dialect: str) -> None:
    rng = random.Random(7)
    for _ in range(1500):
        count = rng.randint(1, 6)
        words = [f"{rng.choice('GXYZIJKRPF')}{rng.choice(VALUES)}" for _ in range(count)]
        _only_gcode_errors("F10\n" + " ".join(words) + "\nM2\n", dialect)
