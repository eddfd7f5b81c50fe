"""Machine variants for tests: the bundled MJCF with some joint or motor attributes changed.

The variant is derived from models/gantry.xml at test time (not a copy), so it follows the
bundled machine; only the named attributes differ. Written with a machine file that points at it.
The one helper for MJCF variants in the suite.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from gantry_sim.controller.config import MachineConfig, load_machine_config
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML


def joint_attribute(name: str, attribute: str) -> float:
    """An attribute of joint ``name`` in the bundled MJCF (SI units)."""
    for j in ET.parse(GANTRY_XML).getroot().iter("joint"):
        if j.get("name") == name:
            return float(j.get(attribute, "0"))
    raise KeyError(name)


def write_variant(
    folder: Path,
    joints: dict[str, dict[str, float]] | None = None,
    motors: dict[str, dict[str, str]] | None = None,
    sections: dict[str, dict[str, Any]] | None = None,
) -> Path:
    """Write gantry_variant.xml (the bundled MJCF with joint attributes, SI, e.g.
    {"x": {"frictionloss": 0}}, and motor attributes, e.g. {"x": {"forcerange": "-1e9 1e9"}},
    replaced) and variant.toml (pointing at it, plus the machine-file keys in ``sections``,
    e.g. {"servo": {"ff_velocity": [0, 0, 0]}}) into ``folder``; return the machine file."""
    tree = ET.parse(GANTRY_XML)
    for tag, changes in (("joint", joints), ("motor", motors)):
        for element in tree.getroot().iter(tag):
            for attr, value in (changes or {}).get(element.get("name") or "", {}).items():
                element.set(attr, value if isinstance(value, str) else repr(float(value)))
    tree.write(folder / "gantry_variant.xml")
    lines = ["[sim]", 'model = "gantry_variant.xml"']
    for section, keys in (sections or {}).items():
        lines.append(f"[{section}]")
        lines += [f"{k} = {json.dumps(v)}" for k, v in keys.items()]
    path = folder / "variant.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def gantry_variant(
    folder: Path,
    joints: dict[str, dict[str, float]] | None = None,
    servo: dict[str, list[float]] | None = None,
    motors: dict[str, dict[str, str]] | None = None,
    limits: dict[str, list[float]] | None = None,
) -> MachineConfig:
    """The bundled machine with joint and motor attributes and [servo] and [limits] keys
    replaced (see :func:`write_variant`); files are written into ``folder``."""
    sections = {"servo": servo or {}, "limits": limits or {}}
    return load_machine_config(DEFAULT_MACHINE, write_variant(folder, joints, motors, sections))


AXIS_NAMES = ("x", "y", "z")
FRICTIONLESS = {a: {"frictionloss": 0.0} for a in AXIS_NAMES}
#: drives that never saturate: ctrlrange and forcerange +-1e9 N on every axis
UNLIMITED_FORCE = {a: {"ctrlrange": "-1e9 1e9", "forcerange": "-1e9 1e9"} for a in AXIS_NAMES}
