"""Seeded, short fuzzing of the exit-status contract (issue 15): valid programs through plan
and run; hostile programs, machine files and option values through every command. Every call
must exit 0, 1 or 2, print ``FILE[:LINE]: error:`` on 2, never a traceback, within a bound.
The long run is scripts/fuzz_contract.py (same inputs, many more of them)."""

from __future__ import annotations

from pathlib import Path

import pytest
from fuzz_inputs import (
    call,
    hostile_machine_files,
    hostile_options,
    hostile_programs,
    valid_programs,
)
from hypothesis import HealthCheck, given, settings

#: every in-process call ends within this [s] (2 cores, under load)
LIMIT_S = 60.0
#: the heavy commands get a small simulated-time bound unless the fuzz sets one itself
SMALL_BUDGET = ["--max-sim-s", "20"]


def fuzz(examples: int) -> settings:
    """Seeded settings for ``examples`` inputs."""
    return settings(FUZZ, max_examples=examples)


FUZZ = settings(
    derandomize=True,  # seeded: the same inputs on every run
    database=None,
    deadline=None,  # timing is asserted by the contract (LIMIT_S), not by hypothesis
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs warnings to ./MUJOCO_LOG.TXT; ./out defaults


def _check(argv: list[str]) -> None:
    outcome = call(argv)
    problem = outcome.violation(LIMIT_S)
    assert problem is None, f"gantry {' '.join(argv)}: {problem}\n{outcome.stderr}"


def _file(tmp_path: Path, name: str, data: str | bytes) -> str:
    path = tmp_path / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return str(path)


@fuzz(15)
@given(program=valid_programs())
def test_valid_programs_plan(tmp_path, program):
    outcome = call(["plan", _file(tmp_path, "v.ngc", program)])
    assert outcome.status == 0, f"{program}\n{outcome.stderr}"


@fuzz(5)
@given(program=valid_programs(max_moves=2))
def test_valid_programs_run(tmp_path, program):
    outcome = call(["run", _file(tmp_path, "v.ngc", program), "--out", str(tmp_path / "o")])
    assert outcome.status == 0, f"{program}\n{outcome.stderr}"


@fuzz(80)
@given(data=hostile_programs())
def test_hostile_programs_parse_and_plan(tmp_path, data):
    prog = _file(tmp_path, "h.ngc", data)
    _check(["parse", prog])
    _check(["plan", prog])


@fuzz(40)
@given(text=hostile_machine_files())
def test_hostile_machine_files(tmp_path, text):
    prog = _file(tmp_path, "p.ngc", "G1 X1 F600\nM2\n")
    _check(["plan", prog, "--machine", _file(tmp_path, "m.toml", text)])


@fuzz(6)
@given(text=hostile_machine_files())
def test_hostile_machine_files_run(tmp_path, text):
    prog = _file(tmp_path, "p.ngc", "G1 X0.5 F600\nM2\n")
    machine = _file(tmp_path, "m.toml", text)
    _check(["run", prog, "--machine", machine, "--out", str(tmp_path / "o"), *SMALL_BUDGET])


@pytest.mark.parametrize(
    ("command", "examples"),
    [("parse", 6), ("plan", 8), ("run", 6), ("ballbar", 8), ("tune", 6), ("sweep", 2)],
)
def test_hostile_options(tmp_path, command, examples):
    prog = _file(tmp_path, "p.ngc", "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n")

    @fuzz(examples)
    @given(opts=hostile_options(command))
    def check(opts):
        argv = [command]
        if command in ("parse", "plan", "run", "sweep"):
            argv.append(prog)
        argv += opts
        if command in ("run", "ballbar", "tune", "sweep"):
            argv += ["--out", str(tmp_path / "o")]
            if not any(o.startswith("--max-sim-s") for o in opts):
                argv += SMALL_BUDGET
        if command == "sweep" and not any(o.startswith("--workers") for o in opts):
            argv += ["--workers", "1"]
        _check(argv)

    check()


def test_the_long_fuzz_script_runs_and_tallies(tmp_path):
    """scripts/fuzz_contract.py, at its smallest: it runs, counts, and passes on our inputs."""
    import json
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    counts = tmp_path / "counts.json"
    r = subprocess.run(
        [sys.executable, str(root / "scripts" / "fuzz_contract.py"), "--examples", "3",
         "--only", "options (plan)", "--json", str(counts)],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout + r.stderr
    tally = json.loads(counts.read_text())
    assert sum(tally["hostile options [plan]"].values()) == 3
    assert "inputs: 3 calls" in r.stdout
