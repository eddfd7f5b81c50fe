"""`gantry run` options and outputs: --json, --no-plots, --feed-override, --deterministic,
timing.json and a "total" that counts everything; --version; run_program with a path or text;
no matplotlib noise on stderr."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from importlib.metadata import version
from pathlib import Path

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.sim.api import run_program
from gantry_sim.sim.cli import main

CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"
TIMING_KEYS = {"parse", "plan", "simulate", "analyse", "write", "total"}


def test_version_is_the_installed_distribution(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"gantry {version('gantry-sim')}\n"


def test_json_prints_the_report_object(write_program, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_program(CIRCLE)), "--out", str(out), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)  # the whole of stdout is one JSON object
    assert printed == json.loads((out / "report.json").read_text())
    assert printed["verdict"]["passed"] is True


def test_no_plots_and_timing_total(write_program, tmp_path, capsys):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    assert main(["run", str(write_program(CIRCLE)), "--out", str(out), "--no-plots"]) == 0
    wall = time.perf_counter() - t0
    assert sorted(p.name for p in out.iterdir()) == ["report.json", "timing.json", "trace.npz"]
    rep = json.loads((out / "report.json").read_text())
    timing = json.loads((out / "timing.json").read_text())
    assert rep["timing_s"] == timing["timing_s"] and timing["timing_s"].keys() == TIMING_KEYS
    assert rep["sim"]["realtime_factor"] == timing["realtime_factor"] > 0
    t = timing["timing_s"]
    stages = sum(v for k, v in t.items() if k != "total")
    assert stages <= t["total"] <= wall  # total: from the command's start to the files written


def test_total_counts_plotting(write_program, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_program(CIRCLE)), "--out", str(out)]) == 0
    t = json.loads((out / "timing.json").read_text())["timing_s"]
    assert (out / "path.png").exists() and t["write"] > 0.05  # the plots take real time
    assert t["total"] >= t["simulate"] + t["write"]
    assert f"total {t['total']:.2f} s" in capsys.readouterr().out


def test_deterministic_reports_are_byte_identical(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    texts = []
    for name in ("a", "b"):
        args = ["run", str(prog), "--out", str(tmp_path / name), "--no-plots", "--deterministic"]
        assert main(args) == 0
        texts.append((tmp_path / name / "report.json").read_bytes())
    assert texts[0] == texts[1]
    rep = json.loads(texts[0])
    # every contract key stays; the wall-clock ones are null here, measured in timing.json
    assert rep["timing_s"].keys() == TIMING_KEYS and set(rep["timing_s"].values()) == {None}
    assert rep["sim"]["realtime_factor"] is None
    assert json.loads((tmp_path / "a" / "timing.json").read_text())["timing_s"]["total"] > 0
    # without the flag the reports differ only in those fields
    for name in ("c", "d"):
        assert main(["run", str(prog), "--out", str(tmp_path / name), "--no-plots"]) == 0
    c, d = (json.loads((tmp_path / n / "report.json").read_text()) for n in "cd")
    for r in (c, d):
        r.pop("timing_s")
        r["sim"].pop("realtime_factor")
    assert c == d


def test_feed_override_scales_the_feeds(write_program, tmp_path, capsys):
    prog = write_program(CIRCLE)
    reps = {}
    for pct in ("100", "50"):
        out = tmp_path / pct
        assert (
            main(["run", str(prog), "--out", str(out), "--no-plots", "--feed-override", pct]) == 0
        )
        reps[pct] = json.loads((out / "report.json").read_text())
    assert reps["50"]["feed_override_pct"] == 50.0
    assert reps["50"]["cycle_time_s"] > 1.7 * reps["100"]["cycle_time_s"]
    assert main(["run", str(prog), "--out", str(tmp_path), "--feed-override", "0"]) == 2
    assert "--feed-override: error:" in capsys.readouterr().err


def test_run_program_takes_a_path_or_text(write_program, tmp_path, machine):
    prog = write_program(CIRCLE, "part.ngc")
    by_path = run_program(prog, machine=machine)
    by_text = run_program(CIRCLE, file="part.ngc", machine=machine)
    assert by_path.report["program"] == str(prog)
    assert by_path.report["blocks"] == by_text.report["blocks"]
    with pytest.raises(GcodeError) as exc:
        run_program(tmp_path / "missing.ngc", machine=machine)
    assert str(tmp_path / "missing.ngc") in str(exc.value) and "not found" in str(exc.value)
    with pytest.raises(GcodeError) as exc:  # a file's name as a str is refused, not run
        run_program(str(prog), machine=machine)
    assert "pass Path(" in str(exc.value)
    bad = write_program("G1 X1 F100\nG2 X2 Q5\n", "bad.ngc")
    with pytest.raises(GcodeError) as exc:
        run_program(Path(bad), machine=machine)
    assert exc.value.file == str(bad) and exc.value.line == 2


def test_no_matplotlib_noise_on_stderr(write_program, tmp_path):
    """An unusable matplotlib config folder makes matplotlib log a warning at import; the run's
    stderr stays empty all the same."""
    env = dict(os.environ, MPLCONFIGDIR=str(tmp_path / "file-not-dir"))
    (tmp_path / "file-not-dir").write_text("")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gantry_sim.sim.cli",
            "run",
            str(write_program(CIRCLE)),
            "--out",
            str(tmp_path / "out"),
        ],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out" / "path.png").exists()
    assert proc.stderr == ""


def test_one_default_out_folder_for_every_command(write_program, tmp_path, monkeypatch, capsys):
    from gantry_sim.sim.cli import build_parser

    prog = str(write_program(CIRCLE))
    parser = build_parser()
    for argv in (["run", prog], ["ballbar"], ["tune"], ["sweep", prog]):
        assert parser.parse_args(argv).out == Path("out"), argv
    monkeypatch.chdir(tmp_path)
    assert main(["ballbar", "--radius", "5", "--feed", "3000"]) == 0
    assert (tmp_path / "out" / "ballbar.json").exists()
