"""An output folder holds one whole run, old or new (README, "Output folders"), whatever the
options of the new run and whenever a signal comes.

Before, ``gantry run --no-plots`` (or ``--no-trace``) after a run with plots left the old
path.png, error.png (trace.npz) beside the new report.json. A command now replaces every file
it can write (sim.outdir.atomic_output_dir ``owns``); files that are not its own (the user's,
another command's) stay. A Ctrl-C or SIGTERM during the commit is raised after it.
"""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fault_helpers import gantry_at

from gantry_sim.sim import interrupts, outdir
from gantry_sim.sim.cli import main
from gantry_sim.sim.outdir import STAGE_PREFIX, atomic_file, atomic_output_dir, recover

LINE = "G21 G90\nG1 X2 F1200\nM2\n"
RUN_FILES = {"report.json", "timing.json", "trace.npz", "path.png", "error.png"}


def _names(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def test_a_run_without_plots_or_trace_leaves_none_of_the_earlier_runs_files(write_program):
    prog, out = str(write_program(LINE)), Path("out")
    assert main(["run", prog, "--out", str(out)]) == 0
    assert _names(out) == RUN_FILES
    (out / "notes.txt").write_text("mine")  # a user's file, not a run output
    (out / "ballbar.json").write_text("{}")  # another command's output: shared folders
    assert main(["run", prog, "--out", str(out), "--no-plots", "--no-trace"]) == 0
    assert _names(out) == {"report.json", "timing.json", "notes.txt", "ballbar.json"}
    files = json.loads((out / "report.json").read_text())["files"]
    assert files == ["report.json", "timing.json"]
    assert main(["run", prog, "--out", str(out), "--no-plots"]) == 0
    assert _names(out) == {"report.json", "timing.json", "trace.npz", "notes.txt", "ballbar.json"}
    assert (out / "notes.txt").read_text() == "mine"


def test_a_failed_run_removes_the_earlier_run_whole_and_keeps_other_files(write_program):
    """README: a run that fails (exit 2) leaves no older report beside its error; the user's
    files stay, and no staging folder is left."""
    out = Path("out")
    assert main(["run", str(write_program(LINE)), "--out", str(out)]) == 0
    (out / "notes.txt").write_text("mine")
    outside = write_program("G1 X400 F3000\nM2\n", "outside.ngc")  # leaves the travel
    assert main(["run", str(outside), "--out", str(out)]) == 2
    assert _names(out) == {"notes.txt"}


def test_a_commit_killed_half_way_is_completed_whole_by_the_next_writer(write_program):
    """kill -9 after two of the new run's files moved in: the next writer completes the commit
    and removes only the earlier run's files, never the new ones already moved in."""
    out = Path("out")
    assert main(["run", str(write_program(LINE, "old.ngc")), "--out", str(out)]) == 0
    new = str(write_program("G21 G90\nG1 X3 F1200\nM2\n", "new.ngc"))
    killed = gantry_at("replace:2", "run", new, "--out", str(out), "--no-plots")
    assert killed.returncode == -9, killed.stderr
    recover(out)  # what the next writer into the folder does first, under its lock
    assert _names(out) == {"report.json", "timing.json", "trace.npz"}
    report = json.loads((out / "report.json").read_text())
    assert Path(report["program"]).name == "new.ngc"
    with np.load(out / "trace.npz") as tr:
        assert report["sim"]["steps"] == 2 * tr["t"].size  # the same run's trace


def _commit(out: Path, files: dict[str, str], owns: tuple[str, ...]) -> None:
    with atomic_output_dir(out, last="a.json", owns=owns) as stage:
        for name, text in files.items():
            (stage / name).write_text(text)


def test_a_commit_replaces_all_its_own_names_and_nothing_else(tmp_path):
    out, owns = tmp_path / "out", ("a.json", "a.png", "a.npz")
    _commit(out, {"a.json": "1", "a.png": "1", "a.npz": "1"}, owns)
    (out / "b.json").write_text("other")  # another command's
    (out / "notes.txt").write_text("mine")
    _commit(out, {"a.json": "2"}, owns)
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "a.json": "2",
        "b.json": "other",
        "notes.txt": "mine",
    }


def test_staging_a_file_the_command_does_not_own_is_a_bug_that_changes_nothing(tmp_path):
    out = tmp_path / "out"
    _commit(out, {"a.json": "1"}, ("a.json",))
    with pytest.raises(RuntimeError, match="not listed"):
        _commit(out, {"a.json": "2", "stray.png": "2"}, ("a.json",))
    assert {p.name: p.read_text() for p in out.iterdir()} == {"a.json": "1"}


@pytest.fixture
def handled() -> Iterator[None]:
    """SIGINT handled as the console script handles it (sim.interrupts), then restored."""
    previous = signal.signal(signal.SIGINT, interrupts.on_signal)
    interrupts.reset()
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        interrupts.reset()


def test_ctrl_c_during_the_commit_is_raised_after_it(tmp_path, monkeypatch, handled):
    out, owns = tmp_path / "out", ("a.json", "a.png")
    _commit(out, {"a.json": "1", "a.png": "1"}, owns)
    real = outdir._commit

    def interrupted(stage: Path, folder: Path) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # arrives with the commit under way
        real(stage, folder)

    monkeypatch.setattr(outdir, "_commit", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _commit(out, {"a.json": "2", "a.png": "2"}, owns)
    assert {p.name: p.read_text() for p in out.iterdir()} == {"a.json": "2", "a.png": "2"}


def test_ctrl_c_before_the_commit_leaves_the_old_run_and_no_staging(tmp_path, handled):
    out, owns = tmp_path / "out", ("a.json", "a.png")
    _commit(out, {"a.json": "1", "a.png": "1"}, owns)
    with pytest.raises(KeyboardInterrupt), atomic_output_dir(out, "a.json", owns) as stage:
        (stage / "a.json").write_text("2")
        os.kill(os.getpid(), signal.SIGINT)
    assert {p.name: p.read_text() for p in out.iterdir()} == {"a.json": "1", "a.png": "1"}
    assert not [p for p in out.iterdir() if p.name.startswith(STAGE_PREFIX)]


def test_an_interrupted_single_file_output_leaves_the_old_file_and_no_temporary(tmp_path, handled):
    """``gantry plan --out`` and ``gantry machine import --out`` (sim.outdir.atomic_file)."""
    target = tmp_path / "traj.npz"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_file(target) as fh:
        fh.write("new")
        os.kill(os.getpid(), signal.SIGINT)
    assert os.listdir(tmp_path) == ["traj.npz"] and target.read_text() == "old"
