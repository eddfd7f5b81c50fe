"""The wheel users install ships the licence and the PEP 561 markers (py.typed in every
package: gantry_sim is a namespace package, so each package declares its own)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tomllib
import zipfile

import pytest

from tests.conftest import ROOT


@pytest.mark.slow
def test_wheel_has_license_and_py_typed(tmp_path):
    # build from a clean copy: setuptools would leave build/ in the checkout, and reuse it
    src = tmp_path / "src"
    junk = (".git", ".venv", "venv", "build", "*.egg-info", "__pycache__", ".*cache", "out")
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(*junk))
    # the [test] extra's setuptools (>= 70.1, which needs no `wheel`): no isolated build
    # environment to install (7.5 s -> 3.1 s); users' pip builds with pyproject's setuptools
    build = ["wheel", "--no-deps", "--no-build-isolation", "-q", str(src), "-w", str(tmp_path)]
    proc = subprocess.run(
        [sys.executable, "-m", "pip", *build],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    [wheel] = tmp_path.glob("gantry_sim-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), sorted(names)
    packages = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    for package in packages["packages"]:
        assert f"{package.replace('.', '/')}/py.typed" in names, package
    license_text = (ROOT / "LICENSE").read_text()
    assert license_text.startswith("MIT License")
