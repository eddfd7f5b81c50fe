"""The layering rules of DESIGN.md, checked on the source: they keep `gantry` quick to start and
the controller testable without MuJoCo."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_controller_imports_nothing_of_sim_models_or_mujoco():
    for path in sorted((ROOT / "controller").glob("*.py")):
        bad = _imports(path) & {"sim", "models", "mujoco", "matplotlib"}
        assert not bad, f"{path.name} imports {sorted(bad)}"


def test_only_the_planner_imports_ruckig():
    users = sorted(
        p.relative_to(ROOT).as_posix()
        for d in ("controller", "sim", "models")
        for p in (ROOT / d).rglob("*.py")
        if "ruckig" in _imports(p)
    )
    assert users in ([], ["controller/planner.py"])


def test_cli_starts_without_heavy_imports():
    code = (
        "import sys; from sim.cli import build_parser; build_parser(); "
        "heavy = sorted(m for m in ('mujoco', 'matplotlib', 'ruckig') if m in sys.modules); "
        "print(','.join(heavy))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == ""
