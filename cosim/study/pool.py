"""The local executor: a process pool with one fresh process per run (libsumo holds one
simulation per process), forked from a fork server that has imported cosim already
(`PRELOAD`, then cosim.study.fork_server). Left by Ctrl-C or SIGTERM, the pool ends its
workers and the fork server before the exception goes on (`_ending_pool`); the parent
notices a signal while it waits for its runs (`_wait_any`)."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

from cosim.errors import InputError, check_signals, signals_deferred
from cosim.study.grid import RunSpec
from cosim.study.worker import OnRecord, error_text, execute_run, failed_record

T = TypeVar("T")

SIGNAL_POLL = 0.2  # s, how often a wait for runs looks for a signal
# bytes, the longest socket path the kernel takes (sun_path: 108 with its NUL); the fork
# server's socket is $TMPDIR/pymp-XXXXXXXX/listener-XXXXXXXX (multiprocessing's names)
SOCKET_PATH_MAX = 107
SOCKET_NAME = len("/pymp-XXXXXXXX/listener-XXXXXXXX")

# What a run imports, loaded once by the fork server rather than by every run.
# libsumo is imported, never started, before the fork. cosim.control.warm compiles the
# numba code (closed loop, collision check) in the server.
PRELOAD = (  # tuned: docs/tuned_constants.md
    "cosim.study.worker", "cosim.run.loop", "cosim.scenario", "cosim.planning.planner",
    "cosim.control.closed_loop", "cosim.traffic.demand", "cosim.traffic.sumo",
    "cosim.vehicle.twotrack", "cosim.vehicle.bicycle", "libsumo", "sumolib",
    "cosim.control.warm", "cosim.study.fork_server",
)


def check_socket_room() -> None:
    """Refuse a temporary folder whose path leaves no room for the fork server's socket
    (multiprocessing would fail with "AF_UNIX path too long" once the batch has begun)."""
    folder = tempfile.gettempdir()
    room = SOCKET_PATH_MAX - SOCKET_NAME
    if len(os.fsencode(folder)) > room:
        raise InputError("environment", "TMPDIR", folder,
                         f"a folder path of at most {room} bytes (the local batch's process "
                         "pool makes its socket there; the kernel takes socket paths of at "
                         f"most {SOCKET_PATH_MAX}): set TMPDIR=/tmp, or use --dask")


def _pool(workers: int) -> cf.ProcessPoolExecutor:
    # A fresh process per run (max_tasks_per_child=1): libsumo holds one
    # simulation per process, and a run cannot leak state into the next.
    # forkserver: children fork from a server that has imported cosim already
    # (a missing module in PRELOAD is skipped by the fork server).
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(PRELOAD))
    # The workers ignore Ctrl-C and SIGHUP from birth (cosim.study.fork_server): the parent
    # ends them itself.
    return cf.ProcessPoolExecutor(workers, mp_context=context, max_tasks_per_child=1)


def _submit(pool: cf.ProcessPoolExecutor, fn: Callable[..., T], /, *args: Any) -> cf.Future[T]:
    """`pool.submit` with Ctrl-C and SIGTERM held. A submit may start a worker; cut short
    between the fork server's fork and the pool's record of it, that worker would be no
    one's to end: it would outlive the batch and, unpickling from a parent that is gone,
    print a traceback."""
    with signals_deferred():
        return pool.submit(fn, *args)


@contextlib.contextmanager
def _ending_pool(workers: int) -> Iterator[cf.ProcessPoolExecutor]:
    """A pool that, left by an exception (Ctrl-C, SIGTERM as `Terminated`), ends its
    workers and the fork server before the exception goes on: no run left running, no
    worker unpickling from a parent that is gone (a traceback), no orphan left defunct.
    Left normally, it waits for its workers as `with ProcessPoolExecutor` does."""
    pool = _pool(workers)
    try:
        yield pool
    except BaseException:
        _end_pool(pool)
        raise
    pool.shutdown(wait=True)


def _end_pool(pool: cf.ProcessPoolExecutor, timeout: float = 10.0) -> None:
    """Terminate the pool's workers, wait for them (the fork server reaps them), then stop
    the fork server (our child: reaped here). Private parts of multiprocessing, read
    defensively. A second Ctrl-C or SIGTERM meanwhile is held until this is done."""
    with signals_deferred():
        _end_pool_now(pool, timeout)


def _end_pool_now(pool: cf.ProcessPoolExecutor, timeout: float) -> None:
    import signal

    procs = list((getattr(pool, "_processes", None) or {}).values())
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    deadline = time.monotonic() + timeout
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(max(0.0, deadline - time.monotonic()))
    # its workers are gone: waiting is short, and shutdown(wait=False) would let the
    # pool's manager thread trip over the processes it forgets (a thread traceback)
    pool.shutdown(wait=True, cancel_futures=True)
    from multiprocessing import forkserver

    server = getattr(forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if server is None or pid is None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)  # it may still be importing PRELOAD: do not wait for it
    with contextlib.suppress(Exception):
        server._stop()  # closes its pipe, reaps it, forgets it (the next pool starts anew)


def _wait_any(futures: Iterable[cf.Future[T]]) -> set[cf.Future[T]]:
    """The futures done once at least one is, looking for a signal every SIGNAL_POLL
    seconds meanwhile (a signal is only noted when it comes: `check_signals` acts on it)."""
    futures = list(futures)
    while True:
        check_signals()
        done, _ = cf.wait(futures, timeout=SIGNAL_POLL, return_when=cf.FIRST_COMPLETED)
        if done:
            return done


def _result(future: cf.Future[T]) -> T:
    """`future.result()`, a signal acted on while it waits."""
    _wait_any([future])
    return future.result()


def start_fork_server() -> None:
    """Start the fork server (imports included) now, e.g. before timing a study."""
    with _ending_pool(1) as pool:
        _result(_submit(pool, os.getpid))


def run_local(specs: Sequence[RunSpec], out_dir: Path, workers: int, on_record: OnRecord) -> None:
    """Run every spec in a local process pool of `workers` processes.

    At most `workers` runs are submitted at a time, so that a run whose
    process dies (a crash, not an exception) breaks the pool with few runs in
    flight; those are then retried one by one, each alone in a pool, and the
    one that breaks its pool alone is recorded as failed.

    The workers' temporary folders (SUMO's log, the fcd file, ...) are made in a folder
    of this batch's own, removed when the batch ends however it ends: a worker ended by
    a signal leaves its folders there, not in the system's temporary folder."""
    queue = list(reversed(specs))
    tmp_root = tempfile.mkdtemp(prefix="cosim-batch-")
    try:
        while queue:
            broken = _run_until_broken(queue, out_dir, workers, on_record, tmp_root)
            for spec in broken:
                on_record(_run_alone(spec, out_dir, tmp_root))
    finally:
        with signals_deferred():
            shutil.rmtree(tmp_root, ignore_errors=True)


