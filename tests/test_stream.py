"""The streamed run (sim/stream.py) gives the whole-program run's numbers bit for bit."""

from __future__ import annotations

import math
import os
import sys
import threading
import time

import numpy as np
import pytest

from gantry_sim.controller.gcode.interpreter import interpret
from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.spill import SpilledList
from gantry_sim.sim import stream
from gantry_sim.sim.contour import analyse
from gantry_sim.sim.machine import load_gantry
from gantry_sim.sim.move_table import ProgramIndex
from gantry_sim.sim.range_rows import RowPicker
from gantry_sim.sim.runner import simulate
from gantry_sim.sim.stream import stream_run

# ~1.5 s: a rapid, a circle, short chords, a Z plunge: several ranges of 300 ticks
PROGRAM = (
    "G21 G17 G90 G94\nG0 X1 Y1\nG1 X5 Y0 F2000\nG3 I-5 J0\n"
    + "".join(f"G1 X{5 - 0.3 * i:g} Y{0.1 * (i % 2):g}\n" for i in range(1, 12))
    + "G1 Z-1\nG0 Z2\nM2\n"
)


# 500 chords of 0.04 mm on an R 20 curve at F6000 (not merged: Q0), a rapid, arcs; run on a soft
# servo without feedforward, the tool lags the reference by up to 0.7 mm, a dozen chords: the
# search walks back to them (163 ticks are nearest to a move it walked to)
LONG = (
    "G21 G17 G90 G64 P0.01 Q0\nG0 X20 Y0\nF6000\n"
    + "".join(
        f"G1 X{20 * math.cos(i / 500):.5f} Y{20 * math.sin(i / 500):.5f}\n" for i in range(1, 501)
    )
    + "G0 X30 Y0\nG1 X32 F2000\nG3 X32 Y4 I0 J2\nG2 X32 Y8 I0 J2\nG1 X20\nM2\n"
)


def _planned(machine, text=PROGRAM):
    moves = tuple(interpret(text, "linuxcnc", "t"))
    return moves, plan(moves, machine)


def test_sample_range_is_a_slice_of_sample_bit_for_bit(machine):
    _, planned = _planned(machine)
    period = machine.servo.period_s
    whole = planned.sample(period)
    n = whole.t.size
    for k0, k1 in ((0, 1), (0, 7), (5, 300), (n - 10, n), (n - 3, n + 50), (0, n)):
        part = planned.sample_range(period, k0, k1)
        for name in ("t", "pos", "vel", "acc", "line"):
            assert np.array_equal(getattr(part, name), getattr(whole, name)[k0:k1]), name


