"""Machine variants for theory tests: the bundled MJCF with some joint attributes changed.

The variant is derived from models/gantry.xml at test time (not a copy), so it follows the
bundled machine; only the named attributes differ. Written with a machine file that points at it.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from gantry_sim.controller.config import MachineConfig, load_machine_config
from gantry_sim.models import DEFAULT_MACHINE, GANTRY_XML


def joint_attribute(name: str, attribute: str) -> float:
    """An attribute of joint ``name`` in the bundled MJCF (SI units)."""
    for j in ET.parse(GANTRY_XML).getroot().iter("joint"):
        if j.get("name") == name:
            return float(j.get(attribute, "0"))
    raise KeyError(name)


def gantry_variant(
    folder: Path,
    joints: dict[str, dict[str, float]] | None = None,
    servo: dict[str, list[float]] | None = None,
) -> MachineConfig:
    """The bundled machine with joint attributes (SI, e.g. {"x": {"frictionloss": 0}}) and
    [servo] keys replaced; files are written into ``folder``."""
    tree = ET.parse(GANTRY_XML)
    for j in tree.getroot().iter("joint"):
        for attr, value in (joints or {}).get(j.get("name") or "", {}).items():
            j.set(attr, repr(float(value)))
    tree.write(folder / "gantry_variant.xml")
    lines = ["[sim]", 'model = "gantry_variant.xml"', "[servo]"]
    lines += [f"{k} = {json.dumps(v)}" for k, v in (servo or {}).items()]
    (folder / "variant.toml").write_text("\n".join(lines) + "\n")
    return load_machine_config(DEFAULT_MACHINE, folder / "variant.toml")


FRICTIONLESS = {a: {"frictionloss": 0.0} for a in ("x", "y", "z")}
