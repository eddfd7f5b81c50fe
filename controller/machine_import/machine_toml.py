"""An import's values as a machine file (TOML, the sections and keys of models/gantry.toml).

Only the keys the import set are written; the file is laid over the bundled defaults like any
``--machine FILE``. What was assumed and what could not be mapped head the file as comments.
"""

from __future__ import annotations

import json
import math

from gantry_sim.controller.machine_import.common import Imported

#: section order of models/gantry.toml
SECTIONS = ("limits", "travel", "segmentation", "path", "servo", "sim", "tools", "work")


def _number(v: float) -> str:
    if not math.isfinite(v):
        raise ValueError(f"non-finite value {v}")
    return repr(float(v))  # the shortest text that reads back as the same float (valid TOML)


def _value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):  # an inline table, e.g. a tool: { length_mm = 10.0, ... }
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }"
    return _number(float(v))


def _comment(text: str) -> list[str]:
    """A note as '#' lines of at most ~98 characters."""
    words, lines, line = text.split(), [], "#  "
    for word in words:
        if len(line) + len(word) > 98 and line.strip() != "#":
            lines.append(line.rstrip())
            line = "#    "
        line += word + " "
    lines.append(line.rstrip())
    return lines


def to_toml(imported: Imported) -> str:
    """The machine file's text (every section of ``imported.values``, in the bundled file's
    order; a section it does not know is a bug, never dropped)."""
    unknown = sorted(set(imported.values) - set(SECTIONS))
    if unknown:
        raise ValueError(f"imported values for unknown machine-file sections: {unknown}")
    out = [
        f"# gantry-sim machine file imported from {imported.kind}: {imported.source}",
        "# Keys not set here keep the bundled models/gantry.toml values.",
    ]
    if imported.assumed:
        out.append("# Assumed:")
        for note in imported.assumed:
            out += _comment(note)
    if imported.not_mapped:
        out.append("# Not mapped:")
        for note in imported.not_mapped:
            out += _comment(note)
    for section in SECTIONS:
        keys = imported.values.get(section)
        if not keys:
            continue
        out += ["", f"[{section}]"]
        out += [f"{key} = {_value(value)}" for key, value in keys.items()]
    return "\n".join(out) + "\n"
