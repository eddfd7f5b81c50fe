"""The bundled machine: an MJCF gantry (SI units) and its machine file (mm, s, N)."""

from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parent
#: The bundled gantry, MJCF in SI units (joints and actuators x, y, z; site "tool").
GANTRY_XML = MODELS_DIR / "gantry.xml"
#: A scene for viewing that includes the gantry (floor, light).
SCENE_XML = MODELS_DIR / "scene.xml"
#: The bundled machine file: the defaults every --machine FILE is laid over.
DEFAULT_MACHINE = MODELS_DIR / "gantry.toml"
