"""Runs shared by the free processes (controller/forked_runs.py): the same results as one
process, in order; failures redone here; children that go on until stopped."""

from __future__ import annotations

import os
import time

import pytest

from gantry_sim.controller.forked import process_count
from gantry_sim.controller.forked_runs import MAX_RUNS, RunsAhead, fork_runs
from tests.fork_helpers import (
    linux,
    no_child_left_behind,  # noqa: F401 (an autouse fixture)
    slow_square_and_pid,
    square_and_pid,
)


@linux
def test_runs_are_shared_by_the_free_processes_and_come_back_in_order() -> None:
    out = fork_runs(slow_square_and_pid, list(range(40)), 3)
    assert [v for v, _ in out] == [x * x for x in range(40)]
    pids = {pid for _, pid in out}
    assert os.getpid() in pids and len(pids) == 3


@linux
def test_the_children_take_the_runs_while_this_process_does_its_own_job() -> None:
    """``before`` runs here, once, before this process takes runs: children forked before it
    take the runs meanwhile (all of them, when the job outlasts the runs)."""
    jobs: list[int] = []

    def before() -> None:
        jobs.append(os.getpid())
        time.sleep(1.0)

    out = fork_runs(square_and_pid, list(range(8)), 2, before)
    assert jobs == [os.getpid()]
    assert [v for v, _ in out] == [x * x for x in range(8)]
    assert os.getpid() not in {pid for _, pid in out}


@linux
def test_a_child_goes_on_while_this_process_is_busy_with_its_own_job() -> None:
    """Results far larger than the pipe holds: the child keeps what the pipe does not take and
    goes on with its runs while this process, busy with its job, reads nothing."""

    def fn(x: int) -> tuple[bytes, int]:
        time.sleep(0.01)
        return bytes(300_000), os.getpid()

    out = fork_runs(fn, list(range(40)), 2, lambda: time.sleep(1.5))
    assert len(out) == 40 and all(len(b) == 300_000 for b, _ in out)
    assert os.getpid() not in {pid for _, pid in out}  # the child did every run meanwhile


@linux
def test_the_runs_of_a_child_that_dies_are_computed_here() -> None:
    parent = os.getpid()

    def fn(x: int) -> tuple[int, int]:
        if os.getpid() != parent:
            os._exit(7)  # killed, out of memory...: none of its results arrives
        time.sleep(0.01)
        return x + 1, os.getpid()

    assert fork_runs(fn, list(range(10)), 3) == [(x + 1, parent) for x in range(10)]


@linux
def test_a_child_that_dies_after_sending_results_is_not_trusted_with_any() -> None:
    """Its results arrive run by run; it dies at its third run: the runs it sent are
    computed here too."""
    parent = os.getpid()
    count = {"runs": 0}  # the child's own copy counts its runs

    def fn(x: int) -> tuple[int, int]:
        time.sleep(0.01)
        if os.getpid() != parent:
            count["runs"] += 1
            if count["runs"] == 3:
                os._exit(7)
        return x + 1, os.getpid()

    out = fork_runs(fn, list(range(20)), 2)
    assert out == [(x + 1, parent) for x in range(20)]


@linux
def test_an_exception_in_a_run_is_raised_here_as_a_sequential_run_raises_it() -> None:
    def fn(x: int) -> int:
        time.sleep(0.01)
        if x == 7:
            raise ValueError("run seven is wrong")
        return x

    with pytest.raises(ValueError, match="run seven is wrong"):
        fork_runs(fn, list(range(12)), 3)


@linux
def test_a_failing_job_of_this_process_leaves_no_child_behind() -> None:
    def before() -> None:
        raise KeyError("job")

    with pytest.raises(KeyError):
        fork_runs(slow_square_and_pid, list(range(50)), 3, before)


