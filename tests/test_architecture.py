"""The layering rules (CONTRIBUTING.md), checked on the source: they keep `gantry` quick to start,
the controller testable without MuJoCo, and the import graph a tree a reader can follow."""

from __future__ import annotations

import ast
import functools
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: repository folder -> installed package name (pyproject.toml maps them the same way)
PACKAGES = {
    "controller": "gantry_sim.controller",
    "sim": "gantry_sim.sim",
    "models": "gantry_sim.models",
}


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return "gantry_sim." + ".".join(parts)


def _sources() -> list[Path]:
    return sorted(p for d in PACKAGES for p in (ROOT / d).rglob("*.py"))


@functools.cache
def _imports(path: Path) -> frozenset[str]:
    """Every module ``path`` imports, anywhere in the file (type-only imports included); each
    file is parsed once for all the rules."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return frozenset(names)


def _tops(path: Path) -> set[str]:
    return {name.split(".")[0] for name in _imports(path)}


def test_controller_imports_nothing_of_sim_models_or_mujoco():
    for path in sorted((ROOT / "controller").rglob("*.py")):
        bad = {
            n for n in _imports(path) if n.startswith(("gantry_sim.sim", "gantry_sim.models"))
        } | (_tops(path) & {"mujoco", "matplotlib"})
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"


def test_only_the_ruckig_solver_imports_ruckig():
    users = sorted(p.relative_to(ROOT).as_posix() for p in _sources() if "ruckig" in _tops(p))
    assert users == ["controller/planner/ruckig_solver.py"]


def test_no_top_level_project_imports():
    """Code imports the installed names only: a user's own `models/` or `sim/` cannot shadow them."""
    for path in (
        _sources()
        + sorted((ROOT / "tests").rglob("*.py"))
        + sorted((ROOT / "scripts").glob("*.py"))
        + sorted((ROOT / "benchmarks").glob("*.py"))
    ):
        bad = _tops(path) & set(PACKAGES)
        assert not bad, f"{path.relative_to(ROOT)} imports top-level {sorted(bad)}"


def test_no_import_cycles():
    modules = {_module_name(p): p for p in _sources()}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        deps = set()
        for imported in _imports(path):
            # `from pkg import mod` names a module; `from mod import func` names the module
            while imported and imported not in modules:
                imported = imported.rpartition(".")[0]
            if imported and imported != name and not name.startswith(imported + "."):
                deps.add(imported)
        graph[name] = deps
    # packages' __init__ re-exports are edges too; a cycle is a back edge in a depth-first search
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for dep in sorted(graph[node]):
            if state.get(dep) == 1:
                cycles.append([*stack[stack.index(dep) :], dep])
            elif dep not in state:
                visit(dep)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_every_package_folder_is_installed():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = sorted(_module_name(p) for d in PACKAGES for p in (ROOT / d).rglob("__init__.py"))
    assert sorted(config["packages"]) == folders
    assert config["package-dir"] == {v: k for k, v in PACKAGES.items()}


def test_servo_is_a_leaf():
    project = {n for n in _imports(ROOT / "controller" / "servo.py") if n.startswith("gantry_sim")}
    assert project <= {"gantry_sim.controller.config", "gantry_sim.controller.config.Servo"}


def test_cli_starts_without_heavy_imports():
    code = (
        "import sys; from gantry_sim.sim.cli import build_parser; build_parser(); "
        "heavy = sorted(m for m in ('mujoco', 'matplotlib', 'ruckig') if m in sys.modules); "
        "print(','.join(heavy))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == ""


def test_gantry_parse_runs_without_numpy(tmp_path):
    """`gantry parse` of lines, arcs and a canned cycle imports no numpy (0.18 s of a 0.3 s
    start): only the commands that plan, and the splines, need it."""
    program = tmp_path / "p.ngc"
    program.write_text("G21 G90\nG0 X1 Y1\nG1 X5 F300\nG2 X9 Y5 R4\nG81 X2 Y2 Z-1 R1\nM2\n")
    code = (
        "import atexit, sys; atexit.register(lambda: print('numpy' in sys.modules, "
        "file=sys.stderr)); from gantry_sim.sim.cli import entry; "
        f"sys.argv = ['gantry', 'parse', {str(program)!r}]; entry()"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert out.stderr.split() == ["False"]
    assert len(out.stdout.splitlines()) >= 6


def test_user_folders_named_like_ours_do_not_change_what_gantry_imports(tmp_path):
    """A user project with its own `models/`, `sim/`, `controller/` (even broken ones) in the
    working directory: gantry and the Python API still import the installed gantry_sim."""
    for name in PACKAGES:
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(
            "raise ImportError('the user folder was imported')\n"
        )
    (tmp_path / "models" / "gantry.xml").write_text("<not a model/>\n")
    code = (
        "import gantry_sim.sim.api, gantry_sim.models, gantry_sim.controller.gcode.interpreter as i; "
        "from pathlib import Path; import gantry_sim.models as m; "
        "assert Path(m.__file__).parent.name == 'models' and Path(m.__file__).parent.parent != Path.cwd(); "
        "print(len(list(i.interpret('G1 X1 F100\\nM2\\n'))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "1"
    program = tmp_path / "p.ngc"
    program.write_text("G1 X1 F100\nM2\n")
    cli = subprocess.run(
        [sys.executable, "-m", "gantry_sim.sim.cli", "parse", "p.ngc"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert cli.returncode == 0, cli.stderr
    assert '"kind": "linear"' in cli.stdout
