"""The tool table and the stored offsets of a LinuxCNC configuration -> ``[tools]`` and ``[work]``.

LinuxCNC keeps them beside the INI: ``[EMCIO] TOOL_TABLE`` (tool.tbl: ``T<n> P<pocket> X Y Z D
;comment``) and ``[RS274NGC] PARAMETER_FILE`` (linuxcnc.var: ``<number> <value>`` lines, the
numbered parameters the interpreter saves between runs). Both are in the machine's length units
(``[TRAJ] LINEAR_UNITS``), converted to mm here; relative names are relative to the INI's folder.

Mapped: every tool T1.. -> ``[tools] N = { length_mm, diameter_mm, x_mm, y_mm }`` (offsets other
than X/Y/Z, pocket, orientation and angles are not); #5221..#5389 (G54..G59.3 origins) ->
``[work] g54_mm`` .. ``g59_3_mm``; #5211..#5213 with #5210 = 1 -> ``g92_mm``; #5161.. -> ``g28_mm``;
#5181.. -> ``g30_mm``. Only non-zero vectors are written (the bundled values are zero). Not mapped,
and said so: the systems' XY rotations (#5230, #5250.. : the machine file has no key for them;
programs that need one set it with G10 L2 R) and the rotary axes' values.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from gantry_sim.controller.errors import ConfigError, GcodeError, shown
from gantry_sim.controller.gcode.tools import parse_tool_table
from gantry_sim.controller.machine_import.common import read_text
from gantry_sim.controller.machine_work import MAX_MM, SYSTEM_KEYS

#: [work] key -> first numbered parameter (X; Y and Z follow)
WORK_PARAMETERS = {
    **{key: 5221 + 20 * i for i, key in enumerate(SYSTEM_KEYS)},
    "g28_mm": 5161,
    "g30_mm": 5181,
}
#: a parameter line; possessive quantifiers (``*+``, ``++``): a line it refuses fails in linear
#: time (``\d+\.?\d*`` splits a run of digits as many ways as it has digits)
_PARAM_LINE = re.compile(
    r"^\s*+(\d++)\s++([-+]?+(?:(?:\d++(?:\.\d*+)?+|\.\d++)(?:[eE][-+]?+\d++)?+"
    r"|inf(?:inity)?+|nan))\s*+$",
    re.IGNORECASE,
)
_SYSTEM_NAMES = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")


def _missing(path: Path) -> str:
    """Why ``path``, which is not a regular file, is not read."""
    return "not a regular file" if path.exists() else "no such file"


def _beside(ini: Path, name: str) -> Path:
    path = Path(name).expanduser()
    return path if path.is_absolute() else ini.parent / path


def import_tools(
    ini: Path, name: str, scale: float, assumed: list[str], unmapped: list[str]
) -> dict[str, dict[str, float]] | None:
    """``[EMCIO] TOOL_TABLE`` -> the ``[tools]`` section (None when there is none to write)."""
    path = _beside(ini, name)
    if not path.is_file():
        assumed.append(
            f"[EMCIO] TOOL_TABLE {name}: {_missing(path)} beside the INI: [tools] not written"
        )
        return None
    skipped: list[tuple[int, str]] = []
    try:
        tools = parse_tool_table(read_text(path, "tool table"), str(path), scale, skipped)
    except GcodeError as exc:
        raise ConfigError(exc.message, file=exc.file, line=exc.line) from None
    for line, text in skipped[:5]:  # e.g. an old-format table's heading
        assumed.append(
            f"{path}:{line}: {shown(text, 60)} is not a tool line (T<n> P<pocket> Z D ;comment): "
            "skipped, as LinuxCNC skips it"
        )
    if len(skipped) > 5:
        assumed.append(f"{path}: {len(skipped) - 5} more lines that are not tool lines skipped")
    out: dict[str, dict[str, float]] = {}
    for number in sorted(tools):
        t = tools[number]
        if number < 1:
            unmapped.append(f"tool T{number} in {name} (tool numbers start at 1)")
            continue
        entry = {"length_mm": t.z_mm, "diameter_mm": t.diameter_mm}
        if t.x_mm:
            entry["x_mm"] = t.x_mm
        if t.y_mm:
            entry["y_mm"] = t.y_mm
        out[str(number)] = entry
    assumed.append(
        f"{name}: {len(out)} tool(s) in {'mm' if scale == 1.0 else f'units of {scale:g} mm'} "
        "-> [tools] (lengths Z, diameters D, X/Y offsets)"
    )
    return out or None


def read_parameter_file(path: Path) -> dict[int, float]:
    """linuxcnc.var: ``<number> <value>`` lines -> {number: value}; other lines are skipped."""
    return {k: v for k, (v, _) in read_parameter_lines(path).items()}


def read_parameter_lines(path: Path) -> dict[int, tuple[float, int]]:
    """linuxcnc.var -> {number: (value, line)}; ``1e999``, ``inf`` and ``nan`` are read as
    LinuxCNC's ``%lf`` reads them (:func:`import_work` refuses them where they are used)."""
    values: dict[int, tuple[float, int]] = {}
    for number, line in enumerate(read_text(path, "LinuxCNC parameter file").splitlines(), 1):
        if m := _PARAM_LINE.match(line):
            values[int(m.group(1))] = (float(m.group(2)), number)
    return values


