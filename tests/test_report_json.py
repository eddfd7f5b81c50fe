"""report.json is written block by block (RunReport.write_json), character for character what
json.dump of the whole object with indent 2 writes; the run's summary and gates read the typed
blocks."""

from __future__ import annotations

import io
import json

import pytest

from gantry_sim.controller.config import load_machine_config
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.api import run_program
from gantry_sim.sim.gates import Gates, evaluate, parse_error_limits


@pytest.fixture(scope="module")
def reports():
    machine = load_machine_config(DEFAULT_MACHINE)
    cut = run_program(
        "G21 G90 G17 F1200\nG1 X2 Y1\nG2 X4 Y1 I1 J0\nG1 X5 Y0.5\nM2\n", machine=machine
    )
    rapid = run_program("G21 G90\nG0 X1 Y1\nM2\n", machine=machine)
    return cut.run_report, rapid.run_report


@pytest.mark.parametrize("deterministic", [False, True])
def test_written_block_by_block_as_json_dump_writes_it(reports, deterministic):
    for report in reports:
        out = io.StringIO()
        report.write_json(out, deterministic)
        whole = json.dumps(report.to_json(deterministic), indent=2) + "\n"
        assert out.getvalue() == whole
    assert len(reports[0].blocks) == 3 and not reports[1].blocks  # blocks, and none


@pytest.mark.parametrize("deterministic", [False, True])
def test_started_before_the_outputs_are_written_and_finished_after(reports, deterministic):
    """write_json_start writes nothing the outputs' writing fills in (LATE_KEYS): finished by
    the report with its timing, verdict and files, the text is that report's json.dump."""
    from dataclasses import replace

    from gantry_sim.sim.gates import Verdict
    from gantry_sim.sim.report import LATE_KEYS

    for report in reports:
        keys = list(report.to_json())
        assert all(keys.index(k) > keys.index("blocks") for k in LATE_KEYS)
        later = replace(
            report,
            timing_s={**report.timing_s, "write": 0.25, "total": 9.5},
            files=("report.json", "path.png"),
            verdict=Verdict(passed=False, gates=("x",), failures=({"gate": "x"},)),
        )
        out = io.StringIO()
        report.write_json_start(out, deterministic)
        later.write_json_end(out, deterministic)
        assert out.getvalue() == json.dumps(later.to_json(deterministic), indent=2) + "\n"


def test_block_times_are_ticks_times_the_servo_period(reports):
    report = reports[0]
    times = report.block_time_s
    for b, item in zip(report.blocks, report.blocks_json(), strict=True):
        assert item["time_s"] == times[b.line] == b.ticks * report.sim.servo_period_s > 0


def test_gates_read_the_typed_report_as_report_json(reports):
    report = reports[0]
    worst = report.worst_block()
    assert worst is not None and worst.max_error_um == max(b.max_error_um for b in report.blocks)
    for text in ("0", "arc=0", "linear=0.001", "1000"):
        gates = Gates(tuple(parse_error_limits(text)), 0.01)
        assert evaluate(report, gates) == evaluate(report.to_json(), gates)
    assert evaluate(report, Gates(tuple(parse_error_limits("0"))))[0]["line"] == worst.line
