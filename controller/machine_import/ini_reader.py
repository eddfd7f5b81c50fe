"""LinuxCNC's INI format, read as LinuxCNC's inifile reader and preprocessor do.

``[SECTION]`` lines; ``KEY = VALUE`` lines (the first occurrence of a key wins); comments
starting with ``#`` or ``;``; blank lines; a trailing backslash continues a line; ``#INCLUDE
file`` reads a file (relative to the including one) in place. Lines that are none of these are
skipped, as LinuxCNC does, and kept in :attr:`IniFile.bad` so an import can say so. Every value
remembers its file and line for ``FILE:LINE: error:`` messages.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.input_files import read_capped

_SECTION = re.compile(r"^\[([^\]]+)\]\s*$")
#: a key line; its value is group 2 stripped (``(.*?)\s*$`` tried every end of a run of
#: spaces from every start in it: quadratic in the run's length)
_KEY = re.compile(r"^([A-Za-z0-9_]++)\s*+=(.*)$")


@dataclass(frozen=True)
class IniFile:
    """Parsed INI: section -> key -> (value, file, line). The first occurrence of a key wins,
    as in LinuxCNC's inifile reader; ``bad`` holds, per section, the first line that is neither
    ``KEY = VALUE`` nor a comment (LinuxCNC skips those; the import says so)."""

    path: str
    sections: dict[str, dict[str, tuple[str, str, int]]]
    bad: dict[str, tuple[str, str, int]]

    def get(self, section: str, key: str) -> tuple[str, str, int] | None:
        return self.sections.get(section, {}).get(key)

    def number(self, section: str, key: str) -> float | None:
        """A numeric value, None if absent; a ConfigError at its line if not a finite number."""
        entry = self.get(section, key)
        if entry is None:
            return None
        text, file, line = entry
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(
                f"[{section}] {key} = {shown(text)}: expected a number", file=file, line=line
            )
        return value


def _logical_lines(text: str) -> list[tuple[int, str]]:
    """(first line number, text) with backslash-continued lines joined, as LinuxCNC does."""
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


def parse_ini(text: str, path: str, _depth: int = 0, _into: IniFile | None = None) -> IniFile:
    """Parse LinuxCNC INI text: ``[SECTION]`` lines, ``KEY = VALUE`` lines, comments (# or ;),
    blank lines, backslash continuations and ``#INCLUDE file`` (relative to the including
    file, read in place, as LinuxCNC's preprocessor does)."""
    ini = _into if _into is not None else IniFile(path=path, sections={}, bad={})
    section: str | None = None
    for number, raw in _logical_lines(text):
        line = raw.strip()
        if line.upper().startswith("#INCLUDE"):
            name = line[len("#INCLUDE") :].strip()
            inc = Path(path).parent / name
            if _depth > 8 or not name:
                raise ConfigError(
                    f"#INCLUDE {name!r}: missing name or nested too deep", file=path, line=number
                )
            try:
                inc_text = read_capped(inc, "#INCLUDE file").decode("utf-8-sig")
            except ConfigError as exc:
                raise ConfigError(
                    f"#INCLUDE {name}: {exc.message}", file=path, line=number
                ) from None
            except UnicodeDecodeError as exc:
                raise ConfigError(
                    f"#INCLUDE {name}: cannot read it ({exc})", file=path, line=number
                ) from None
            parse_ini(inc_text, str(inc), _depth + 1, ini)
            section = None
            continue
        if not line or line[0] in "#;":
            continue
        if m := _SECTION.match(line):
            section = m.group(1).strip()
            ini.sections.setdefault(section, {})
        elif section is None:
            raise ConfigError(f"not inside a [SECTION]: {shown(line, 60)}", file=path, line=number)
        elif m := _KEY.match(line):
            ini.sections[section].setdefault(m.group(1), (m.group(2).strip(), path, number))
        else:
            ini.bad.setdefault(section, (line, path, number))
    if _depth == 0 and not ini.sections:
        raise ConfigError("no [SECTION] found: not a LinuxCNC INI file", file=path)
    return ini