def _offset(p: dict[int, tuple[float, int]], base: int, scale: float, path: Path) -> list[float]:
    """#base..#base+2 [mm] (absent: 0); a value that is not finite, or beyond what a [work]
    offset holds, is a ConfigError at its line of the parameter file."""
    out = []
    for k in range(base, base + 3):
        value, line = p.get(k, (0.0, 0))
        mm = value * scale
        if not (math.isfinite(mm) and abs(mm) < MAX_MM):
            raise ConfigError(
                f"#{k} = {value:g}: a stored offset must be a finite number of magnitude below "
                f"{MAX_MM:g} mm",
                file=str(path),
                line=line,
            )
        out.append(mm)
    return out


def import_work(
    ini: Path,
    name: str,
    scale: float,
    assumed: list[str],
    unmapped: list[str],
    keep_g92: bool = True,
) -> dict[str, Any] | None:
    """``[RS274NGC] PARAMETER_FILE`` -> the ``[work]`` section (None when nothing to write).
    ``keep_g92``: False where ``[RS274NGC] DISABLE_G92_PERSISTENCE`` is set (LinuxCNC then
    clears the stored G92 offset at start-up). The coordinate system LinuxCNC starts in
    (#5220) has no key: a system other than G54 is listed as not mapped."""
    path = _beside(ini, name)
    if not path.is_file():
        assumed.append(
            f"[RS274NGC] PARAMETER_FILE {name}: {_missing(path)} beside the INI: [work] not "
            "written "
            "(the stored offsets are all zero)"
        )
        return None
    lines = read_parameter_lines(path)
    p = {k: v for k, (v, _) in lines.items()}
    out: dict[str, Any] = {}
    keys = dict(WORK_PARAMETERS)
    g92 = any(p.get(5211 + i, 0.0) for i in range(3))
    if g92 and not keep_g92:
        assumed.append(
            f"G92 offset #5211-#5213 in {name}: not written ([RS274NGC] "
            "DISABLE_G92_PERSISTENCE: LinuxCNC clears it at start-up)"
        )
    elif p.get(5210, 0.0) == 1.0:
        keys["g92_mm"] = 5211
    elif g92:
        unmapped.append(f"G92 offset #5211-#5213 in {name} (not in effect: #5210 is 0)")
    raw = p.get(5220, 1.0)
    index = int(raw + 0.0001) if math.isfinite(raw) else 1  # as LinuxCNC: 1..9, else G54
    if 2 <= index <= 9:
        code = _SYSTEM_NAMES[index - 1]
        unmapped.append(
            f"#5220 = {index} in {name}: LinuxCNC starts programs in {code}; gantry-sim starts "
            f"them in G54 (write {code} at the program's start)"
        )
    for key, base in keys.items():
        vec = _offset(lines, base, scale, path)
        if any(vec):
            out[key] = vec
    for i, system in enumerate(_SYSTEM_NAMES):
        rotation = p.get(5230 + 20 * i, 0.0)
        if rotation:
            unmapped.append(
                f"{system} XY rotation {rotation:g} deg (#{5230 + 20 * i} in {name}): the machine "
                "file has no key for it; set it in the program with G10 L2 R"
            )
    if out:
        assumed.append(f"{name}: stored offsets and G28/G30 positions -> [work] (mm)")
    return out or None
