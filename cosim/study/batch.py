"""Batch studies: a grid of `cosim run`s over traffic density, seed, occupant
type p, friction mu, driver (controller) and plant, on local processes or a
Dask cluster; resumable; one CSV row per run and a summary per grid cell.

Life of a study (`cosim batch`):

1. `expand(study)` turns the study into `RunSpec`s. A run's id is a hash of
   its parameters and of the base scenario file's bytes, so the same grid
   always gives the same ids and a resumed study knows exactly what is done.
2. Runs whose record `DIR/runs/<run_id>.json` exists are skipped.
3. The rest go to `execute_run` -- one top-level function for both back ends
   -- which runs `cosim.run.loop.run_scenario` and turns every exception into a
   failed record. Local back end: a process pool with one fresh process per
   run (libsumo holds one simulation per process). Dask back end: the same
   function mapped over a `distributed.Client` whose workers have one thread.
4. Each record is written atomically (temporary file + `os.replace`) by the
   parent as soon as its run finishes.
5. `assemble` reads the grid's records into `runs.csv` (sorted by the
   parameters), `cosim.study.summary.summarize` groups them into `summary.csv`, and the plots go
   to `DIR/plots/`. Both CSVs depend only on the records, and the records
   only on the parameters -- except the wall-time columns (`wall_time_s` and
   the run's own `wall_*` and `cpu_*` columns), which differ from one
   execution to the next.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import hashlib
import json
import math
import multiprocessing
import os
import random
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from cosim.errors import InputError, signals_deferred
from cosim.study.run_table import (
    NO_PLANT,
    NO_VARIANT,
    PARAMETERS,
    STATUS_FAILED,
    STATUS_OK,
    is_timing_column,
)

if TYPE_CHECKING:  # pandas and scipy load lazily: a worker process needs neither
    import pandas as pd

from cosim.output import (
    atomic_write_json,
    make_output_dir,
    stale_temp_files,
)

T = TypeVar("T")

# Record keys kept in DIR/runs/<run_id>.json but not in runs.csv.
RECORD_ONLY = ("traceback", "code")


@dataclass(frozen=True)
class RunSpec:
    """One run of a study: the base scenario and the grid values that replace its own."""

    scenario: str  # path of the base scenario file
    scenario_sha: str  # sha256 of the base scenario file's bytes
    duration: float | None  # s, simulated time (None: the scenario's own)
    driver: str  # SV controller: "mimo" | "siso" | "sumo"
    plant: str  # "twotrack" | "bicycle" | "none" (the SUMO-native driver)
    occupant: float  # -, p in [0, 1]
    mu: float  # -, road friction
    density: float  # veh per km per lane
    seed: int  # SUMO and traffic seed
    traces: bool = False  # keep the run's trace and metrics files
    variant: str = NO_VARIANT  # name of a set of scenario overrides (study `variants`)
    overrides: tuple[tuple[str, Any], ...] = ()  # the variant's (override name, value) pairs

    @property
    def run_id(self) -> str:
        """12 hex digits of a hash of everything that determines the run's result."""
        key = {
            "scenario_sha": self.scenario_sha,
            "duration": None if self.duration is None else float(self.duration),
            **{name: getattr(self, name) for name in PARAMETERS},
        }
        key["occupant"] = float(key["occupant"])
        key["mu"] = float(key["mu"])
        key["density"] = float(key["density"])
        key["seed"] = int(key["seed"])
        if self.variant == NO_VARIANT:
            del key["variant"]  # ids of studies without variants stay what they were
        else:
            key["overrides"] = [list(pair) for pair in self.overrides]
        text = json.dumps(key, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    def parameters(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in PARAMETERS}


def file_sha(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def expand(
    scenario: str | Path,
    *,
    densities: Sequence[float],
    seeds: Sequence[int],
    occupants: Sequence[float],
    mus: Sequence[float],
    drivers: Sequence[str],
    plants: Sequence[str],
    duration: float | None = None,
    traces: bool = False,
    variants: Mapping[str, Mapping[str, Any]] | None = None,
) -> list[RunSpec]:
    """The grid as RunSpecs, in a fixed shuffled order (so the time left shown
    while the study runs is not skewed by running all dense cases last).

    `variants`: name -> scenario overrides (`cosim.scenario.with_overrides` names),
    one more grid dimension for our drivers; the SUMO-native driver runs once, as
    the base scenario (no variant)."""
    sha = file_sha(scenario)
    named = [(name, tuple(sorted(ov.items()))) for name, ov in (variants or {}).items()]
    if not named:
        named = [(NO_VARIANT, ())]
    specs = [
        RunSpec(
            scenario=str(Path(scenario).resolve()), scenario_sha=sha, duration=duration,
            driver=d, plant=pl, occupant=float(p), mu=float(m), density=float(k), seed=int(s),
            traces=traces, variant=v, overrides=ov,
        )
        for d in drivers for pl in (plants if d != "sumo" else (NO_PLANT,))
        for v, ov in (named if d != "sumo" else [(NO_VARIANT, ())])
        for p in occupants for m in mus for k in densities for s in seeds
    ]
    ids = [s.run_id for s in specs]
    if len(set(ids)) != len(ids):
        raise InputError(str(scenario), "grid", "repeated values", "each grid value once")
    random.Random(0).shuffle(specs)
    return specs


# --------------------------------------------------------------------------- one run


def apply_spec(spec: RunSpec) -> Any:
    """The base scenario with the run's grid values in place."""
    from cosim.scenario import load_scenario, with_overrides

    # The run id names the base scenario's bytes: a file edited while the study
    # runs would give results under the wrong id, so such a run fails instead.
    if file_sha(spec.scenario) != spec.scenario_sha:
        raise InputError(
            spec.scenario, "file", "(edited)",
            "the base scenario as it was when the study started; run the study again "
            "to run the edited scenario under new run ids",
        )
    scenario = load_scenario(spec.scenario)
    changes: dict[str, Any] = {
        "seed": spec.seed,
        "density": spec.density,
        "occupant": spec.occupant,
        "mu": spec.mu,
        "controller": spec.driver,
    }
    if spec.plant != NO_PLANT:
        changes["plant"] = spec.plant
    changes.update(dict(spec.overrides))
    if spec.duration is not None:
        changes["duration"] = spec.duration
    return with_overrides(scenario, **changes)


def execute_run(spec: RunSpec, out_dir: str) -> dict[str, Any]:
    """Run one grid point and return its record; never raises.

    The one worker function of both back ends. A run that raises is returned
    as a failed record with the error's type and message (and the traceback,
    kept in the JSON record only)."""
    start = time.perf_counter()
    record: dict[str, Any] = {"run_id": spec.run_id, **spec.parameters()}
    try:
        from cosim.run.loop import run_scenario

        scenario = apply_spec(spec)
        # Traces (trace.csv, plans.csv, metrics.csv, timing.csv) only when asked.
        run_dir = Path(out_dir) / "traces" / spec.run_id if spec.traces else None
        metrics = run_scenario(
            scenario, run_dir, write_trace=True, write_figures=False, progress=False, gui=False
        )
        record.update(status=STATUS_OK, error="")
        for key, value in metrics.items():
            if key not in record:  # the grid's own values win over the scenario echo
                record[key] = _plain(value)
    except Exception as exc:
        record.update(
            status=STATUS_FAILED, error=error_text(exc), traceback=traceback.format_exc()
        )
    record["wall_time_s"] = time.perf_counter() - start
    return record


def error_text(exc: BaseException) -> str:
    """One line: the exception's type and message."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def failed_record(spec: RunSpec, error: str, wall_time: float = math.nan) -> dict[str, Any]:
    """The record of a run whose worker never returned (its process died)."""
    return {
        "run_id": spec.run_id, **spec.parameters(), "status": STATUS_FAILED,
        "error": error, "wall_time_s": wall_time,
    }


def _plain(value: Any) -> Any:
    """numpy scalars -> Python scalars, so records are plain JSON."""
    if isinstance(value, np.generic):
        return value.item()
    return value


# --------------------------------------------------------------------------- records


def runs_dir(out_dir: Path) -> Path:
    return out_dir / "runs"


def record_path(out_dir: Path, run_id: str) -> Path:
    return runs_dir(out_dir) / f"{run_id}.json"


def write_record(out_dir: Path, record: dict[str, Any]) -> None:
    """Write a run's record atomically: a reader sees the whole file or none."""
    atomic_write_json(record_path(out_dir, record["run_id"]), record)


def read_record(out_dir: Path, run_id: str) -> dict[str, Any] | None:
    path = record_path(out_dir, run_id)
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def pending(
    specs: Iterable[RunSpec], out_dir: Path, *, retry_failed: bool = False
) -> list[RunSpec]:
    """The runs that still have to be run: no record yet (or a failed one, if asked)."""
    todo = []
    for spec in specs:
        record = read_record(out_dir, spec.run_id)
        if record is None or (retry_failed and record.get("status") != STATUS_OK):
            todo.append(spec)
    return todo


# --------------------------------------------------------------------------- back ends

OnRecord = Callable[[dict[str, Any]], None]


# What a run imports, loaded once by the fork server rather than by every run
# (about 0.4 s a run otherwise). libsumo is imported, never started, before the fork.
# cosim.control.warm compiles the numba code (closed loop, collision check) in the server (about
# 1.2 s a run otherwise).
PRELOAD = (
    "cosim.study.batch", "cosim.run.loop", "cosim.scenario", "cosim.planning.planner",
    "cosim.control.closed_loop", "cosim.traffic.demand", "cosim.traffic.sumo",
    "cosim.vehicle.twotrack", "cosim.vehicle.bicycle", "libsumo", "sumolib",
    "cosim.control.warm", "cosim.study.fork_server",
)


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


def warm_up() -> None:
    """Start the fork server (imports included) now, e.g. before timing a study."""
    with _ending_pool(1) as pool:
        _submit(pool, os.getpid).result()


def run_local(specs: Sequence[RunSpec], out_dir: Path, workers: int, on_record: OnRecord) -> None:
    """Run every spec in a local process pool of `workers` processes.

    At most `workers` runs are submitted at a time, so that a run whose
    process dies (a crash, not an exception) breaks the pool with few runs in
    flight; those are then retried one by one, each alone in a pool, and the
    one that breaks its pool alone is recorded as failed."""
    queue = list(reversed(specs))
    while queue:
        broken: list[RunSpec] = []
        with _ending_pool(workers) as pool:
            running: dict[cf.Future[dict[str, Any]], RunSpec] = {}
            while (queue or running) and not broken:
                while queue and len(running) < workers:
                    spec = queue.pop()
                    running[_submit(pool, execute_run, spec, str(out_dir))] = spec
                done, _ = cf.wait(running, return_when=cf.FIRST_COMPLETED)
                for future in done:
                    spec = running.pop(future)
                    try:
                        on_record(future.result())
                    except cf.process.BrokenProcessPool:
                        broken.append(spec)
            broken += list(running.values())
        for spec in broken:
            start = time.perf_counter()
            with _ending_pool(1) as alone:
                try:
                    record = _submit(alone, execute_run, spec, str(out_dir)).result()
                except cf.process.BrokenProcessPool as exc:
                    record = failed_record(
                        spec, f"worker process died: {error_text(exc)}",
                        time.perf_counter() - start,
                    )
            on_record(record)


def dask_client(address: str, workers: int) -> Any:
    """A distributed.Client: on `address`, or on a new LocalCluster if it is "local"."""
    from distributed import Client, LocalCluster

    if address == "local":
        import logging

        # errors only: a study ended by Ctrl-C or SIGTERM cancels its tasks, and the
        # workers' warnings about that would bury the one line that says so
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
            silence_logs=logging.ERROR,
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


def _start_dask(address: str, workers: int) -> Any:
    """`dask_client`, with Ctrl-C and SIGTERM held while a LocalCluster starts: cut short,
    its half-started workers fail in distributed's exit hooks (tracebacks); held, the
    cluster is whole and `_close_dask` ends it."""
    started: list[Any] = []
    try:
        with signals_deferred():
            started.append(dask_client(address, workers))
    except BaseException:
        if started:
            _close_dask(started[0], address)
        raise
    return started[0]


def _close_dask(client: Any, address: str | None) -> None:
    """Close the client and, for --dask local, its LocalCluster (a second signal held)."""
    with signals_deferred():
        cluster = client.cluster if address == "local" else None
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
    for future in as_completed(futures):
        try:
            record = future.result()
        except Exception as exc:  # KilledWorker and the like: the task never returned
            record = failed_record(spec_of[future.key], f"worker died: {error_text(exc)}")
        on_record(record)
        future.release()


# --------------------------------------------------------------------------- tables


def assemble(specs: Iterable[RunSpec], out_dir: Path) -> pd.DataFrame:
    """runs.csv as a table: one row per run of the grid, sorted by its parameters.

    Columns: run_id, the parameters, status, error, the metrics (in the order
    the first successful run reports them), then the wall-time columns."""
    import pandas as pd

    records = [read_record(out_dir, s.run_id) for s in specs]
    records = [r for r in records if r is not None]
    for r in records:
        r.setdefault("variant", NO_VARIANT)  # records of studies without variants
    records.sort(key=lambda r: tuple(r[p] for p in PARAMETERS))
    head = ["run_id", *PARAMETERS, "status", "error"]
    metric_columns: list[str] = []
    for r in sorted(records, key=lambda r: r["status"] != STATUS_OK):
        metric_columns += [k for k in r if k not in head and k not in metric_columns]
    metric_columns = [k for k in metric_columns if k not in RECORD_ONLY]
    timing = [c for c in metric_columns if is_timing_column(c)]
    columns = head + [c for c in metric_columns if c not in timing] + timing
    return pd.DataFrame.from_records(records, columns=columns)


# --------------------------------------------------------------------------- the study


def provenance() -> dict[str, Any]:
    """The code that ran this call of the study (run ids do not name it: after
    changing cosim, start a new output folder)."""
    import subprocess

    from cosim import __version__

    info: dict[str, Any] = {"cosim": __version__}
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "cosim"],
                               capture_output=True, text=True, timeout=10, check=True).stdout
        info.update(git_commit=head, cosim_files_modified=len(dirty.splitlines()))
    except (OSError, subprocess.SubprocessError):
        pass  # not a git checkout
    return info


