"""Executors for sweeps: map a function over argument tuples, yielding results as they finish.

``local``: a ProcessPoolExecutor over all cores (spawned processes: no fork of a process that
holds threads). ``dask``: a dask.distributed Client; by default on a LocalCluster of one
single-threaded worker process per core, or on a running cluster's scheduler when an address is
given (``DASK_SCHEDULER_ADDRESS`` or ``scheduler=``). Results come in completion order, not in
argument order; no units of their own.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable


def local_map(fn: Callable, args: list[tuple], workers: int | None) -> Iterable[dict]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1, mp_context=ctx) as ex:
        futures = [ex.submit(fn, *a) for a in args]
        for fut in as_completed(futures):
            yield fut.result()


def dask_map(
    fn: Callable, args: list[tuple], workers: int | None, scheduler: str | None
) -> Iterable[dict]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        from gantry_sim.controller.errors import ConfigError

        raise ConfigError(
            "the dask executor needs Dask distributed: pip install 'gantry-sim[distributed]'",
            file="--executor",
        ) from None
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
    if address:
        client, cluster = Client(address), None
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
