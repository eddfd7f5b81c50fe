"""The regular expressions that read program lines and machine files fail in linear time, and
read what their quadratic forms read.

Each pattern below had two quantifiers that could share a run of characters (``\\s*`` twice in a
row, ``\\d+\\.?\\d*``, ``(.*?)\\s*$``): a line it refuses made the engine try every split of the
run, quadratic in its length (200,000 spaces: minutes; a hostile file is one long line). Their
quantifiers are possessive now. The old patterns are kept here as the reference: on short lines
(where they are fast) both read the same lines the same way.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.gcode import fanuc_subs
from gantry_sim.controller.machine_import import grbl_settings, ini_reader, work_files
from gantry_sim.controller.machine_import.grbl_settings import parse_settings
from gantry_sim.controller.machine_import.ini_reader import parse_ini
from gantry_sim.controller.machine_import.work_files import read_parameter_file

#: the patterns before 2026-11-29
OLD_BARE_O = re.compile(r"^\s*/?\s*(?:[nN]\s*\d+\s*)?[oO]\s*(\d+)\s*(?:\(.*\)|;.*)?\s*$")
OLD_PARAM_LINE = re.compile(r"^\s*(\d+)\s+([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*$")
OLD_KEY = re.compile(r"^([A-Za-z0-9_]+)\s*=\s*(.*?)\s*$")
#: the setting line with backtracking quantifiers (its number of at most 9 digits and its
#: description captured since 2026-12-02: grbl 0.8's numbering is told by the description)
OLD_SETTING = re.compile(r"^\$(\d{1,9})\s*=\s*([^\s(]+)\s*(?:\((.*)\))?\s*$")

LONG = 200_000  # characters in a run: the quadratic forms took minutes on such a line


def _groups(m: re.Match[str] | None) -> tuple[str | None, ...] | None:
    return None if m is None else m.groups()


@given(st.text(alphabet=" \t/nNoO0123()x;.", max_size=24))
@settings(max_examples=600, deadline=None)
def test_bare_o_lines_read_as_before(line: str) -> None:
    assert _groups(fanuc_subs._BARE_O.match(line)) == _groups(OLD_BARE_O.match(line))


@given(st.text(alphabet=" \t0123456789.eE+-x", max_size=24))
@settings(max_examples=600, deadline=None)
def test_parameter_lines_read_as_before(line: str) -> None:
    assert _groups(work_files._PARAM_LINE.match(line)) == _groups(OLD_PARAM_LINE.match(line))


@given(st.text(alphabet=" \tAK_1=ab#;\u00a0", max_size=24))
@settings(max_examples=600, deadline=None)
def test_ini_key_lines_read_as_before(line: str) -> None:
    new, old = ini_reader._KEY.match(line), OLD_KEY.match(line)
    assert (new is None) == (old is None)
    if new is not None and old is not None:
        assert (new.group(1), new.group(2).strip()) == old.groups()


@given(st.text(alphabet=" \t$12=5.x()", max_size=24))
@settings(max_examples=600, deadline=None)
def test_grbl_setting_lines_read_as_before(line: str) -> None:
    assert _groups(grbl_settings._LINE.match(line)) == _groups(OLD_SETTING.match(line))


def _old_logical_lines(text: str) -> list[tuple[int, str]]:
    """ini_reader._logical_lines as it was before 2026-12-02 (quadratic in continuations)."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip()
        if pending is not None:
            number, line = pending[0], pending[1] + " " + line.strip()
            pending = None
        if line.endswith("\\"):
            pending = (number, line[:-1].rstrip())
            continue
        out.append((number, line))
    if pending is not None:
        out.append(pending)
    return out


@given(st.text(alphabet=" \t\\\nab=", max_size=40))
@settings(max_examples=800, deadline=None)
def test_continuation_lines_join_as_before(text: str) -> None:
    assert ini_reader._logical_lines(text) == _old_logical_lines(text)


def test_a_long_run_of_spaces_is_searched_in_linear_time() -> None:
    lines = ["G0 X1", " " * LONG + "x", "O12" + " " * LONG + "x", "O12 (sub)"]
    assert fanuc_subs.find_program(lines, 0, 12) == 3


def test_machine_files_with_long_runs_are_read_in_linear_time(tmp_path: Path) -> None:
    ini = parse_ini(
        "[AXIS_X]\nMAX_VELOCITY = 30" + " " * LONG + "\nMIN_LIMIT = a" + " " * LONG + "b\n", "m.ini"
    )
    assert ini.get("AXIS_X", "MAX_VELOCITY")[0] == "30"
    assert ini.get("AXIS_X", "MIN_LIMIT")[0] == "a" + " " * LONG + "b"
    var = tmp_path / "linuxcnc.var"
    var.write_text("5221 1.5\n5222 " + "2" * LONG + "x\n5223 -.5e1" + " " * LONG + "\n")
    assert read_parameter_file(var) == {5221: 1.5, 5223: -5.0}
    assert parse_settings("$110=500" + " " * LONG + "(x max rate)\n", "s.txt") == {110: (500.0, 1)}
    with pytest.raises(ConfigError, match="not a grbl setting line") as info:
        parse_settings("$1=5" + " " * LONG + "x\n", "s.txt")
    assert info.value.line == 1