STUDY_FILE = "study.json"  # the grid and the base it was run with (`base_fingerprint`)


def base_fingerprint(specs: Sequence[RunSpec]) -> dict[str, Any]:
    """What the runs of a study folder were made from besides their grid values: the base
    scenario resolved (every key, in file units, with the study's duration), its file's and
    its network's bytes, and the variants' overrides. Kept in DIR/study.json, so that a
    study resumed into DIR with another base is refused (`check_same_base`), not silently
    rerun under new run ids with the old rows dropped from runs.csv."""
    from cosim.scenario import load_scenario, scenario_to_dict, with_overrides

    if not specs:
        return {}
    spec = specs[0]
    base = load_scenario(spec.scenario)
    if spec.duration is not None:
        base = with_overrides(base, duration=spec.duration)
    resolved = json.loads(json.dumps(scenario_to_dict(base), default=str))
    return {
        "scenario": resolved,
        "scenario_sha": spec.scenario_sha,
        "network_sha": file_sha(base.network),
        "variants": {s.variant: [list(p) for p in s.overrides] for s in specs
                     if s.variant != NO_VARIANT},
    }


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(tree, dict):
        out: dict[str, Any] = {}
        for k, v in tree.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(tree, list) and any(isinstance(v, (dict, list)) for v in tree):
        out = {}
        for i, v in enumerate(tree):
            out.update(_flat(v, f"{prefix}[{i}]"))
        return out
    return {prefix: tree}