def _run_until_broken(queue: list[RunSpec], out_dir: Path, workers: int,
                      on_record: OnRecord, tmp_root: str) -> list[RunSpec]:
    """Run the queue's runs (popped from its end) in one pool until it is empty or the pool
    breaks; return the runs in flight when it broke."""
    broken: list[RunSpec] = []
    with _ending_pool(workers) as pool:
        running: dict[cf.Future[dict[str, Any]], RunSpec] = {}
        while (queue or running) and not broken:
            while queue and len(running) < workers:
                spec = queue.pop()
                running[_submit(pool, execute_run, spec, str(out_dir), tmp_root)] = spec
            done = _wait_any(running)
            for future in done:
                spec = running.pop(future)
                try:
                    on_record(future.result())
                except cf.process.BrokenProcessPool:
                    broken.append(spec)
        broken += list(running.values())
    return broken


def _run_alone(spec: RunSpec, out_dir: Path, tmp_root: str) -> dict[str, Any]:
    """The record of one run in a pool of its own; failed if its process dies."""
    start = time.perf_counter()
    with _ending_pool(1) as alone:
        try:
            return _result(_submit(alone, execute_run, spec, str(out_dir), tmp_root))
        except cf.process.BrokenProcessPool as exc:
            return failed_record(
                spec, f"worker process died: {error_text(exc)}", time.perf_counter() - start,
            )
