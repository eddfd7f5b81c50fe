"""Executors for sweeps: map a function over argument tuples, yielding results as they finish.

``local``: a ProcessPoolExecutor over all cores (spawned processes: no fork of a process that
holds threads). ``dask``: a dask.distributed Client; by default on a LocalCluster of one
single-threaded worker process per core, or on a running cluster's scheduler when an address is
given (``DASK_SCHEDULER_ADDRESS`` or ``scheduler=``). Results come in completion order, not in
argument order; no units of their own. Before any task, every Dask worker must answer with the
client's gantry-sim version (:func:`check_workers`): a worker without gantry-sim, or with another
version, is a clear error instead of a hung client.

No orphans: local workers ask the kernel to kill them when the sweep's process dies (Linux
``PR_SET_PDEATHSIG``; also a kill -9 of the sweep), ignore Ctrl-C (the sweep stops them), and
are terminated at once when the sweep stops early (an error, Ctrl-C, SIGTERM), so no worker,
resource tracker or semaphore outlives it.
"""

from __future__ import annotations

import os
import re
import signal
import sys
from collections.abc import Callable, Generator

from gantry_sim.controller.errors import ConfigError

#: seconds to wait for a Dask scheduler to answer
SCHEDULER_TIMEOUT_S = 5
#: seconds to wait for a first worker, and for the workers' versions
WORKER_TIMEOUT_S = 10
_ADDRESS = re.compile(r"^(?:(tcp|tls|ucx|ws|wss)://)?(\[[0-9a-fA-F:.]+\]|[\w.-]+):(\d{1,5})$")


def _die_with_parent(parent_pid: int) -> None:
    """Worker initializer: killed with the parent (Linux), deaf to Ctrl-C (the parent stops
    the pool), and gone at once if the parent died before this ran."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:
        os._exit(1)


def local_map(fn: Callable, args: list[tuple], workers: int | None) -> Generator[dict, None, None]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    ctx = multiprocessing.get_context("spawn")
    ex = ProcessPoolExecutor(
        max_workers=min(workers or os.cpu_count() or 1, max(1, len(args))),
        mp_context=ctx,
        initializer=_die_with_parent,
        initargs=(os.getpid(),),
    )
    finished = False
    try:
        futures = [ex.submit(fn, *a) for a in args]
        for fut in as_completed(futures):
            yield fut.result()
        finished = True
    finally:
        if finished:
            ex.shutdown(wait=True)
        else:  # stopped early: do not wait for the simulations under way
            procs = list((getattr(ex, "_processes", None) or {}).values())
            # shutdown() forgets the pool's thread: kept here, to be joined below
            manager = getattr(ex, "_executor_manager_thread", None)
            ex.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                p.terminate()
            for p in procs:
                p.join(timeout=5)
            # the pool's thread then ends at once. Joined, and still referenced here, it
            # leaves the queues' semaphores to this thread, which an interrupted gantry frees
            # before it exits (sim.interrupts.leave). Left to end by itself, it dropped the
            # queues and ran their finalizers while the process exited: a semaphore unlinked
            # but not yet unregistered was reported by the resource tracker as "leaked
            # semaphore objects" on stderr after "gantry: terminated"
            if manager is not None:
                manager.join(timeout=5)


def check_scheduler_address(address: str, option: str) -> str:
    """``address`` if it looks like a Dask scheduler address (``[tcp://]host:port``)."""
    m = _ADDRESS.match(address.strip())
    if not m or not 0 < int(m.group(3)) < 65536:
        raise ConfigError(
            f"'{address}' is not a Dask scheduler address; expected tcp://HOST:PORT, "
            "e.g. tcp://127.0.0.1:8786",
            file=option,
        )
    return address.strip()


def _first_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0][:200] if lines else "no detail"


def _workers_text(addresses: list[str]) -> str:
    shown = ", ".join(addresses[:3])
    return shown + (f" and {len(addresses) - 3} more" if len(addresses) > 3 else "")


def check_workers(client, where: str, option: str) -> list[str]:
    """The addresses of the cluster's workers, once each has answered with the gantry-sim
    version of this client; a ConfigError naming the workers otherwise (none joined within
    WORKER_TIMEOUT_S, or one cannot import gantry-sim or has another version)."""
    from importlib.metadata import version

    from gantry_sim.sim.sweep.remote import installed_version

    want = version("gantry-sim")
    try:
        client.wait_for_workers(1, timeout=WORKER_TIMEOUT_S)
    except TimeoutError:
        raise ConfigError(
            f"no Dask worker joined {where} within {WORKER_TIMEOUT_S} s; start one "
            "(dask worker ADDRESS) where gantry-sim is installed",
            file=option,
        ) from None
    try:  # Client.run has no timeout of its own; its coroutine under one
        answers = client.sync(
            client._run, installed_version, on_error="return", callback_timeout=WORKER_TIMEOUT_S
        )
    except TimeoutError:
        raise ConfigError(
            f"the Dask workers of {where} did not say their gantry-sim version within "
            f"{WORKER_TIMEOUT_S} s",
            file=option,
        ) from None
    missing = sorted(a for a, v in answers.items() if isinstance(v, BaseException))
    other = sorted(a for a, v in answers.items() if not isinstance(v, BaseException) and v != want)
    if missing:
        exc = answers[missing[0]]
        why = _first_line(exc)  # a failed unpickling arrives as Exception('Error(...)')
        why = why if type(exc) is Exception else f"{type(exc).__name__}: {why}"
        raise ConfigError(
            f"Dask worker(s) {_workers_text(missing)} of {where} cannot run gantry-sim "
            f"({why}); install gantry-sim {want} "
            "in the workers' Python environment",
            file=option,
        )
    if other:
        raise ConfigError(
            f"Dask worker(s) {_workers_text(other)} of {where} have gantry-sim "
            f"{answers[other[0]]}, this client {want}; install gantry-sim {want} on every "
            "worker (the numbers must come from the same code)",
            file=option,
        )
    return sorted(answers)


def dask_map(
    fn: Callable, shared: tuple, points: list, workers: int | None, scheduler: str | None
) -> Generator[dict, None, None]:
    """``fn(shared, p)`` for each of ``points`` on a Dask cluster; ``shared`` is sent once to
    each worker (scattered), and only to workers that passed :func:`check_workers`."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise ConfigError(
            "the dask executor needs Dask distributed: pip install 'gantry-sim[distributed]'",
            file="--executor",
        ) from None
    option = "--scheduler" if scheduler else "DASK_SCHEDULER_ADDRESS"
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
    if address:
        address = check_scheduler_address(address, option)
        try:
            client, cluster = Client(address, timeout=f"{SCHEDULER_TIMEOUT_S}s"), None
        except Exception as exc:  # refused, timed out, or not a Dask scheduler answering
            raise ConfigError(
                f"cannot connect to a Dask scheduler at {address} within "
                f"{SCHEDULER_TIMEOUT_S} s ({type(exc).__name__}: {_first_line(exc)}); is it "
                "running, and is the address right?",
                file=option,
            ) from None
        where = f"the scheduler at {address}"
    else:
        option, where = "--executor", "the local Dask cluster"
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # any free port (None took 8787, and warned if busy)
        )
        client = Client(cluster)
    try:
        ready = check_workers(client, where, option)
        [data] = client.scatter([shared], workers=ready, broadcast=True, hash=False)
        futures = [
            client.submit(fn, data, p, pure=False, workers=ready, allow_other_workers=False)
            for p in points
        ]
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
