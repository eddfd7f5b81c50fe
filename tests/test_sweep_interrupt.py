"""Ctrl-C on a local sweep (issue 14): it stops within about a second, keeps the finished
points in the journal, says where it stopped and how to resume, exits 130; the rerun resumes."""

from __future__ import annotations

import csv
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_faults_sweep import _children, _gone

# 96 s simulated at 100 %: the 60 % points simulate 160 s, at least 1 s of computing after the
# quick pair (48 and 64 s) on a fast machine and about 2-4 s on a loaded one, so the slow pair is
# running when Ctrl-C comes; the rerun computes them again, so they are kept no longer.
PROGRAM = "G21 G90\nG0 X-80\nG1 X80 F100\nM2\n"
GRID = "200,150,60,61"


def _sweep(prog: Path, out: Path) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "gantry_sim.sim.cli", "sweep", str(prog), "--workers", "2"]
    return subprocess.Popen(
        [*cmd, "--feed-override", GRID, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        # as a terminal's job: Ctrl-C delivered (a test runner started in the background by a
        # non-interactive shell passes SIGINT on ignored, and an ignored signal stays ignored)
        preexec_fn=_default_sigint,
    )


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _lines(path: Path) -> list[str]:
    try:
        return path.read_text().splitlines()
    except FileNotFoundError:
        return []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")
def test_ctrl_c_stops_a_local_sweep_at_once_and_the_rerun_resumes(tmp_path):
    prog = tmp_path / "p.ngc"
    prog.write_text(PROGRAM)
    out = tmp_path / "out"
    journal = out / "sweep.partial.jsonl"
    proc = _sweep(prog, out)
    try:
        deadline = time.monotonic() + 30
        while len(_lines(journal)) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
        assert len(_lines(journal)) == 2, "the two quick points did not finish"
        time.sleep(0.3)  # the slow pair is under way
        kids = _children(proc.pid)
        assert proc.poll() is None and kids
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the whole foreground process group
        _, err = proc.communicate(timeout=10)
        stopped_s = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    left = _gone(kids, 5.0)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert proc.returncode == 128 + signal.SIGINT
    assert stopped_s < 2.0, f"took {stopped_s:.2f} s to stop"
    assert not left, "workers outlived the interrupted sweep"
    assert "Traceback" not in err
    assert f"gantry: interrupted: 2 of 4 grid point(s) done, kept in {journal}" in err
    assert "rerun the same sweep to resume: gantry sweep " in err
    assert not (out / "sweep.csv").exists()
    kept = {
        json.loads(x)["row"]["feed_override_pct"]: json.loads(x)["row"] for x in _lines(journal)
    }
    assert set(kept) == {200.0, 150.0}

    # the same command again: the two kept points are not simulated again
    again = _sweep(prog, out)
    try:
        got, err = again.communicate(timeout=60)
    finally:
        if again.poll() is None:
            os.killpg(again.pid, signal.SIGKILL)
            again.wait()
    assert again.returncode == 0, err
    assert f"{journal}: resuming: 2 of 4 grid point(s) already done" in err
    rows = list(csv.DictReader(io.StringIO(got)))
    assert [float(r["feed_override_pct"]) for r in rows] == [200.0, 150.0, 60.0, 61.0]
    assert all(r["status"] == "ok" for r in rows)
    for r in rows[:2]:  # the kept rows, as journaled
        assert float(r["cycle_time_s"]) == kept[float(r["feed_override_pct"])]["cycle_time_s"]
    assert (out / "sweep.csv").exists() and not journal.exists()