@pytest.mark.parametrize(
    ("stateful", "worker", "text"),
    [(False, "1", PROGRAM), (True, "1", PROGRAM), (False, "0", PROGRAM), (False, "1", LONG)],
)
def test_streamed_run_equals_the_whole_program_run(machine, stateful, worker, text, monkeypatch):
    from gantry_sim.sim import analysis_worker, error_tally
    from gantry_sim.sim.blend_parts import split_reference

    monkeypatch.setattr(error_tally, "TILE_TICKS", 128)  # sums over tiles cut across ranges
    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", worker)  # analysed in a worker process or here
    made = []
    make = analysis_worker.make_analyser
    monkeypatch.setattr(stream, "make_analyser", lambda *a: made.append(make(*a)) or made[-1])
    if stateful:
        machine = machine.with_changes("servo", ki_N_per_mm_s=[40.0, 40.0, 60.0]).with_changes(
            "sim", backlash_mm=[0.01, 0.02, 0.005]
        )
    if text is LONG:  # gains / 10 (kd / sqrt(10)), no feedforward
        servo = machine.servo
        machine = machine.with_changes(
            "servo",
            kp_N_per_mm=[k / 10.0 for k in servo.kp_N_per_mm],
            kd_N_s_per_mm=[k / 10.0**0.5 for k in servo.kd_N_s_per_mm],
            ff_velocity=[0.0] * 3,
            ff_acceleration=[0.0] * 3,
        )
    reached, threads, carried = [], set(), set()
    tables = RowPicker.tables

    def tables_spy(*a):
        threads.add(threading.current_thread().name)
        reached.append(len((t := tables(*a)).moves))
        carried.add(type(t.moves).__name__)
        return t

    monkeypatch.setattr(RowPicker, "tables", tables_spy)
    moves, planned = _planned(machine, text)
    gantry = load_gantry(machine)
    traj = planned.sample(machine.servo.period_s)
    sim = simulate(gantry, machine, traj)
    whole = analyse(moves, traj.line, traj.pos, sim.pos, planned.vertices, traj.source)
    whole = split_reference(whole, planned, traj)

    ranges = []
    # LONG: the lag reaches back past a range's first moves (20 ticks: 2 mm of its fitted arc
    # at the feed, 50 of its 0.04 mm moves)
    size = 20 if text is LONG else 300
    # kept on disk in blocks of 5 (as a long program's moves are, in blocks of 4,096): a
    # worker gets each range's moves as the pickled blocks that hold them, and keeps the
    # blocks two ranges share decoded
    kept = SpilledList(moves, block_items=5)
    streamed = stream_run(
        kept, planned, machine, gantry, range_ticks=size, on_range=lambda *a: ranges.append(a)
    )
    n = traj.t.size
    assert streamed.ticks == n and len(ranges) == -(-n // size) > 3
    if text is LONG:  # each range analysed against the few moves it reaches
        assert len(reached) == len(ranges) and max(reached) < len(moves) / 4
    in_process = isinstance(made[0], analysis_worker.ProcessAnalyser)
    assert in_process == (worker == "1" and os.name == "posix" and (os.cpu_count() or 1) >= 2)
    # handed to the analysis by the helper thread beside a worker process, else by the loop's
    assert [name.split("_")[0] for name in threads] == [
        "gantry-range" if in_process else "MainThread"
    ]
    assert carried == {"PickledSlice" if in_process else "list"}
    got = streamed.analysis
    assert got.contour == whole.contour and got.parts == whole.parts
    assert got.blocks == whole.blocks and sum(b.ticks for b in got.blocks) > 0
    assert got.err_um.size == got.feed.size == 0  # per-tick arrays: not kept for the whole run
    # full-rate arrays, range by range, are the whole run's
    assert [lo for lo, *_ in ranges] == list(range(0, n, size))
    cat = np.concatenate
    assert np.array_equal(cat([r[1].t for r in ranges]), traj.t)
    assert np.array_equal(cat([r[1].pos for r in ranges]), traj.pos)
    assert np.array_equal(cat([r[2] for r in ranges]), sim.pos)
    assert np.array_equal(cat([r[3] for r in ranges]), sim.force)
    assert np.array_equal(cat([r[1].line for r in ranges]), traj.line)
    assert np.array_equal(cat([r[4].err_um for r in ranges]), whole.err_um)
    assert np.array_equal(cat([r[4].feed for r in ranges]), whole.feed)
    assert np.array_equal(cat([r[4].nearest for r in ranges]), whole.nearest)
    # running figures of the forces
    assert np.array_equal(streamed.max_force_N, np.abs(sim.force).max(axis=0))
    # the decimated trace: rows of the whole trace, with each range's worst tick
    dec = streamed.decimated
    rows = np.searchsorted(traj.t, dec.t)
    assert np.array_equal(traj.t[rows], dec.t)
    assert np.array_equal(sim.pos[rows], dec.pos) and np.array_equal(whole.err_um[rows], dec.err_um)
    assert np.array_equal(traj.pos[rows], dec.ref) and np.array_equal(traj.line[rows], dec.line)
    assert np.array_equal(whole.nearest[rows], dec.nearest) and np.array_equal(
        sim.force[rows], dec.force_N
    )
    assert np.array_equal(whole.feed[rows], dec.feed)
    assert (dec.line.dtype, dec.feed.dtype) == (np.int64, np.bool_)
    assert dec.err_um.max() == whole.err_um.max()


def test_a_failure_in_the_analysis_worker_stops_the_run(machine):
    """An exception in the worker reaches the run as a RuntimeError with its traceback, and the
    worker is gone."""
    from gantry_sim.sim import analysis_worker

    if os.name != "posix":
        pytest.skip("the worker process runs on POSIX systems")
    moves, planned = _planned(machine)
    piece = planned.sample_range(machine.servo.period_s, 0, 100)
    picker = RowPicker(moves, moves, ProgramIndex.of(moves), None)
    tables = picker.tables(piece, piece.pos, 0, piece.pos)
    worker = analysis_worker.ProcessAnalyser()
    try:
        broken = np.zeros((3, 3))  # a reference context far shorter than the range
        worker.submit(analysis_worker.RangeJob(0, piece, broken, 0, piece.pos, piece.pos), tables)
        with pytest.raises(RuntimeError, match=r"analysis worker failed: .*Error"):
            worker.ready(drain=True)
    finally:
        worker.close()
    assert worker._pipes.proc.returncode is not None


def _helper_threads():
    return [t for t in threading.enumerate() if t.name.startswith("gantry-range")]


@pytest.mark.skipif(os.name != "posix", reason="the worker process runs on POSIX systems")
def test_a_run_that_fails_mid_run_stops_its_helper_and_worker(machine, monkeypatch):
    """The simulation fails while the helper thread waits on the analysis: the run raises the
    simulation's error, the worker is killed, the helper thread is gone."""
    from gantry_sim.controller.errors import SimulationError
    from gantry_sim.sim import analysis_worker

    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "1")
    made = []
    make = analysis_worker.make_analyser
    monkeypatch.setattr(stream, "make_analyser", lambda *a: made.append(make(*a)) or made[-1])
    tables = RowPicker.tables

    def slow_tables(*a):
        time.sleep(0.3)  # the hand-over is under way when the simulation fails
        return tables(*a)

    monkeypatch.setattr(RowPicker, "tables", slow_tables)
    real = stream.simulate_pieces

    def failing(*a, **k):
        for k_range, item in enumerate(real(*a, **k)):
            if k_range == 2:
                raise SimulationError("diverged", line=3)
            yield item

    monkeypatch.setattr(stream, "simulate_pieces", failing)
    moves, planned = _planned(machine)
    with pytest.raises(SimulationError, match="diverged"):
        stream_run(moves, planned, machine, load_gantry(machine), range_ticks=200)
    if not isinstance(made[0], analysis_worker.ProcessAnalyser):
        pytest.skip("one core: no worker, no helper thread")
    assert made[0]._pipes.proc.returncode is not None and not _helper_threads()


