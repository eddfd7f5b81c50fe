"""Executors for sweeps: map a function over argument tuples, yielding results as they finish.

``local``: a ProcessPoolExecutor over all cores (spawned processes: no fork of a process that
holds threads). ``dask``: a dask.distributed Client; by default on a LocalCluster of one
single-threaded worker process per core, or on a running cluster's scheduler when an address is
given (``DASK_SCHEDULER_ADDRESS`` or ``scheduler=``). Results come in completion order, not in
argument order; no units of their own.

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
            ex.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                p.terminate()
            for p in procs:
                p.join(timeout=5)


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


def dask_map(
    fn: Callable, args: list[tuple], workers: int | None, scheduler: str | None
) -> Generator[dict, None, None]:
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
    else:
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
        )
        client = Client(cluster)
    try:
        futures = [client.submit(fn, *a, pure=False) for a in args]
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
