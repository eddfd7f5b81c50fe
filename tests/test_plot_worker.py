"""The plots drawn by the run's plot worker (sim.plot_worker) are the run's own, byte for byte;
the run draws them itself when the worker fails; the worker is started where it pays and ends
however the run ends."""

from __future__ import annotations

import gc
from pathlib import Path

import pytest

from gantry_sim.controller.errors import GcodeError
from gantry_sim.sim import api, plot_worker, program, worker_pipes
from gantry_sim.sim.gates import ErrorLimit, Gates
from gantry_sim.sim.path_outline import outline
from gantry_sim.sim.plot_files import drawn_fields
from gantry_sim.sim.plot_worker import PlotRequest, PlotWorker

CIRCLE = "G21 G17 G90 G94\nG1 X5 F3000\nG3 I-5 J0\nG1 X0\nM2\n"
#: a gate on a kind of move: error.png draws it where the arcs run (Gates.line_kinds)
PNGS = ("path.png", "error.png")
GATES = Gates(errors=(ErrorLimit(limit_um=2.0), ErrorLimit(limit_um=3.0, kind="arc")))


@pytest.fixture
def workers(monkeypatch):
    """Every PlotWorker made, in order; the worker wanted wherever the machine allows it."""
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "1")
    if not worker_pipes.worker_wanted("GANTRY_PLOT_WORKER"):
        pytest.skip("no plot worker on this machine (one core, or not POSIX)")
    made: list[PlotWorker] = []
    init = PlotWorker.__init__

    def counted(self):
        init(self)
        made.append(self)

    monkeypatch.setattr(PlotWorker, "__init__", counted)
    return made


@pytest.fixture
def waits(monkeypatch):
    """Whether each PlotWorker.wait had the PNG files' bytes (True) or not (False: drawn here)."""
    seen: list[bool] = []
    real = PlotWorker.wait

    def spy(self):
        got = real(self)
        seen.append(got is not None)
        return got

    monkeypatch.setattr(PlotWorker, "wait", spy)
    return seen


def _ended(worker: PlotWorker) -> bool:
    return worker._pipes is not None and worker._pipes.proc.poll() is not None


def _pngs(folder: Path) -> dict[str, bytes]:
    """The plots, and report.json (written while the worker draws: RunReport.write_json_start;
    the runs here are deterministic, so its text is the same)."""
    return {name: (folder / name).read_bytes() for name in (*PNGS, "report.json")}


def _run(machine, folder: Path, *, worker: bool, text: str = CIRCLE) -> dict[str, bytes]:
    result = api.run_program(text, file="c.ngc", machine=machine, plots=worker)
    api.write_run_outputs(result, folder, deterministic=True, gates=GATES)
    return _pngs(folder)


def test_the_worker_draws_the_files_the_run_draws(machine, tmp_path, workers, waits):
    drawn = _run(machine, tmp_path / "worker", worker=True)
    assert len(workers) == 1 and waits == [True]  # drawn there, not here after a failure
    assert workers[0].outline_kept  # path.png's outline computed there too
    assert _ended(workers[0])  # one set of plots: closed once written
    here = _run(machine, tmp_path / "here", worker=False)
    assert len(workers) == 1 and waits == [True]  # no worker asked for
    assert drawn == here
    assert all(here[png].startswith(b"\x89PNG") and len(here[png]) > 10_000 for png in PNGS)
    assert b'"write": null' in here["report.json"]  # deterministic: no wall-clock times


def test_a_streamed_run_hands_its_decimated_trace_to_the_worker(
    machine, tmp_path, monkeypatch, workers, waits
):
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)  # the circle streamed, range by range
    monkeypatch.setattr(plot_worker, "EARLY_WORKER_CHARS", 1)  # started after the parse
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True)
    assert result.streamed and result.plotter is workers[0]
    api.write_run_outputs(result, tmp_path / "worker", deterministic=True, gates=GATES)
    assert waits == [True] and _ended(workers[0])
    assert _pngs(tmp_path / "worker") == _run(machine, tmp_path / "here", worker=False)


def test_a_dead_worker_leaves_the_plots_to_the_run(machine, tmp_path, workers, waits):
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True)
    assert result.plotter is workers[0]
    proc = workers[0]._pipes.proc
    proc.kill()
    proc.wait()
    api.write_run_outputs(result, tmp_path / "a", deterministic=True, gates=GATES)
    assert waits in ([False], [])  # its pipe broke at the request, or no reply came
    assert _pngs(tmp_path / "a") == _run(machine, tmp_path / "b", worker=False)