def test_a_failed_hand_over_stops_the_run(machine, monkeypatch):
    """An error while a range is handed to the analysis (here: laying out its tables) reaches
    the run, on the helper thread or not."""
    tables = RowPicker.tables
    calls = []

    def broken(*a):
        calls.append(1)
        if len(calls) == 2:
            raise ValueError("no tables for this range")
        return tables(*a)

    monkeypatch.setattr(RowPicker, "tables", broken)
    moves, planned = _planned(machine)
    with pytest.raises(ValueError, match="no tables"):
        stream_run(moves, planned, machine, load_gantry(machine), range_ticks=200)
    assert not _helper_threads()


def test_run_program_streams_long_runs_with_the_same_outputs(machine, monkeypatch, tmp_path):
    """run_program streams a run beyond STREAM_ABOVE_TICKS: report.json (bar the wall-clock
    timings) and trace.npz equal the whole-program run's bit for bit; the RunResult's trace is
    decimated rows of the whole one."""
    import json

    from gantry_sim.sim import api, error_tally, stream

    monkeypatch.setattr(error_tally, "TILE_TICKS", 100)  # sums over tiles cut across ranges
    whole = api.run_program(PROGRAM, machine=machine)
    api.write_run_outputs(whole, tmp_path / "whole", plots=False, deterministic=True)
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    monkeypatch.setattr(stream, "STREAM_TICKS", 256)
    monkeypatch.setattr(stream, "DECIMATED_TICKS", 100)
    streamed = api.run_program(PROGRAM, machine=machine)
    assert streamed.streamed and streamed.full_trace is not None and not whole.streamed
    assert streamed.trace.t.size < whole.trace.t.size / 5
    api.write_run_outputs(streamed, tmp_path / "streamed", plots=True, deterministic=True)
    a, b = (json.loads((tmp_path / d / "report.json").read_text()) for d in ("whole", "streamed"))
    assert set(b["timing_s"]) - set(a["timing_s"]) == {"trace"}
    a.pop("timing_s")
    b.pop("timing_s")
    assert a.pop("files") == ["report.json", "timing.json", "trace.npz"]  # plots=False
    assert b.pop("files") == ["report.json", "timing.json", "trace.npz", "path.png", "error.png"]
    assert a == b
    with (
        np.load(tmp_path / "whole" / "trace.npz") as x,
        np.load(tmp_path / "streamed" / "trace.npz") as y,
    ):
        assert sorted(x.files) == sorted(y.files)
        for name in x.files:
            assert x[name].dtype == y[name].dtype and np.array_equal(x[name], y[name]), name
    assert (tmp_path / "streamed" / "path.png").stat().st_size > 0


