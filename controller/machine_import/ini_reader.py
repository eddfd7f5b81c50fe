"""LinuxCNC's INI format, read as LinuxCNC's inifile reader and preprocessor do.

``[SECTION]`` lines; ``KEY = VALUE`` lines (the first occurrence of a key wins); comments
starting with ``#`` or ``;``; blank lines; a trailing backslash continues a line; ``#INCLUDE
file`` reads a file (relative to the including one) in place: its keys belong to the section
the include stands in, and a section it opens goes on after it, as in LinuxCNC's preprocessed
file. Lines that are none of these are skipped, as LinuxCNC does, and kept in
:attr:`IniFile.bad` so an import can say so. Every value remembers its file and line for
``FILE:LINE: error:`` messages.

Text that is not UTF-8 is refused at its line only where LinuxCNC reads it (a section or a
key); a comment in Latin-1 (``# Fräse``) is skipped as any comment. A number is read as
LinuxCNC 2.9's ``IniFile::Find`` reads it (``sscanf("%lf")``): the leading number of the value,
hexadecimal too (``0x10`` is 16), anything after it ignored (``100 # mm/s`` is 100; the import
says so).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from gantry_sim.controller.errors import ConfigError, shown
from gantry_sim.controller.input_files import CONFIG_CAP_BYTES, read_capped

_SECTION = re.compile(r"^\[([^\]]+)\]\s*$")
#: a key line; its value is group 2 stripped (``(.*?)\s*$`` tried every end of a run of
#: spaces from every start in it: quadratic in the run's length)
_KEY = re.compile(r"^([A-Za-z0-9_]++)\s*+=(.*)$")
#: the leading number ``sscanf("%lf")`` reads: hexadecimal (glibc's strtod: 0x10 is 16, 0x1p4
#: too), decimal, inf, nan
_LEADING_NUMBER = re.compile(
    r"[+-]?+(?:(?P<hex>0x(?:[0-9a-f]++\.?+[0-9a-f]*+|\.[0-9a-f]++)(?:p[+-]?+\d++)?+)"
    r"|(?:\d++\.?+\d*+|\.\d++)(?:e[+-]?+\d++)?+|inf(?:inity)?+|nan)",
    re.IGNORECASE,
)
#: #INCLUDE files within #INCLUDE files, at most (a file that includes itself stops there)
MAX_INCLUDE_DEPTH = 9
#: #INCLUDE lines read in all, and the bytes of all the files they read: an INI with its
#: includes is a configuration, not more (a few files of 100 includes each had read for ever)
MAX_INCLUDES, MAX_INCLUDED_BYTES = 1000, CONFIG_CAP_BYTES
#: the code points ``surrogateescape`` gives the bytes that are not UTF-8
_NOT_UTF8 = re.compile("[\udc80-\udcff]")


@dataclass(frozen=True)
class IniFile:
    """Parsed INI: section -> key -> (value, file, line). The first occurrence of a key wins,
    as in LinuxCNC's inifile reader; ``bad`` holds, per section, the first line that is neither
    ``KEY = VALUE`` nor a comment (LinuxCNC skips those; the import says so)."""

    path: str
    sections: dict[str, dict[str, tuple[str, str, int]]]
    bad: dict[str, tuple[str, str, int]]
    #: how values were read, for the import's notes (:meth:`note`): as their leading number,
    #: with text after it ignored (as LinuxCNC does), or a limit beyond the machine file's as none
    notes: list[str] = field(default_factory=list)
    #: #INCLUDE files read so far, and their bytes (bounded by MAX_INCLUDES, MAX_INCLUDED_BYTES)
    included: list[int] = field(default_factory=lambda: [0, 0])

    def get(self, section: str, key: str) -> tuple[str, str, int] | None:
        return self.sections.get(section, {}).get(key)

    def number(self, section: str, key: str) -> float | None:
        """A numeric value, None if absent; a ConfigError at its line if not a finite number."""
        entry = self.get(section, key)
        if entry is None:
            return None
        text, file, line = entry
        m = _LEADING_NUMBER.match(text)
        value = math.nan if m is None else _float(m)
        if not math.isfinite(value):
            raise ConfigError(
                f"[{section}] {key} = {shown(text)}: expected a number (a finite one)",
                file=file,
                line=line,
            )
        if m and m.end() < len(text):
            self.note(
                f"{file}:{line}: [{section}] {key} = {shown(text)} read as {value:g}, the text "
                "after the number ignored (as LinuxCNC does)"
            )
        return value

    def note(self, text: str) -> None:
        """Keep ``text`` among :attr:`notes`, once (a value is read once per axis using it)."""
        if text not in self.notes:
            self.notes.append(text)


def _float(m: re.Match[str]) -> float:
    """The number :data:`_LEADING_NUMBER` matched (inf where it overflows, as strtod)."""
    if m.group("hex") is None:
        return float(m.group())
    try:
        return float.fromhex(m.group())
    except OverflowError:
        return -math.inf if m.group().startswith("-") else math.inf


def decode_ini(data: bytes, path: str) -> str:
    """An INI file's bytes as text: UTF-8 (a leading BOM dropped), the bytes that are not UTF-8
    kept as ``surrogateescape`` code points for :func:`parse_ini` to refuse where they are read;
    binary data is a ConfigError."""
    if b"\x00" in data:
        raise ConfigError("not a LinuxCNC INI file (binary data)", file=path)
    return data.decode("utf-8", errors="surrogateescape").removeprefix("\ufeff")


def read_ini(path: Path) -> str:
    """:func:`decode_ini` of the file at ``path`` (at most the configuration files' cap)."""
    return decode_ini(read_capped(path, "LinuxCNC INI file"), str(path))


def _logical_lines(text: str) -> list[tuple[int, str]]:
    """(first line number, text) with backslash-continued lines joined, as LinuxCNC does: each
    continuation stripped and joined with one space. The pieces are joined once, at the end of
    the logical line (joining them line by line took quadratic time: 900,000 continuations,
    under the file cap, took two minutes)."""
    out: list[tuple[int, str]] = []
    start = 0  # the logical line's first line number; 0: none open
    parts: list[str] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        first = start == 0
        piece = raw.rstrip() if first else raw.strip()
        start = number if first else start
        if not piece.endswith("\\"):
            parts.append(piece)
            out.append((start, " ".join(parts)))
            start, parts = 0, []
        elif (kept := piece[:-1].rstrip()) or first:
            parts.append(kept)  # an empty continuation adds no space (it was stripped away)
    if start:
        out.append((start, " ".join(parts)))
    return out


def parse_ini(text: str, path: str) -> IniFile:
    """Parse LinuxCNC INI text (:func:`decode_ini`'s): ``[SECTION]`` lines, ``KEY = VALUE``
    lines, comments (# or ;), blank lines, backslash continuations and ``#INCLUDE file``
    (relative to the including file, read in place, as LinuxCNC's preprocessor does)."""
    ini = IniFile(path=path, sections={}, bad={})
    _parse_into(ini, text, path, 0, None)
    if not ini.sections:
        raise ConfigError("no [SECTION] found: not a LinuxCNC INI file", file=path)
    return ini


def _parse_into(ini: IniFile, text: str, path: str, depth: int, section: str | None) -> str | None:
    """Parse ``text`` into ``ini`` from within ``section`` (an #INCLUDE's: its lines stand in
    the including file); returns the section open at its end."""
    for number, raw in _logical_lines(text):
        line = raw.strip()
        # the word #INCLUDE, as LinuxCNC spells it (2.9's handle_includes: the line's first
        # word; 2.10's inifile.cc: followed by a blank); "#Includes accel..." is a comment
        if line.startswith("#INCLUDE") and line[8:9] in ("", " ", "\t"):
            name = line[len("#INCLUDE") :].strip()
            why = (
                "no file name"
                if not name
                else "its name is not UTF-8"
                if _NOT_UTF8.search(name)
                else f"included more than {MAX_INCLUDE_DEPTH} deep (an include cycle?)"
                if depth >= MAX_INCLUDE_DEPTH
                else None
            )
            if why is not None:
                raise ConfigError(f"#INCLUDE {shown(name)}: {why}", file=path, line=number)
            inc = Path(path).parent / name
            try:
                data = read_capped(inc, "#INCLUDE file")
                inc_text = decode_ini(data, str(inc))
            except ConfigError as exc:
                raise ConfigError(
                    f"#INCLUDE {name}: {exc.message}", file=path, line=number
                ) from None
            ini.included[0] += 1
            ini.included[1] += len(data)
            if ini.included[0] > MAX_INCLUDES or ini.included[1] > MAX_INCLUDED_BYTES:
                raise ConfigError(
                    f"#INCLUDE {name}: more than {MAX_INCLUDES} #INCLUDE files, or more than "
                    f"{MAX_INCLUDED_BYTES // 2**20} MB of them, in one configuration",
                    file=path,
                    line=number,
                )
            section = _parse_into(ini, inc_text, str(inc), depth + 1, section)
            continue
        if not line or line[0] in "#;":
            continue
        if _NOT_UTF8.search(line):
            raise ConfigError("not a LinuxCNC INI file (invalid UTF-8)", file=path, line=number)
        if m := _SECTION.match(line):
            section = m.group(1).strip()
            ini.sections.setdefault(section, {})
        elif section is None:
            raise ConfigError(f"not inside a [SECTION]: {shown(line, 60)}", file=path, line=number)
        elif m := _KEY.match(line):
            ini.sections[section].setdefault(m.group(1), (m.group(2).strip(), path, number))
        else:
            ini.bad.setdefault(section, (line, path, number))
    return section