def test_a_drawing_that_fails_in_the_worker_is_reported_to_the_run(workers):
    worker = PlotWorker()
    worker.start()
    bad = PlotRequest(None, "x", None, None, None, {})  # type: ignore[arg-type]
    try:
        assert worker.draw(bad)
        assert not worker.draw(bad)  # one request a worker
        assert worker.wait() is None  # its reply is the traceback, not the files
    finally:
        worker.close()
    assert _ended(worker)
    assert not worker.draw(bad) and worker.wait() is None


def test_an_outline_that_fails_in_the_worker_leaves_the_plots_to_the_run(workers):
    """The moves' blocks do not decode in the worker: the request that needs their outline is
    answered with the error, so the run draws both files itself."""
    from gantry_sim.controller.pickled_slice import PickledSlice

    worker = PlotWorker()
    worker.start()
    try:
        assert worker.send_outline(PickledSlice(1, 0, (b"not a pickle",), 1, 0, 3, 4))
        assert not worker.send_outline(PickledSlice(1, 0, (), 0, 0, 0, 4))  # one outline a worker
        assert worker.outline_kept
        request = PlotRequest(None, "x", None, None, None, {}, outline_kept=True)  # type: ignore[arg-type]
        assert worker.draw(request)
        assert worker.wait() is None
    finally:
        worker.close()


def test_a_worker_outliving_its_run_writes_nothing(machine, tmp_path, workers):
    """The worker sends the files' bytes back; the run writes them (sim.outdir's staging)."""
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True)
    request = PlotRequest(
        result.trace,
        "c.ngc",
        result.run_report.contour_error_um,
        result.outline.result(timeout=30) if result.outline is not None else None,
        None,
        {},
    )
    before = sorted(p for p in tmp_path.rglob("*"))
    assert workers[0].draw(request)
    path_png, error_png = workers[0].wait() or (b"", b"")
    assert path_png.startswith(b"\x89PNG") and error_png.startswith(b"\x89PNG")
    assert sorted(p for p in tmp_path.rglob("*")) == before
    result.plotter.close()  # type: ignore[union-attr]


def test_no_plots_no_worker_and_a_closed_worker(machine, tmp_path, workers):
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True)
    api.write_run_outputs(result, tmp_path / "out", plots=False)
    assert _ended(workers[0])
    assert not (tmp_path / "out" / "path.png").exists()
    unknown = api.run_program(CIRCLE, file="c.ngc", machine=machine)  # plots=None
    assert len(workers) == 1 and unknown.outline is not None  # prepared in a thread here
    none = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=False)
    assert len(workers) == 1 and none.outline is None and none.plotter is None
    # --no-plots prepares nothing, and the plots can still be drawn when asked for
    api.write_run_outputs(none, tmp_path / "late", deterministic=True, gates=GATES)
    api.write_run_outputs(unknown, tmp_path / "thread", deterministic=True, gates=GATES)
    assert _pngs(tmp_path / "late") == _pngs(tmp_path / "thread")


def test_the_worker_ends_when_the_run_fails_or_its_result_is_dropped(machine, workers):
    with pytest.raises(GcodeError, match=r"c\.ngc:2: error"):
        api.run_program(
            CIRCLE.replace("G1 X5", "G1 X5 Q"), file="c.ngc", machine=machine, plots=True
        )
    assert len(workers) == 1 and _ended(workers[0])
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True)
    proc = workers[1]._pipes.proc
    assert proc.poll() is None
    workers.clear()  # the only references left are the result's
    del result
    gc.collect()
    assert proc.wait(timeout=10) is not None


def test_a_long_program_starts_its_worker_after_its_parse(machine, monkeypatch, workers):
    """Before the parse for a short program (its imports overlap the run's own), after it for
    a long one (beside the analysis worker's start, it slowed the parse)."""
    events: list[str] = []
    start, interpret = PlotWorker.start, program.interpret_program

    def started(self):
        if self._pipes is None:
            events.append("worker")
        start(self)

    def parsed(*args, **kwargs):
        events.append("parse")
        return interpret(*args, **kwargs)

    monkeypatch.setattr(PlotWorker, "start", started)
    monkeypatch.setattr(program, "interpret_program", parsed)
    for chars, order in (
        (len(CIRCLE) + 1, ["worker", "parse"]),
        (len(CIRCLE), ["parse", "worker"]),
    ):
        monkeypatch.setattr(plot_worker, "EARLY_WORKER_CHARS", chars)
        events.clear()
        api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=True).plotter.close()  # type: ignore[union-attr]
        assert events == order


def test_no_worker_where_it_cannot_pay(monkeypatch):
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "0")
    assert plot_worker.early_plot_worker(CIRCLE) is None
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "1")
    from gantry_sim.controller.forked import one_process

    with one_process():  # a sweep's point: one process per core already
        assert plot_worker.early_plot_worker(CIRCLE) is None


