"""Every input file is read within a size cap, and none hangs or nests the readers to death
(hostile-input review: /dev/zero as a machine file, tool table, report or machine import grew
to ~10 GB and exited 3; a FIFO without a writer hung; TOML and JSON nested 100,000 deep
exited 3 with RecursionError). Each is exit 2 with ``FILE: error: MESSAGE``."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from gantry_sim.controller import input_files
from gantry_sim.sim import compare
from gantry_sim.sim.cli import main
from tests.fault_helpers import gantry

ROOT = Path(__file__).resolve().parent.parent
CIRCLE = str(ROOT / "examples" / "circle.ngc")
ZERO = "/dev/zero"
needs_zero = pytest.mark.skipif(not Path(ZERO).exists(), reason="no /dev/zero here")


def refused(args: list[str], capsys) -> str:
    """stderr of ``gantry ARGS``, which must exit 2 in one line without a traceback."""
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@needs_zero
@pytest.mark.parametrize(
    ("args", "what"),
    [
        (["parse", CIRCLE, "--machine", ZERO], "machine file larger than 4 MB"),
        (["parse", CIRCLE, "--tool-table", ZERO], "tool table larger than 4 MB"),
        (["machine", "import", "linuxcnc", ZERO], "LinuxCNC INI file larger than 4 MB"),
        (["machine", "import", "grbl", ZERO], "grbl settings file larger than 4 MB"),
    ],
)
def test_an_endless_stream_is_refused_at_the_cap_of_its_kind(args, what, capsys):
    assert refused(args, capsys).startswith(f"{ZERO}: error: {what}")


@needs_zero
def test_an_endless_report_is_refused_at_the_report_cap(tmp_path, monkeypatch, capsys):
    # the real cap is 256 MB (1.4 million blocks); made small here to stay fast
    monkeypatch.setattr(compare, "REPORT_CAP_BYTES", 1_000_000)
    good = tmp_path / "good.json"
    good.write_text(json.dumps({"cycle_time_s": 1.0, "blocks": []}))
    err = refused(["compare", str(good), ZERO], capsys)
    assert err.startswith(f"{ZERO}: error: report larger than 1 MB"), err
    program = tmp_path / "p.ngc"
    program.write_text("G1 X1 F100\nM2\n")
    err = refused(["run", str(program), "--baseline", ZERO, "--no-plots"], capsys)
    assert err.startswith(f"{ZERO}: error: report larger than 1 MB"), err


def test_a_large_regular_file_is_refused_before_it_is_read(tmp_path, capsys):
    # sparse files: refused from their size alone (nothing of them is read)
    big = tmp_path / "big"
    with open(big, "wb") as f:
        f.truncate(600_000_000)
    err = refused(["parse", str(big)], capsys)
    assert err.startswith(f"{big}: error: program larger than 500 MB"), err
    err = refused(["compare", str(big), str(big)], capsys)
    assert err.startswith(f"{big}: error: report larger than 256 MB"), err
    err = refused(["parse", CIRCLE, "--machine", str(big)], capsys)
    assert err.startswith(f"{big}: error: machine file larger than 4 MB"), err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_without_a_writer_is_refused_not_waited_for(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    report = tmp_path / "r.json"
    report.write_text(json.dumps({"cycle_time_s": 1.0, "blocks": []}))
    for args, what in [
        (["parse", str(fifo)], "program"),
        (["parse", CIRCLE, "--machine", str(fifo)], "machine file"),
        (["parse", CIRCLE, "--tool-table", str(fifo)], "tool table"),
        (["compare", str(report), str(fifo)], "report"),
        (["machine", "import", "grbl", str(fifo)], "grbl settings file"),
    ]:
        done = gantry(*args, timeout=60)  # a process: a hang fails instead of stopping the suite
        assert done.returncode == 2, done.stderr
        assert done.stderr.startswith(
            f"{fifo}: error: {what} is a FIFO with no writer (nothing to read)"
        ), done.stderr


def test_a_stream_with_a_writer_is_read(tmp_path, capsys):
    # a pipe (as `--machine <(...)` or `cat m.toml | gantry ... --machine /dev/stdin` give)
    read, write = os.pipe()
    os.write(write, (ROOT / "models" / "gantry.toml").read_bytes())
    os.close(write)
    assert main(["parse", CIRCLE, "--machine", f"/dev/fd/{read}"]) == 0
    os.close(read)
    assert len(capsys.readouterr().out.splitlines()) == 6


def test_deeply_nested_toml_is_refused_naming_the_file(tmp_path, capsys):
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 100_000 + "\n")
    err = refused(["parse", CIRCLE, "--machine", str(deep)], capsys)
    assert err.startswith(f"{deep}: error: not valid TOML: ") and "nested too deep" in err


@pytest.mark.parametrize("text", ["[" * 100_000, '{"a":' * 100_000])
def test_deeply_nested_json_is_refused_naming_the_file(tmp_path, capsys, text):
    deep, good = tmp_path / "deep.json", tmp_path / "good.json"
    deep.write_text(text)
    good.write_text(json.dumps({"cycle_time_s": 1.0, "blocks": []}))
    err = refused(["compare", str(good), str(deep)], capsys)
    assert err.startswith(f"{deep}: error: not a readable report.json: ") and "deep" in err
    program = tmp_path / "p.ngc"
    program.write_text("G1 X1 F100\nM2\n")
    err = refused(["run", str(program), "--baseline", str(deep), "--no-plots"], capsys)
    assert err.startswith(f"{deep}: error: not a readable report.json: "), err


@pytest.mark.parametrize(
    "report",
    [[1, 2], {"blocks": {}, "cycle_time_s": 1}, {"blocks": [], "cycle_time_s": [1]}],
)
def test_json_of_the_wrong_shape_is_refused_as_baseline_too(tmp_path, capsys, report):
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps(report))
    program = tmp_path / "p.ngc"
    program.write_text("G1 X1 F100\nM2\n")
    err = refused(["run", str(program), "--baseline", str(wrong), "--no-plots"], capsys)
    assert err.startswith(f"{wrong}: error: not a gantry report.json"), err


def test_an_include_of_an_endless_stream_names_the_including_line(tmp_path, capsys):
    if not Path(ZERO).exists():
        pytest.skip("no /dev/zero here")
    ini = tmp_path / "m.ini"
    ini.write_text(f"[EMC]\n#INCLUDE {ZERO}\n")
    err = refused(["machine", "import", "linuxcnc", str(ini)], capsys)
    assert err.startswith(f"{ini}:2: error: #INCLUDE {ZERO}: #INCLUDE file larger than 4 MB")


def test_the_caps_are_the_documented_ones():
    assert input_files.CONFIG_CAP_BYTES == 4_000_000
    assert input_files.REPORT_CAP_BYTES == 256_000_000