@linux
def test_runs_ahead_go_on_while_this_process_works_and_hold_their_cores(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The children take runs from the start; this process takes the runs left only when it
    finishes. Meanwhile process_count counts the children out (here and in them), and gives
    them back when finished, or closed."""
    monkeypatch.setenv("GANTRY_PLAN_WORKERS", "3")

    def fn(x: int) -> tuple[int, int, int]:
        time.sleep(0.01)
        return x * x, os.getpid(), process_count()

    ahead = RunsAhead(fn, list(range(30)), 3)
    assert process_count() == 1
    time.sleep(1.0)  # the children take every run meanwhile
    out = ahead.finish()
    assert process_count() == 3
    assert [v for v, _, _ in out] == [x * x for x in range(30)]
    assert os.getpid() not in {pid for _, pid, _ in out}
    assert {n for _, _, n in out} == {1}  # a child counts the cores held too

    slow = RunsAhead(slow_square_and_pid, list(range(200)), 2)
    assert process_count() == 2
    slow.close()  # not wanted: stopped, reaped, the core given back
    assert process_count() == 3
    slow.close()  # twice is nothing


@linux
def test_runs_ahead_left_when_finished_are_taken_here_in_order() -> None:
    ahead = RunsAhead(slow_square_and_pid, list(range(40)), 2, hold=False)
    out = ahead.finish()  # at once: both processes take runs
    assert [v for v, _ in out] == [x * x for x in range(40)]
    assert len({pid for _, pid in out}) == 2


@linux
def test_a_child_goes_on_with_then_until_finish_stops_it() -> None:
    """A child that took every run goes on with ``then`` (given its own results) while this
    process works; finish stops it at once, even in a ``then`` that never ends, and the
    extras it sent arrive whole and in order."""

    def endless(mine: dict[int, int], send) -> None:
        send(("mine", sorted(mine.items())))
        k = 0
        while True:  # sends until stopped
            send(("more", k))
            k += 1
            time.sleep(0.001)

    ahead = RunsAhead(lambda x: x * x, list(range(6)), 2, then=endless)
    time.sleep(0.5)
    start = time.monotonic()
    assert ahead.finish() == [x * x for x in range(6)]
    assert time.monotonic() - start < 5.0  # (the stop does not wait for ``then`` to end)
    assert ahead.extras[0] == ("mine", [(x, x * x) for x in range(6)])
    more = [k for tag, k in ahead.extras[1:]]  # type: ignore[misc]
    assert len(more) > 10 and more == list(range(len(more)))


@linux
def test_meanwhile_runs_once_the_children_are_stopped_and_their_cores_given_back() -> None:
    """finish's ``meanwhile`` comes after every run is taken and the children are told to
    stop, with their cores counted back (a new child may be forked there), and before their
    results are read: nothing sent meanwhile is lost."""
    seen: list[tuple[int, int]] = []

    def endless(mine: dict[int, int], send) -> None:
        k = 0
        while True:
            send(k)
            k += 1
            time.sleep(0.001)

    ahead = RunsAhead(lambda x: x * x, list(range(6)), 2, then=endless)
    assert process_count() == 1
    time.sleep(0.3)

    def meanwhile() -> None:
        seen.append((process_count(), len(ahead.extras)))
        assert fork_runs(lambda x: x + 1, [1, 2, 3], 2) == [2, 3, 4]

    assert ahead.finish(meanwhile) == [x * x for x in range(6)]
    assert seen == [(2, 0)]  # once, the core back, nothing read yet
    assert len(ahead.extras) > 10 and ahead.extras == list(range(len(ahead.extras)))


@linux
def test_then_that_fails_or_ends_keeps_what_it_sent_and_the_runs() -> None:
    def failing(mine: dict[int, int], send) -> None:
        send("first")
        raise RuntimeError("only ends then")

    ahead = RunsAhead(lambda x: x + 1, list(range(5)), 2, then=failing)
    time.sleep(0.3)
    assert ahead.finish() == [1, 2, 3, 4, 5]
    assert ahead.extras == ["first"]

    ended = RunsAhead(lambda x: x + 1, list(range(5)), 2, then=lambda mine, send: send(len(mine)))
    time.sleep(0.3)
    assert ended.finish() == [1, 2, 3, 4, 5]
    assert ended.extras == [5]


@linux
def test_a_child_killed_in_then_gives_no_extras_and_its_runs_are_computed_here() -> None:
    """A child that dies in ``then`` (e.g. killed for memory) is not trusted: what it sent
    is dropped, and its runs are computed in this process."""
    import signal

    def dies(mine: dict[int, tuple[int, int]], send) -> None:
        send("before")
        os.kill(os.getpid(), signal.SIGKILL)

    ahead = RunsAhead(square_and_pid, list(range(6)), 2, then=dies)
    time.sleep(0.5)
    out = ahead.finish()
    assert [v for v, _ in out] == [x * x for x in range(6)]
    assert {pid for _, pid in out} == {os.getpid()}
    assert ahead.extras == []


@linux
def test_a_child_stopped_on_its_runs_skips_then_and_finish_taken_at_once_has_them_all() -> None:
    """finish right away: this process takes runs too, the child is stopped while it still
    computes one, and ``then`` (given only the child's runs, if it runs at all) sends at most
    that; every run's result is there."""

    def then(mine: dict[int, tuple[int, int]], send) -> None:
        send(sorted(mine))

    ahead = RunsAhead(slow_square_and_pid, list(range(40)), 2, then=then)
    out = ahead.finish()
    assert [v for v, _ in out] == [x * x for x in range(40)]
    child_runs = [i for i, (_, pid) in enumerate(out) if pid != os.getpid()]
    assert child_runs and ahead.extras in ([], [child_runs])


def test_runs_in_one_process_do_the_job_first_and_refuse_too_many_runs() -> None:
    order: list[object] = []
    out = fork_runs(lambda x: order.append(x) or x, [1, 2], 1, lambda: order.append("job"))
    assert out == [1, 2] and order == ["job", 1, 2]
    with pytest.raises(ValueError, match="at most"):
        fork_runs(abs, [0] * (MAX_RUNS + 1), 2)