def base_changes(before: Mapping[str, Any], now: Mapping[str, Any]) -> list[str]:
    """What differs between two fingerprints, in words ("scenario.duration_s 10.0 -> 5.0")."""
    old, new = _flat(before.get("scenario", {})), _flat(now.get("scenario", {}))
    changes = [f"{k} {old.get(k, '(absent)')!r} -> {new.get(k, '(absent)')!r}"
               for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    if before.get("scenario") is None and before.get("duration") != now.get("duration"):
        changes.append(f"duration {before.get('duration')!r} -> {now.get('duration')!r}")
    for name in sorted(set(before.get("variants", {})) & set(now.get("variants", {}))):
        if before["variants"][name] != now["variants"][name]:
            changes.append(f"variant {name!r} {before['variants'][name]} -> "
                           f"{now['variants'][name]}")
    if not changes and before.get("scenario_sha") != now.get("scenario_sha"):
        changes.append("the base scenario file's text (same settings; the run ids name its "
                       "bytes)")
    if before.get("network_sha", now["network_sha"]) != now["network_sha"]:
        changes.append("the network file")
    return changes


def read_fingerprint(out_dir: Path) -> dict[str, Any] | None:
    """The fingerprint a study folder's runs were made with (None: no study there yet).
    Folders from before fingerprints were kept: the base file's hash and duration of the
    runs study.json lists."""
    try:
        data = json.loads((out_dir / STUDY_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    if isinstance(data.get("base"), dict):
        return data["base"]
    runs = data.get("runs") or []
    if not runs or not isinstance(runs[0], dict):
        return None
    return {"scenario": None, "scenario_sha": runs[0].get("scenario_sha"),
            "duration": runs[0].get("duration")}


def check_same_base(out_dir: Path, specs: Sequence[RunSpec]) -> dict[str, Any]:
    """The study's fingerprint; InputError if DIR holds runs made from another base (a
    resumed study must not mix them, nor drop them silently): --restart or another -o."""
    now = base_fingerprint(specs)
    before = read_fingerprint(out_dir)
    if before is None or not now:
        return now
    if before.get("scenario") is None:  # an older folder: compare what its runs name
        now_old = {"scenario_sha": now["scenario_sha"], "duration": specs[0].duration}
        changes = [] if now_old == {k: before.get(k) for k in now_old} else [
            "the base scenario file or --duration (this folder's study.json predates the "
            "settings kept for comparison)"]
    else:
        changes = base_changes(before, now)
    if changes:
        shown = "; ".join(changes[:3]) + (f"; and {len(changes) - 3} more"
                                            if len(changes) > 3 else "")
        raise InputError(
            str(out_dir / STUDY_FILE), "base", shown,
            f"the base scenario the runs in {out_dir} were made with: add --restart to "
            "replace them, or give another -o")
    return now


def clear_study(out_dir: Path) -> None:
    """--restart: remove the runs a study folder holds: what a study writes (records
    `runs/<run_id>.json`, `traces/<run_id>/`, the tables, the plots), nothing else, and
    only where a study.json says it is a study's folder."""
    import re
    import shutil

    if not (out_dir / STUDY_FILE).is_file():
        return
    run_id = re.compile(r"[0-9a-f]{12}")
    for p in runs_dir(out_dir).glob("*.json"):
        if run_id.fullmatch(p.stem):
            p.unlink(missing_ok=True)
    for p in (out_dir / "traces").glob("*"):
        if p.is_dir() and run_id.fullmatch(p.name):
            shutil.rmtree(p, ignore_errors=True)
    for p in (out_dir / "plots").glob("*"):
        if p.suffix in (".png", ".svg", ".pdf"):
            p.unlink(missing_ok=True)
    for name in ("runs.csv", "summary.csv", "summary.md", STUDY_FILE):
        (out_dir / name).unlink(missing_ok=True)


@dataclass
class StudyResult:
    out_dir: Path
    runs: pd.DataFrame
    summary: pd.DataFrame
    ran: int  # runs executed by this call
    skipped: int  # runs already recorded before this call
    failed: int  # failed runs in the whole study
    wall_time: float  # s, this call
    plots: list[Path]


def run_study(
    specs: Sequence[RunSpec],
    out_dir: Path,
    *,
    workers: int | None = None,
    dask: str | None = None,
    progress: bool = True,
    retry_failed: bool = False,
    plots: bool = True,
    title: str = "study",
    on_start: Callable[[int], None] | None = None,
    restart: bool = False,
    figure_format: str | None = None,
) -> StudyResult:
    """Run what is not yet recorded, then write runs.csv, summary.csv and plots.

    `on_start(n_to_run)` is called once the input is known good (a Dask
    scheduler reached), just before anything is written. A folder whose runs were made
    from another base scenario (or duration, network, variant) is refused
    (`check_same_base`) unless `restart`, which removes its runs and starts afresh."""
    start = time.perf_counter()
    out_dir = Path(out_dir)
    workers = workers or os.cpu_count() or 1
    specs = list({s.run_id: s for s in specs}.values())  # a run listed twice runs once
    # Another base than the folder's runs were made with: refused before anything runs.
    fingerprint = base_fingerprint(specs) if restart else check_same_base(out_dir, specs)
    todo = list(specs) if restart else pending(specs, out_dir, retry_failed=retry_failed)
    done_before = len(specs) - len(todo)
    todo_ids = {s.run_id for s in todo}
    failed_before = 0 if restart else sum(
        1 for s in specs
        if s.run_id not in todo_ids
        and (read_record(out_dir, s.run_id) or {}).get("status") != STATUS_OK
    )
    # Connect first: a bad address is an input error, before anything is written.
    client = _start_dask(dask, workers) if dask is not None and todo else None
    bar = None
    try:
        if on_start is not None:
            on_start(len(todo))
        if restart:
            clear_study(out_dir)
        make_output_dir(runs_dir(out_dir))
        for stale in stale_temp_files(runs_dir(out_dir)):  # left by a killed study
            stale.unlink(missing_ok=True)
        atomic_write_json(
            out_dir / STUDY_FILE,
            {"title": title, "base": fingerprint,
             "runs": [asdict(s) | {"run_id": s.run_id} for s in specs]},
        )

        from cosim.progress import Bar

        # ETA from the rate after the first round of runs (the workers' start-up in it)
        bar = Bar(len(specs), initial=done_before, unit="run", desc=title,
                  disable=not progress,
                  warm=min(max(workers, 1), max(len(specs) - done_before, 1)))
        failed = [failed_before]
        code = provenance()

        def on_record(record: dict[str, Any]) -> None:
            record["code"] = code  # which code made this record (kept in the JSON only)
            write_record(out_dir, record)
            if record["status"] != STATUS_OK:
                failed[0] += 1
            bar.postfix(done=bar.n + 1, failed=failed[0])
            bar.update(1)

        bar.postfix(done=bar.n, failed=failed[0])
        if client is not None:
            run_dask(todo, out_dir, client, on_record)
        elif todo:
            run_local(todo, out_dir, workers, on_record)
    finally:
        if bar is not None:
            bar.close()
        if client is not None:
            _close_dask(client, dask)

    runs = assemble(specs, out_dir)
    from cosim.study.summary import (  # pandas and scipy: the parent only
        summarize,
        write_tables,
    )

    summary = summarize(runs)
    write_tables(runs, summary, out_dir)
    figures: list[Path] = []
    if plots and len(runs):
        from cosim.plots.batch import plot_summary

        figures = plot_summary(summary, out_dir / "plots", title=title, fmt=figure_format)
    return StudyResult(
        out_dir=out_dir, runs=runs, summary=summary, ran=len(todo), skipped=done_before,
        failed=int((runs["status"] != STATUS_OK).sum()) if len(runs) else 0,
        wall_time=time.perf_counter() - start, plots=figures,
    )
