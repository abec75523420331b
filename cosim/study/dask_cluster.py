"""The Dask executor: `execute_run` mapped over a `distributed.Client` whose workers have
one thread each (libsumo: one simulation per process), on a scheduler's address or on a
LocalCluster of its own (`LOCAL_CLUSTER`)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cosim.errors import InputError, check_signals, signals_deferred
from cosim.study.grid import RunSpec
from cosim.study.worker import OnRecord, error_text, execute_run, failed_record

LOCAL_CLUSTER = "local"  # the address `--dask local`: a LocalCluster of --workers processes
SIGNAL_POLL = 0.2  # s, how often the wait for runs looks for a signal


def dask_client(address: str, workers: int) -> Any:
    """A distributed.Client: on `address`, or on a new LocalCluster if it is LOCAL_CLUSTER."""
    from distributed import Client, LocalCluster

    if address == LOCAL_CLUSTER:
        import logging

        # critical only: a study ended by Ctrl-C or SIGTERM cancels its tasks and closes
        # the scheduler, and the workers' warnings and heartbeat errors about that (with
        # tracebacks, on a loaded machine) would bury the one line that says so; a run's
        # own failure comes back as its record, a dead worker as KilledWorker
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
            silence_logs=logging.CRITICAL,
            # no dashboard, and the scheduler's HTTP server (health routes) on a free port:
            # on its default 8787, a second study on the machine prints a UserWarning
            scheduler_kwargs={"dashboard": False, "dashboard_address": ":0"},
        )
        return Client(cluster)
    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(
            "--dask", "address", address, f"a reachable Dask scheduler ({exc})"
        ) from None
    threads = client.nthreads()
    many = {w: n for w, n in threads.items() if n != 1}
    if many:
        client.close()
        raise InputError(
            "--dask", "worker threads", many,
            "one thread per worker (libsumo: one simulation per process); "
            "start workers with `dask worker ADDRESS --nthreads 1`",
        )
    return client


def start_dask(address: str, workers: int) -> Any:
    """`dask_client`, with Ctrl-C and SIGTERM held while a LocalCluster starts: cut short,
    its half-started workers fail in distributed's exit hooks (tracebacks); held, the
    cluster is whole and `close_dask` ends it."""
    started: list[Any] = []
    try:
        with signals_deferred():
            started.append(dask_client(address, workers))
    except BaseException:
        if started:
            close_dask(started[0], address)
        raise
    return started[0]


def close_dask(client: Any, address: str | None) -> None:
    """Close the client and, for a LocalCluster, the cluster (a second signal held)."""
    with signals_deferred():
        cluster = client.cluster if address == LOCAL_CLUSTER else None
        client.close()
        if cluster is not None:
            cluster.close()


def run_dask(specs: Sequence[RunSpec], out_dir: Path, client: Any, on_record: OnRecord) -> None:
    """Run every spec as a task of `client`; a task whose worker died is a failed run."""
    from distributed import as_completed

    futures = client.map(
        execute_run, list(specs), out_dir=str(out_dir), pure=False,
        key=[f"cosim-run-{s.run_id}-{time.time_ns()}" for s in specs],
    )
    spec_of = {f.key: s for f, s in zip(futures, specs, strict=True)}
    finished = as_completed(futures)
    while not finished.is_empty():
        check_signals()  # a signal is only noted when it comes: acted on here
        done = finished.next_batch(block=False)
        if not done:
            time.sleep(SIGNAL_POLL)
        for future in done:
            try:
                record = future.result()
            except Exception as exc:  # KilledWorker and the like: the task never returned
                record = failed_record(spec_of[future.key], f"worker died: {error_text(exc)}")
            on_record(record)
            future.release()