def _cli_run(tmp_path, name, flags, capsys):
    """`gantry run` of PROGRAM into tmp_path/name -> (report.json, sorted file names, stdout)."""
    import json

    from gantry_sim.sim.cli import main

    program = tmp_path / "p.ngc"
    program.write_text(PROGRAM)
    out = tmp_path / name
    assert main(["run", str(program), "--out", str(out), "--deterministic", *flags]) == 0
    said = capsys.readouterr().out
    return (
        json.loads((out / "report.json").read_text()),
        sorted(p.name for p in out.iterdir()),
        said,
    )


def test_a_streamed_runs_stages_add_up_to_its_set_up_too(machine, monkeypatch):
    """The model's load (and the rest of the set-up before the first range) counts in a
    streamed run's "simulate" stage, as in the whole-program run's: the stages add up to the
    total. (The load is slowed by a known 0.3 s here: it must show in "simulate".)"""
    from gantry_sim.sim import api
    from gantry_sim.sim import machine as machine_module

    real = machine_module.load_gantry

    def slow_load(*args, **kwargs):
        time.sleep(0.3)
        return real(*args, **kwargs)

    monkeypatch.setattr(machine_module, "load_gantry", slow_load)
    monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
    run = api.run_program(PROGRAM, machine=machine, plots=False)
    timing = run.run_report.timing_s
    assert run.streamed
    assert timing["simulate"] >= 0.3
    stages = sum(v for k, v in timing.items() if k != "total")
    assert timing["total"] == pytest.approx(stages, rel=1e-9)


@pytest.mark.parametrize("streamed", [False, True])
def test_no_trace_writes_everything_but_trace_npz(streamed, monkeypatch, tmp_path, capsys):
    """--no-trace: no trace.npz (and no staging trace in a streamed run); report.json lists
    the files written in "files" and is otherwise the traced run's; the plots are drawn."""
    from gantry_sim.sim import api, stream, trace_writer

    if streamed:
        monkeypatch.setattr(api, "STREAM_ABOVE_TICKS", 0)
        monkeypatch.setattr(stream, "STREAM_TICKS", 256)
    traced, names, _ = _cli_run(tmp_path, "traced", [], capsys)
    assert names == ["error.png", "path.png", "report.json", "timing.json", "trace.npz"]
    assert traced["files"] == ["report.json", "timing.json", "trace.npz", "path.png", "error.png"]

    def no_staging(*args):
        raise AssertionError("a --no-trace run staged a trace")

    monkeypatch.setattr(trace_writer.TraceWriter, "__init__", no_staging)
    bare, names, said = _cli_run(tmp_path, "bare", ["--no-trace"], capsys)
    assert names == ["error.png", "path.png", "report.json", "timing.json"]
    assert bare["files"] == ["report.json", "timing.json", "path.png", "error.png"]
    assert "path.png, error.png (no trace.npz: --no-trace)" in said
    assert "trace.npz," not in said
    traced.pop("files")
    bare.pop("files")
    assert traced == bare


