"""Work split over forked processes: the same results as one process, failures redone here."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import gantry_sim.controller.planner.chain_plan as chain_plan
from gantry_sim.controller import forked
from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.forked import (
    BACKGROUND_NICE,
    Background,
    fork_map,
    lower_priority,
    one_process,
    process_count,
)
from gantry_sim.controller.gcode.interpreter import parse_program
from gantry_sim.controller.planner import plan
from gantry_sim.models import DEFAULT_MACHINE
from tests.fork_helpers import (
    children,
    linux,
    no_child_left_behind,  # noqa: F401 (an autouse fixture)
    square_and_pid,
)
from tests.plan_helpers import count_fork_runs

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@linux
def test_parts_after_the_first_run_in_other_processes_in_order() -> None:
    out = fork_map(square_and_pid, [1, 2, 3, 4])
    assert [v for v, _ in out] == [1, 4, 9, 16]
    assert out[0][1] == os.getpid()
    others = {pid for _, pid in out[1:]}
    assert os.getpid() not in others and len(others) == 3


@linux
def test_an_exception_in_a_child_is_raised_here_as_a_sequential_run_raises_it() -> None:
    def fn(x: int) -> int:
        if x == 3:
            raise ValueError("part three is wrong")
        return x

    with pytest.raises(ValueError, match="part three is wrong"):
        fork_map(fn, [1, 2, 3])


@linux
def test_a_child_that_dies_has_its_part_computed_here() -> None:
    parent = os.getpid()

    def fn(x: int) -> tuple[int, int]:
        if os.getpid() != parent:
            os._exit(7)  # killed, out of memory...: no result arrives
        return x + 1, os.getpid()

    assert fork_map(fn, [1, 2, 3]) == [(2, parent), (3, parent), (4, parent)]


@linux
def test_a_failing_parent_part_leaves_no_child_behind() -> None:
    parent = os.getpid()

    def fn(x: int) -> int:
        if os.getpid() == parent:
            raise KeyError(x)
        return x

    with pytest.raises(KeyError):
        fork_map(fn, [0, 1, 2])


@linux
def test_background_work_runs_in_a_child_while_this_process_goes_on(monkeypatch) -> None:
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    started = time.perf_counter()
    job = Background(lambda: (time.sleep(0.3), os.getpid())[1])
    assert time.perf_counter() - started < 0.25  # not waited for here
    assert job.result() not in (os.getpid(), None)
    assert job.result() == job.result()  # taken once, kept


@linux
def test_background_work_whose_child_dies_or_fails_is_done_here(monkeypatch) -> None:
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    parent = os.getpid()

    def dies() -> int:
        if os.getpid() != parent:
            os._exit(7)
        return 42

    assert Background(dies).result() == 42

    def fails() -> int:
        raise ValueError(f"wrong in {'a child' if os.getpid() != parent else 'the parent'}")

    with pytest.raises(ValueError, match="wrong in the parent"):  # the parent's own exception
        Background(fails).result()


@linux
def test_background_work_not_taken_is_stopped_and_one_process_forks_nothing(monkeypatch) -> None:
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    job = Background(lambda: time.sleep(30))
    assert len(children()) >= 1
    started = time.perf_counter()
    job.close()  # killed and reaped (the autouse fixture checks no child is left)
    assert time.perf_counter() - started < 5
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")
    calls: list[int] = []
    job = Background(lambda: calls.append(os.getpid()) or len(calls))
    assert calls == []  # computed when asked for, here
    assert job.result() == 1 and calls == [os.getpid()]


@linux
def test_background_work_yields_the_core_and_this_process_keeps_its_priority(monkeypatch) -> None:
    import threading

    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "2")
    mine = os.getpriority(os.PRIO_PROCESS, 0)
    child = Background(lambda: os.getpriority(os.PRIO_PROCESS, 0)).result()
    assert child >= BACKGROUND_NICE and child >= mine
    import gc

    assert Background(gc.isenabled).result() is False and gc.isenabled()  # none in the child
    parent = os.getpid()

    def redone_here() -> int:
        if os.getpid() != parent:
            os._exit(3)
        return os.getpriority(os.PRIO_PROCESS, 0)

    assert Background(redone_here).result() == mine  # the parent's own priority, untouched
    seen: list[int] = []

    def in_thread() -> None:
        lower_priority()
        seen.append(os.getpriority(os.PRIO_PROCESS, 0))

    t = threading.Thread(target=in_thread)
    t.start()
    t.join()
    assert seen[0] >= BACKGROUND_NICE and os.getpriority(os.PRIO_PROCESS, 0) == mine


@linux
def test_background_work_never_raises_a_thread_s_priority() -> None:
    """A thread already nicer than BACKGROUND_NICE (a run under ``nice -n 19``) keeps its
    value: lower_priority only lowers."""
    import threading

    seen: list[int] = []

    def in_thread() -> None:
        tid = threading.get_native_id()
        nicer = max(os.getpriority(os.PRIO_PROCESS, tid), BACKGROUND_NICE + 5)
        os.setpriority(os.PRIO_PROCESS, tid, nicer)
        lower_priority()
        seen.extend((nicer, os.getpriority(os.PRIO_PROCESS, tid)))

    t = threading.Thread(target=in_thread)
    t.start()
    t.join()
    assert seen[0] == seen[1] > BACKGROUND_NICE


def test_the_process_count_follows_the_environment_and_one_process(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "3")
    assert process_count() == (3 if sys.platform.startswith("linux") else 1)
    with one_process():
        assert process_count() == 1
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "0")
    assert process_count() == 1
    monkeypatch.delenv("GANTRY_PLAN_WORKERS")
    assert 1 <= process_count() <= forked.MAX_PROCESSES


def _curve_bytes(p) -> list[bytes]:  # type: ignore[no-untyped-def]
    return [np.ascontiguousarray(a).tobytes() for ax in p.curve.axes for a in ax]


@linux
@pytest.mark.parametrize("name", ["pocket_tangent_arcs.ngc", "side_planes.ngc"])
def test_a_plan_split_over_processes_is_the_same_bit_for_bit(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    machine = load_machine_config(DEFAULT_MACHINE)
    moves = parse_program((EXAMPLES / name).read_text())
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "1")
    alone = plan(moves, machine)
    calls = count_fork_runs(monkeypatch, chain_plan)
    monkeypatch.setattr(chain_plan, "FORK_WORK", 2)
    monkeypatch.setattr(chain_plan, "WAVE_WORK", 40)
    monkeypatch.setattr(chain_plan, "RUN_WORK", 1)
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "3")
    split = plan(moves, machine)
    assert len(calls) > 1 and max(n for n, _ in calls) > 1  # the split path ran, in waves
    assert split.duration_s == alone.duration_s
    assert np.array_equal(split.move_start_s, alone.move_start_s)
    assert split.ruckig_piece_count == alone.ruckig_piece_count
    assert _curve_bytes(split) == _curve_bytes(alone)


def test_a_wave_is_cut_into_contiguous_runs_of_about_the_run_work() -> None:
    """Every chain once, in order, in runs of at least RUN_WORK (the last may be less), none
    longer than it needs to be."""
    work = [10 + (i % 7) * 30 for i in range(2000)]
    chains = [((i, i + 1, 0.0, 0.0), i) for i in range(2000)]
    runs = chain_plan._runs(chains, work)  # type: ignore[arg-type]
    assert [c for run in runs for c in run] == chains
    sizes = [sum(work[i] for _, i in run) for run in runs]
    assert all(s >= chain_plan.RUN_WORK for s in sizes[:-1])
    assert all(
        s - work[run[-1][1]] < chain_plan.RUN_WORK for s, run in zip(sizes, runs, strict=True)
    )


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (an orphan's zombie waits for init to reap it)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


@linux
def test_a_child_dies_with_its_parent() -> None:
    """kill -9 of the process that forked: its children stop at once, not after their part."""
    import signal
    import subprocess
    import time

    script = "import time\nfrom gantry_sim.controller.forked import fork_map\n"
    script += "fork_map(time.sleep, [30.0, 30.0])\n"
    proc = subprocess.Popen([sys.executable, "-c", script])
    kids: list[int] = []
    try:
        deadline = time.monotonic() + 20
        while not kids and time.monotonic() < deadline:
            listed = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
            kids = [int(k) for k in listed]
            time.sleep(0.01)
        assert kids, "the child was not forked"
        time.sleep(0.2)  # past the child's own start
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    deadline = time.monotonic() + 5
    while any(_alive(k) for k in kids) and time.monotonic() < deadline:
        time.sleep(0.02)
    left = [k for k in kids if _alive(k)]
    for k in left:
        os.kill(k, signal.SIGKILL)
    assert not left, "a forked child outlived its parent"
