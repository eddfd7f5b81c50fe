"""A long program's analysis worker is started before the program is parsed, and ended however
its run ends (sim.analysis_worker.early_worker, sim.api.run_program)."""

from __future__ import annotations

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.sim import analysis_worker, api, program, runner, stream
from tests.test_stream import PROGRAM


@pytest.fixture
def workers(monkeypatch):
    """Every ProcessAnalyser made, in order; the early worker for any program of 1 character
    or more; the worker wanted wherever the machine allows it."""
    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "1")
    if not analysis_worker.worker_wanted():
        pytest.skip("no analysis worker on this machine (one core, or not POSIX)")
    monkeypatch.setattr(analysis_worker, "EARLY_WORKER_CHARS", 1)
    made: list[analysis_worker.ProcessAnalyser] = []
    init = analysis_worker.ProcessAnalyser.__init__

    def counted(self):
        init(self)
        made.append(self)

    monkeypatch.setattr(analysis_worker.ProcessAnalyser, "__init__", counted)
    return made


def _ended(worker: analysis_worker.ProcessAnalyser) -> bool:
    return worker._pipes.proc.poll() is not None


def test_a_streamed_run_uses_the_worker_started_before_parsing(machine, monkeypatch, workers):
    """... and only that one; the report is the one analysed in the run's own process."""
    import json

    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    monkeypatch.setattr(stream, "STREAM_TICKS", 256)
    at_parse: list[int] = []
    interpret = program.interpret_program

    def parse(*args, **kwargs):
        at_parse.append(len(workers))
        return interpret(*args, **kwargs)

    monkeypatch.setattr(program, "interpret_program", parse)
    result = api.run_program(PROGRAM, machine=machine)
    assert result.streamed and at_parse == [1] and len(workers) == 1
    assert _ended(workers[0])
    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "0")
    inline = api.run_program(PROGRAM, machine=machine)
    assert len(workers) == 1
    a, b = (json.loads(json.dumps(r.report)) for r in (result, inline))
    for report in (a, b):  # the wall-clock figures aside
        report.pop("timing_s")
        report["sim"].pop("realtime_factor")
    assert a == b


def test_a_run_not_streamed_ends_its_worker_before_simulating(machine, monkeypatch, workers):
    ended_then: list[bool] = []
    simulate = runner.simulate

    def watched(*args, **kwargs):
        ended_then.append(all(_ended(w) for w in workers))
        return simulate(*args, **kwargs)

    monkeypatch.setattr(runner, "simulate", watched)
    result = api.run_program(PROGRAM, machine=machine)
    assert not result.streamed and len(workers) == 1 and ended_then == [True]


def test_a_program_refused_ends_its_worker(machine, workers):
    with pytest.raises(GcodeError, match="<program>:2: error"):
        api.run_program(PROGRAM.replace("G0 X1 Y1", "G0 X1 Y1 Q"), machine=machine)
    assert len(workers) == 1 and _ended(workers[0])


def test_a_short_program_gets_no_early_worker(monkeypatch):
    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "1")
    chars = analysis_worker.EARLY_WORKER_CHARS
    assert analysis_worker.early_worker(chars - 1) is None
    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "0")
    assert analysis_worker.early_worker(chars) is None