def test_gantry_run_starts_the_worker_first_and_no_plots_none(tmp_path, workers, waits, capsys):
    from gantry_sim.sim.cli import main

    prog = tmp_path / "c.ngc"
    prog.write_text(CIRCLE)
    assert main(["run", str(prog), "--out", str(tmp_path / "a")]) == 0
    assert len(workers) == 1 and waits == [True] and _ended(workers[0])
    assert main(["run", str(prog), "--out", str(tmp_path / "b"), "--no-plots"]) == 0
    assert len(workers) == 1 and not (tmp_path / "b" / "path.png").exists()
    # refused before the run starts: the worker started for it ends with the command
    assert main(["run", str(prog), "--out", str(tmp_path / "c"), "--feed-override", "0"]) == 2
    assert "--feed-override" in capsys.readouterr().err
    assert len(workers) == 2 and _ended(workers[1])


def test_gantry_ballbar_draws_polar_png_in_the_worker(tmp_path, monkeypatch, workers, waits):
    from gantry_sim.sim.cli import main

    args = ["ballbar", "--radius", "5", "--feed", "2000", "--json"]
    assert main([*args, "--out", str(tmp_path / "w")]) == 0
    assert len(workers) == 1 and waits == [True] and _ended(workers[0])
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "0")
    assert main([*args, "--out", str(tmp_path / "here")]) == 0
    assert len(workers) == 1  # none made: drawn here
    for name in ("polar.png", "ballbar.json"):
        assert (tmp_path / "w" / name).read_bytes() == (tmp_path / "here" / name).read_bytes()


def test_a_dead_worker_leaves_polar_png_to_the_command(machine, tmp_path, workers, waits):
    from gantry_sim.sim.circular.ballbar import run_ballbar, write_ballbar_outputs

    result = run_ballbar(machine, "XY", 5.0, 2000.0, plots_elsewhere=True)
    assert result.run.plotter is None and result.run.outline is None  # nothing prepared
    worker = plot_worker.started_plot_worker()
    assert worker is not None
    worker._pipes.proc.kill()  # type: ignore[union-attr]
    write_ballbar_outputs(result, tmp_path / "a", worker)
    worker.close()
    write_ballbar_outputs(result, tmp_path / "b")
    assert waits in ([False], [])
    assert (tmp_path / "a" / "polar.png").read_bytes() == (
        tmp_path / "b" / "polar.png"
    ).read_bytes()


def test_no_worker_without_an_interpreter_to_start(monkeypatch):
    """An application embedding Python may have no sys.executable: the plots are drawn here."""
    monkeypatch.setenv("GANTRY_PLOT_WORKER", "1")
    monkeypatch.setattr(worker_pipes.sys, "executable", "")
    assert plot_worker.early_plot_worker(CIRCLE) is None
    assert not worker_pipes.worker_wanted("GANTRY_ANALYSIS_WORKER")


def test_the_plots_draw_nothing_of_what_the_worker_is_not_sent(machine):
    """The request leaves out the trace's reference and drive forces (48 bytes a tick); the
    plots drawn without them are the plots of the whole trace, byte for byte."""
    result = api.run_program(CIRCLE, file="c.ngc", machine=machine, plots=False)
    whole = result.trace
    slim = drawn_fields(whole)
    assert slim.ref.shape == (0, 3) and slim.force_N.shape == (0, 3) and len(whole.ref) > 500
    assert all(getattr(slim, f) is getattr(whole, f) for f in ("t", "pos", "line", "err_um"))

    def drawn(trace):
        return PlotRequest(
            trace, "c.ngc", result.run_report.contour_error_um, outline(result.moves), GATES, {}
        ).render()

    assert drawn(slim) == drawn(whole)


def test_the_outline_from_pickled_blocks_is_the_moves_outline():
    """The worker's outline, its moves' blocks decoded as it reaches them, is the outline of
    the moves, cut into blocks anywhere."""
    import pickle

    import numpy as np

    from gantry_sim.controller.gcode.interpreter import parse_program
    from gantry_sim.controller.spill import SpilledList
    from gantry_sim.sim.plot_worker import OutlineRequest

    moves = parse_program(CIRCLE.replace("M2\n", "G0 X9\nG1 Y2\nG2 X11 Y4 I2\nG1 X12\nM2\n"))
    expect = outline(moves)
    for block in (1, 2, 3, 100):
        kept = SpilledList(moves, block_items=block)
        request = pickle.loads(pickle.dumps(OutlineRequest(kept.pickled(0, len(kept)))))
        got = request.outline()
        assert got is not None and got.planes == expect.planes
        assert np.array_equal(got.feed, expect.feed, equal_nan=True)
        assert np.array_equal(got.rapid, expect.rapid, equal_nan=True)