def test_the_worker_takes_ranges_larger_than_the_pipe_buffer():
    """Each range and each reply is larger than a pipe's buffer (64 KB on Linux): sending a
    range while the worker is sending its reply would block both processes (a deadlock the
    alarm turns into a failure); the results are those of the inline analysis."""
    import signal

    from gantry_sim.controller.trajectory import Trajectory
    from gantry_sim.sim import analysis_worker

    if os.name != "posix":
        pytest.skip("the worker process runs on POSIX systems")
    moves = tuple(interpret("G1 X100 F6000\nG3 X100 Y20 I0 J10\nM2\n", "linuxcnc", "t"))
    picker = RowPicker(moves, moves, ProgramIndex.of(moves), None)
    n = 20_000
    rng = np.random.default_rng(0)
    jobs = []
    for k in range(4):
        x = np.linspace(0, 100, n + 2 * 50)
        ref = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
        pos = ref[50:-50] + rng.normal(scale=1e-3, size=(n, 3))
        line = np.where(np.arange(n) < n // 2 + 100 * k, 1, 2)
        piece = Trajectory(
            t=np.arange(n) * 1e-3,
            pos=ref[50:-50],
            vel=ref[50:-50],
            acc=ref[50:-50],
            line=line,
            period_s=1e-3,
        )
        job = analysis_worker.RangeJob(k * n, piece, ref, 50, pos, pos)
        jobs.append((job, picker.tables(piece, ref, 50, pos)))

    def hang(*_):
        raise TimeoutError("the analysis worker and the run blocked each other")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(20)
    worker = analysis_worker.ProcessAnalyser()
    try:
        got = []
        for job, tables in jobs:
            worker.submit(job, tables)
            got += worker.ready()
        got += worker.ready(drain=True)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        worker.close()
    # every result was in: the worker is killed, not waited for while it tears down its heap
    assert worker._pipes.proc.returncode == -signal.SIGKILL
    inline = analysis_worker.InlineAnalyser()
    for job, tables in jobs:
        inline.submit(job, tables)
    expect = inline.ready(drain=True)
    assert [g[0].lo for g in got] == [e[0].lo for e in expect] == [0, n, 2 * n, 3 * n]
    for (_, a, pa), (_, b, pb) in zip(got, expect, strict=True):
        assert np.array_equal(a.err_um, b.err_um) and np.array_equal(a.nearest, b.nearest)
        assert (a.reference_max_um, a.tracking_max_um, pa) == (
            b.reference_max_um,
            b.tracking_max_um,
            pb,
        )


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="/proc")
def test_a_streamed_run_killed_mid_run_leaves_nothing_in_tmpdir(tmp_path):
    """kill -9 of a streamed run while it simulates: its temporary files (the deflating trace,
    the spilled errors, the plan's blocks) were anonymous, so $TMPDIR is left as it was."""
    import signal
    import subprocess
    import sys
    import time

    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    program = tmp_path / "p.ngc"
    program.write_text("G21 G90\nG0 X-200\nG1 X200 F400\nM2\n")  # 60 s: 60,000 ticks
    script = (
        "import sys; from gantry_sim.sim import api, stream; from gantry_sim.sim.cli import main\n"
        "api.STREAM_ABOVE_TICKS = 0; stream.STREAM_TICKS = 512\n"
        "sys.exit(main(sys.argv[1:]))"
    )
    argv = [sys.executable, "-c", script, "run", str(program), "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(argv, env=dict(os.environ, TMPDIR=str(tmpdir)))
    fds = f"/proc/{proc.pid}/fd"
    try:
        deadline = time.monotonic() + 60
        while proc.poll() is None and time.monotonic() < deadline:
            try:
                links = [os.readlink(f"{fds}/{fd}") for fd in os.listdir(fds)]
            except OSError:
                links = []  # an fd closed while listed
            if sum(link.startswith(str(tmpdir)) for link in links) >= 6:  # trace members
                break
            time.sleep(0.005)
        assert proc.poll() is None, "the run ended before its trace was being written"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert sorted(p.name for p in tmpdir.iterdir()) == []


def test_a_range_crosses_to_the_worker_with_the_moves_it_reaches():
    """A range of a long program goes to the worker with the few moves it reaches (their
    tables laid out there), not the program's tables; its arrays go out of band and arrive
    writable (at 100,000 moves the whole tables were 57 MB, sent once and held by the worker;
    pickling them in one piece held 126 MB more at the run's start)."""
    import pickle
    import threading
    from multiprocessing import Pipe

    from gantry_sim.controller.trajectory import Trajectory
    from gantry_sim.sim.worker_pipes import recv_out_of_band, send_out_of_band

    text = "G21 G17\n" + "".join(f"G1 X{i % 97} Y{i % 89} F900\n" for i in range(3000))
    moves = tuple(interpret(text + "G2 I5 J5\nM2\n", "linuxcnc", "t"))
    picker = RowPicker(
        moves, moves, ProgramIndex.of(moves), np.repeat(np.arange(3001), 2).reshape(-1, 2)
    )
    n = 2000
    src = np.repeat(np.arange(1000, 1010), n // 10)
    ref = np.linspace(moves[1000].start, moves[1009].end, n)
    piece = Trajectory(np.arange(n) * 1e-3, ref, ref, ref, src + 2, 1e-3, np.stack([src, src], 1))
    tables = picker.tables(piece, ref, 0, ref + 1e-4)
    assert 10 <= len(tables.moves) <= 16 and tables.r0 >= 995
    assert len(tables.path_moves) <= 16 and tables.path_window is not None
    job = (tables, piece.line, piece.source, ref + 1e-4, ref, 0)
    reader, writer = Pipe(duplex=False)
    sizes: list[int] = []

    class Recording:  # the real pipe's end, noting the size of every message
        def send(self, obj: object) -> None:
            sizes.append(len(pickle.dumps(obj)))
            writer.send(obj)

        def send_bytes(self, buf) -> None:
            writer.send_bytes(buf)

    sender = threading.Thread(target=send_out_of_band, args=(Recording(), job))
    sender.start()
    got = recv_out_of_band(reader)
    sender.join()
    assert got[0].moves == tables.moves and got[0].r0 == tables.r0
    for a, b in zip(job[1:5], got[1:5], strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
        assert b.flags.writeable or not a.flags.writeable
    assert max(sizes) < 20_000 and ref.nbytes > 40_000


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread nice: Linux")
def test_the_trace_is_deflated_at_background_priority():
    """The deflating thread yields the core to the servo loop (controller.forked
    .lower_priority); the loop's own thread keeps its priority."""
    from gantry_sim.controller.forked import BACKGROUND_NICE
    from gantry_sim.sim.trace_writer import TraceWriter

    mine = os.getpriority(os.PRIO_PROCESS, 0)
    writer = TraceWriter(0)
    try:
        tid = writer._thread.native_id
        deadline = time.monotonic() + 10
        while os.getpriority(os.PRIO_PROCESS, tid) < BACKGROUND_NICE:
            assert time.monotonic() < deadline, "the deflating thread kept its priority"
            time.sleep(0.01)
        assert os.getpriority(os.PRIO_PROCESS, 0) == mine
    finally:
        writer.close()


def test_a_run_is_cut_into_eight_ranges_or_ranges_of_the_least_size(machine, monkeypatch):
    """The last range's analysis is not overlapped by any simulation: a run is cut into
    MIN_RANGES ranges at least (of MIN_RANGE_TICKS at least, STREAM_TICKS at most), the last
    of them in halves down to END_TICKS."""
    moves, planned = _planned(machine)
    n = planned.sample_count(machine.servo.period_s)
    gantry = load_gantry(machine)

    def starts():
        ranges = []
        stream_run(moves, planned, machine, gantry, on_range=lambda lo, *a: ranges.append(lo))
        return ranges

    monkeypatch.setattr(stream, "END_TICKS", n)  # the last range kept whole
    monkeypatch.setattr(stream, "MIN_RANGE_TICKS", 100)
    size = -(-n // stream.MIN_RANGES)
    assert starts() == list(range(0, n, size)) and len(starts()) == stream.MIN_RANGES
    monkeypatch.setattr(stream, "MIN_RANGE_TICKS", n // 3)
    assert starts() == list(range(0, n, n // 3))
    monkeypatch.setattr(stream, "STREAM_TICKS", n // 5)
    assert starts() == list(range(0, n, n // 5))
    size = n // 4 + 1  # four ranges, the last of n - 3 size ticks, cut in 3 (END_TICKS n / 23)
    monkeypatch.setattr(stream, "STREAM_TICKS", size)
    monkeypatch.setattr(stream, "END_TICKS", n // 23)
    last = n - 3 * size
    half = last // 2
    quarter = (last - half) // 2
    assert starts() == [0, size, 2 * size, 3 * size, 3 * size + half, 3 * size + half + quarter]


@pytest.mark.parametrize(
    ("n", "size", "end", "sizes"),
    [
        (160_000, 40_000, 5_000, [40_000] * 3 + [20_000, 10_000, 5_000, 5_000]),
        (150_001, 40_000, 5_000, [40_000] * 3 + [15_000, 7_500, 7_501]),
        (100, 40, 10, [40, 40, 10, 10]),
        (50, 40, 10, [40, 10]),
        (19, 40, 10, [19]),
        (20, 40, 10, [10, 10]),
        (0, 40, 10, []),
    ],
)
def test_range_bounds_cover_the_run_and_halve_its_last_range(n, size, end, sizes):
    bounds = stream.range_bounds(n, size, end)
    assert [hi - lo for lo, hi in bounds] == sizes
    assert [lo for lo, _ in bounds[1:]] == [hi for _, hi in bounds[:-1]]
    assert not bounds or (bounds[0][0], bounds[-1][1]) == (0, n)


def test_no_worker_process_inside_one_process(monkeypatch):
    """A sweep runs one point per core (controller.forked.one_process): its streamed runs
    analyse in their own process."""
    from gantry_sim.controller.forked import one_process
    from gantry_sim.sim import analysis_worker

    monkeypatch.setenv("GANTRY_ANALYSIS_WORKER", "1")
    with one_process():
        analyser = analysis_worker.make_analyser()
    try:
        assert isinstance(analyser, analysis_worker.InlineAnalyser)
    finally:
        analyser.close()
