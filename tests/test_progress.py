"""`gantry run --progress`: one bar per stage on stderr, stdout untouched; quiet by default
when stderr is not a terminal (tests, pipes, CI)."""

from __future__ import annotations

import json

import pytest

from gantry_sim.sim import api, error_tally, progress, stream
from gantry_sim.sim.cli import main

PROGRAM = "G21 G17 G90 G94\nG0 X1 Y1\nG1 X5 Y0 F2000\nG3 I-5 J0\nG1 X0 Y0\nM2\n"


def _run(tmp_path, capsys, *flags):
    program = tmp_path / "p.ngc"
    program.write_text(PROGRAM)
    assert main(["run", str(program), "--out", str(tmp_path / "out"), "--json", *flags]) == 0
    got = capsys.readouterr()
    return json.loads(got.out), got.err  # the whole of stdout is still one JSON object


def test_progress_draws_a_bar_per_stage_on_stderr_only(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.0)  # the test's stages are short
    report, err = _run(tmp_path, capsys, "--progress")
    assert report["verdict"]["passed"]
    for name in ("parse", "plan", "simulate", "analyse", "write"):
        assert f"{name}: " in err, name
    simulate = [s for s in err.replace("\r", "\n").splitlines() if s.startswith("simulate: ")]
    assert any("%|" in s and "<" in s and "tick/s" in s for s in simulate)  # elapsed<ETA, rate


def test_progress_of_a_streamed_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.0)
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    monkeypatch.setattr(stream, "STREAM_TICKS", 256)
    monkeypatch.setattr(error_tally, "TILE_TICKS", 100)
    _, err = _run(tmp_path, capsys, "--progress")
    for name in ("parse", "plan", "simulate+analyse", "trace.npz", "write"):
        assert f"{name}: " in err, name


@pytest.mark.parametrize("flags", [(), ("--no-progress",)])
def test_quiet_unless_asked_when_stderr_is_no_terminal(tmp_path, capsys, monkeypatch, flags):
    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.0)
    _, err = _run(tmp_path, capsys, *flags)
    assert err == ""


def test_no_progress_wins_on_a_terminal(monkeypatch):
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    assert progress.wanted(None) is True
    assert progress.wanted(False) is False


def test_a_stage_without_updates_still_shows_its_elapsed_time(monkeypatch, capsys):
    """A whole-trace analysis reports nothing while it runs: its bar is redrawn by a ticker once
    the delay has passed, then erased."""
    import threading
    import time

    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.05)
    monkeypatch.setattr(progress._Ticker, "TICK_S", 0.05)
    with progress.stage("analyse", 3, "tick", True, known_size=False):
        time.sleep(0.4)
    err = capsys.readouterr().err
    assert err.count("analyse: 00:00 elapsed") >= 2
    assert not any(t.name == "gantry-progress" for t in threading.enumerate())


def test_a_ticking_stage_is_redrawn_between_its_updates(monkeypatch, capsys):
    """Planning reports in steps seconds apart (a window, a batch of a print's parts): its bar
    shows its share and is redrawn meanwhile, so its elapsed time moves."""
    import threading
    import time

    monkeypatch.setattr(progress, "PROGRESS_DELAY_S", 0.05)
    monkeypatch.setattr(progress._Ticker, "TICK_S", 0.05)
    with progress.stage("plan", 4, "move", True, ticking=True) as advance:
        advance(1)
        time.sleep(0.4)
        advance(3)
    err = capsys.readouterr().err
    assert err.count("plan:  25%") >= 2  # redrawn while no update came
    assert not any(t.name == "gantry-progress" for t in threading.enumerate())
