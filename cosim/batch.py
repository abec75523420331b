"""Batch studies: a grid of `cosim run`s over traffic density, seed, occupant
type p, friction mu, driver (controller) and plant, on local processes or a
Dask cluster; resumable; one CSV row per run and a summary per grid cell.

Life of a study (`cosim batch`):

1. `expand(study)` turns the study into `RunSpec`s. A run's id is a hash of
   its parameters and of the base scenario file's bytes, so the same grid
   always gives the same ids and a resumed study knows exactly what is done.
2. Runs whose record `DIR/runs/<run_id>.json` exists are skipped.
3. The rest go to `execute_run` -- one top-level function for both back ends
   -- which runs `cosim.sim.run_scenario` and turns every exception into a
   failed record. Local back end: a process pool with one fresh process per
   run (libsumo holds one simulation per process). Dask back end: the same
   function mapped over a `distributed.Client` whose workers have one thread.
4. Each record is written atomically (temporary file + `os.replace`) by the
   parent as soon as its run finishes.
5. `assemble` reads the grid's records into `runs.csv` (sorted by the
   parameters), `summarize` groups them into `summary.csv`, and the plots go
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
from statistics import NormalDist
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from cosim.errors import InputError
from cosim.metrics import FOLLOWER_PERCENTILE

if TYPE_CHECKING:  # pandas and scipy load lazily: a worker process needs neither
    import pandas as pd

from cosim.output import (
    atomic_write_csv,
    atomic_write_json,
    atomic_write_text,
    make_output_dir,
    stale_temp_files,
)

T = TypeVar("T")

# Grid parameters, in the order runs.csv lists (and sorts) them.
PARAMETERS = ("driver", "variant", "plant", "occupant", "mu", "density", "seed")
# Parameters that define a grid cell of summary.csv (every parameter but the seed).
CELL = ("driver", "variant", "plant", "occupant", "mu", "density")
# The variant of runs without one (and of the SUMO-native driver, which no variant
# changes): the base scenario as it is.
NO_VARIANT = ""
STATUS_OK = "ok"
STATUS_FAILED = "failed"
# Columns of runs.csv measured by a clock (`wall_time_s` and the run's own
# `wall_*` and `cpu_*` columns from cosim.sim): they differ between two
# executions of the same run; everything else is reproducible.
TIMING_PREFIXES = ("wall_", "cpu_")
# The plant of the SUMO-native driver: SUMO moves the SV, no plant of ours runs.
NO_PLANT = "none"

# Metrics summarised per grid cell (names as cosim.metrics writes them).
SUCCESS_METRIC = "lane_change_completed"  # bool: the commanded lane change ended in its lane
COLLISION_METRIC = "collision"  # bool: our geometric check saw an overlap
SUMO_COLLISION_METRIC = "sumo_collision"  # bool: SUMO's getCollisions saw one (cross-check)
UNFINISHED_METRIC = "lane_change_unfinished"  # bool: the run ended during the lane change
SV_COLLISION_METRIC = "collisions_sv"  # count: collisions the SV caused (cosim.sim)
MANOEUVRE_COLLISION_METRIC = "collisions_manoeuvre"  # count: ... while changing lanes
DURATION_METRIC = "lane_change_duration_s"  # s
TTC_METRIC = "min_ttc_s"  # s
FOLLOWER_METRIC = "follower_max_decel_mps2"  # m/s^2, the SV's new follower (issue 16)
PERCENTILES = (10, 50, 90)
# Record keys kept in DIR/runs/<run_id>.json but not in runs.csv.
RECORD_ONLY = ("traceback", "code")
CONFIDENCE = 0.95


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
        from cosim.sim import run_scenario

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
    "cosim.batch", "cosim.sim", "cosim.scenario", "cosim.planning.planner",
    "cosim.control.closed_loop", "cosim.traffic.demand", "cosim.traffic.sumo",
    "cosim.vehicle.twotrack", "cosim.vehicle.bicycle", "libsumo", "sumolib",
    "cosim.control.warm", "cosim.fork_server",
)


def _pool(workers: int) -> cf.ProcessPoolExecutor:
    # A fresh process per run (max_tasks_per_child=1): libsumo holds one
    # simulation per process, and a run cannot leak state into the next.
    # forkserver: children fork from a server that has imported cosim already
    # (a missing module in PRELOAD is skipped by the fork server).
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(PRELOAD))
    # The workers ignore Ctrl-C and SIGHUP from birth (cosim.fork_server): the parent
    # ends them itself.
    return cf.ProcessPoolExecutor(workers, mp_context=context, max_tasks_per_child=1)


def _submit(pool: cf.ProcessPoolExecutor, fn: Callable[..., T], /, *args: Any) -> cf.Future[T]:
    """`pool.submit` with Ctrl-C and SIGTERM held. A submit may start a worker; cut short
    between the fork server's fork and the pool's record of it, that worker would be no
    one's to end: it would outlive the batch and, unpickling from a parent that is gone,
    print a traceback."""
    from cosim.errors import signals_deferred

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
    from cosim.errors import signals_deferred

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
    from cosim.errors import signals_deferred

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
    from cosim.errors import signals_deferred

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


def is_timing_column(name: str) -> bool:
    """Whether a runs.csv column is a wall-clock measurement (not reproducible)."""
    return name.startswith(TIMING_PREFIXES)


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


def wilson(successes: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (NaNs for n = 0)."""
    if n == 0:
        return (math.nan, math.nan)
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # exact at the ends (0 successes: from 0; all: up to 1), whatever the rounding
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return (low, high)


def mean_ci(values: np.ndarray, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Mean and Student-t confidence interval (NaN where undefined). For quantities
    that may take either sign; positive ones (durations, TTC) use `median_ci`."""
    values = values[np.isfinite(values)]
    n = len(values)
    if n == 0:
        return (math.nan, math.nan, math.nan)
    mean = float(values.mean())
    if n == 1:
        return (mean, math.nan, math.nan)
    from scipy import stats

    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * values.std(ddof=1) / math.sqrt(n))
    return (mean, mean - half, mean + half)


def median_ci(values: np.ndarray, confidence: float = CONFIDENCE
              ) -> tuple[float, float, float, float]:
    """Median, a distribution-free confidence interval for it and that interval's
    coverage: the order statistics (x_(j), x_(n+1-j)) with the largest j whose
    binomial coverage is at least `confidence`. The bounds are observed values, so
    a positive quantity (a duration, a TTC) never gets a negative bound, and a
    skewed one an honest asymmetric interval. Below 6 values no pair reaches 95 %:
    the interval is then the range, and its coverage (1 - 2 / 2^n) says so.
    NaN where undefined (no finite value; one value: no interval)."""
    x = np.sort(values[np.isfinite(values)])
    n = len(x)
    if n == 0:
        return (math.nan, math.nan, math.nan, math.nan)
    median = float(np.median(x))
    if n == 1:
        return (median, math.nan, math.nan, math.nan)
    from scipy import stats

    # coverage of (x_(j), x_(n+1-j)): P(j <= B < n+1-j), B ~ Binomial(n, 1/2)
    j = np.arange(1, n // 2 + 1)
    coverage = stats.binom.cdf(n - j, n, 0.5) - stats.binom.cdf(j - 1, n, 0.5)
    ok = np.flatnonzero(coverage >= confidence)
    k = int(ok[-1]) if ok.size else 0
    return (median, float(x[j[k] - 1]), float(x[n - j[k]]), float(coverage[k]))


def _as_bool(column: pd.Series) -> pd.Series:
    if column.dtype == object:
        return column.map(lambda v: str(v).strip().lower() in ("true", "1", "1.0", "yes"))
    return column.fillna(0).astype(float) != 0


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """summary.csv: per grid cell (all parameters but the seed), the number of
    runs, failed runs, runs whose lane change the end cut short (`unfinished`), the
    success rate over the other (finished) runs, the collision rates of both checks
    (ours `collision`, SUMO's `sumo_collision`) and the SV-caused one, with Wilson
    intervals, and
    lane-change duration and minimum TTC: mean, percentiles, and the median's
    distribution-free interval (`median_ci`); the new follower's largest deceleration:
    count, 95th percentile and maximum.

    Rates are over the runs that finished (status ok): a failed run is a fault
    of the tool, not an outcome of the manoeuvre, and is counted apart."""
    import pandas as pd

    rows = []
    if "variant" not in runs:
        runs = runs.assign(variant=NO_VARIANT)
    runs = runs.assign(variant=runs["variant"].fillna(NO_VARIANT).astype(str))
    for cell, group in runs.groupby(list(CELL), sort=True):
        ok = group[group["status"] == STATUS_OK]
        n = len(ok)
        row: dict[str, Any] = dict(zip(CELL, cell, strict=True))
        row.update(runs=len(group), ok=n, failed=len(group) - n)
        # lane changes the run's end cut short are neither successes nor failures
        unfinished = (int(_as_bool(ok[UNFINISHED_METRIC]).sum())
                      if UNFINISHED_METRIC in ok and n else 0)
        row["unfinished"] = unfinished
        for name, metric in (("success", SUCCESS_METRIC), ("collision", COLLISION_METRIC),
                             ("sumo_collision", SUMO_COLLISION_METRIC),
                             ("sv_collision", SV_COLLISION_METRIC),
                             ("manoeuvre_collision", MANOEUVRE_COLLISION_METRIC)):
            hits = int(_as_bool(ok[metric]).sum()) if metric in ok and n else 0
            known = metric in ok or name in ("success", "collision")  # older records lack some
            of = n - unfinished if name == "success" else n
            row[f"{name}_rate"] = hits / of if of and known else math.nan
            row[f"{name}_ci_low"], row[f"{name}_ci_high"] = wilson(hits, of if known else 0)
        for name, metric in (("lc_duration_s", DURATION_METRIC), ("min_ttc_s", TTC_METRIC)):
            values = (
                pd.to_numeric(ok[metric], errors="coerce").to_numpy(float)
                if metric in ok else np.empty(0)
            )
            finite = values[np.isfinite(values)]
            row[f"{name}_n"] = len(finite)
            row[f"{name}_mean"] = float(finite.mean()) if len(finite) else math.nan
            for q in PERCENTILES:
                row[f"{name}_p{q}"] = float(np.percentile(finite, q)) if len(finite) else math.nan
            # the median and its interval: the statistic of summary.md and the plots
            (_, row[f"{name}_ci_low"], row[f"{name}_ci_high"],
             row[f"{name}_ci_coverage"]) = median_ci(values)
        decel = (pd.to_numeric(ok[FOLLOWER_METRIC], errors="coerce").to_numpy(float)
                 if FOLLOWER_METRIC in ok else np.empty(0))
        decel = decel[np.isfinite(decel)]
        row["follower_decel_mps2_n"] = len(decel)
        row[f"follower_decel_mps2_p{FOLLOWER_PERCENTILE}"] = (
            float(np.percentile(decel, FOLLOWER_PERCENTILE)) if len(decel) else math.nan)
        row["follower_decel_mps2_max"] = float(decel.max()) if len(decel) else math.nan
        row.update(comfort_summary(ok))
        row.update(merge_summary(ok))
        rows.append(row)
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ comfort (issue 22)
# Per grid cell: medians (p50) and worst values of the SV's comfort metrics
# (cosim.metrics.COMFORT_COLUMNS), over the finished runs where the metric is finite.
COMFORT_MEDIANS = ("rms_long_accel_mps2", "rms_long_jerk_mps3", "max_long_jerk_mps3",
                   "long_accel_jump_share", "merge_time_gap_s", "post_change_max_decel_mps2",
                   "request_to_lane_s")
HARD_BRAKE = 3.0  # m/s^2, a deceleration after the change this large counts as hard braking


def comfort_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's comfort columns of one cell's finished runs: `<metric>_p50` for each
    of COMFORT_MEDIANS, `max_long_jerk_mps3_max`, `merge_time_gap_s_min`,
    `post_change_max_decel_mps2_max` and `hard_post_change_brakes` (runs that braked
    harder than HARD_BRAKE after a change; NaN before these metrics existed)."""
    import pandas as pd

    row: dict[str, float] = {}

    def values(metric: str) -> np.ndarray:
        if metric not in ok:
            return np.empty(0)
        v = pd.to_numeric(ok[metric], errors="coerce").to_numpy(float)
        return v[np.isfinite(v)]

    for metric in COMFORT_MEDIANS:
        v = values(metric)
        row[f"{metric}_p50"] = float(np.median(v)) if len(v) else math.nan
    jerk, gap, decel = (values(m) for m in ("max_long_jerk_mps3", "merge_time_gap_s",
                                            "post_change_max_decel_mps2"))
    row["max_long_jerk_mps3_max"] = float(jerk.max()) if len(jerk) else math.nan
    row["merge_time_gap_s_min"] = float(gap.min()) if len(gap) else math.nan
    row["post_change_max_decel_mps2_max"] = float(decel.max()) if len(decel) else math.nan
    row["hard_post_change_brakes"] = (float(np.sum(decel > HARD_BRAKE))
                                      if "post_change_max_decel_mps2" in ok else math.nan)
    return row


# ------------------------------------------------------------------ merges (issue 24)
MERGE_METRIC = "merge_success"  # 1 / 0; empty when the SV's start lane does not end


def merge_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's merge columns of one cell's finished runs (cosim.metrics.MERGE_DOCS):
    `merge_n` runs whose start lane ends, `merge_success_rate` among them with its Wilson
    interval, the medians of `merge_distance_to_end_m` and `stopped_time_s`, and the
    target lane follower's largest deceleration: 95th percentile and maximum (all NaN
    when no run started in a lane that ends)."""
    import pandas as pd

    def values(metric: str) -> np.ndarray:
        if metric not in ok:
            return np.empty(0)
        v = pd.to_numeric(ok[metric], errors="coerce").to_numpy(float)
        return v[np.isfinite(v)]

    success = values(MERGE_METRIC)
    n, hits = len(success), int(np.sum(success > 0.5))
    row: dict[str, float] = {"merge_n": float(n),
                             "merge_success_rate": hits / n if n else math.nan}
    row["merge_success_ci_low"], row["merge_success_ci_high"] = wilson(hits, n)
    for metric in ("merge_distance_to_end_m", "stopped_time_s"):
        v = values(metric) if n else np.empty(0)
        row[f"{metric}_p50"] = float(np.median(v)) if len(v) else math.nan
    decel = values("merge_follower_max_decel_mps2")
    row[f"merge_follower_decel_mps2_p{FOLLOWER_PERCENTILE}"] = (
        float(np.percentile(decel, FOLLOWER_PERCENTILE)) if len(decel) else math.nan)
    row["merge_follower_decel_mps2_max"] = float(decel.max()) if len(decel) else math.nan
    return row


def comfort_markdown(summary: pd.DataFrame) -> str:
    """The comfort columns of summary.csv as a Markdown table (comfort.md)."""
    head = ["driver", "variant", "mu", "density (veh/km/lane)",
            "max jerk m/s^3: median / max", "ax jumps > 5 m/s^2: median share",
            "merge time gap s: median / min", "decel after change m/s^2: median / max",
            "runs braking > 3 m/s^2 after change", "request to target lane s: median"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def num(value: Any, digits: int = 2) -> str:
        return "-" if not (isinstance(value, float | int) and math.isfinite(value)) \
            else f"{value:.{digits}f}"

    for _, r in summary.iterrows():
        if "max_long_jerk_mps3_p50" not in r:
            continue
        lines.append("| " + " | ".join([
            str(r["driver"]), str(r["variant"]), f"{r['mu']:g}", f"{r['density']:g}",
            f"{num(r['max_long_jerk_mps3_p50'], 0)} / {num(r['max_long_jerk_mps3_max'], 0)}",
            num(r["long_accel_jump_share_p50"], 3),
            f"{num(r['merge_time_gap_s_p50'])} / {num(r['merge_time_gap_s_min'])}",
            f"{num(r['post_change_max_decel_mps2_p50'])} / "
            f"{num(r['post_change_max_decel_mps2_max'])}",
            num(r["hard_post_change_brakes"], 0), num(r["request_to_lane_s_p50"])]) + " |")
    return "\n".join(lines) + "\n"


def interval(low: float, high: float, digits: int = 2, scale: float = 1.0) -> str:
    """A confidence interval as "[low, high]": no hyphen that could read as a minus."""
    return f"[{scale * low:.{digits}f}, {scale * high:.{digits}f}]"


def summary_markdown(summary: pd.DataFrame) -> str:
    """The main figures of summary.csv as a Markdown table (for docs and READMEs):
    rates with Wilson intervals, durations and TTC as medians with the median's
    distribution-free interval (the statistic the plots show too)."""

    def pct(row: pd.Series, name: str) -> str:
        if not math.isfinite(row[f"{name}_rate"]):
            return "-"
        return (f"{100 * row[f'{name}_rate']:.0f} "
                + interval(row[f"{name}_ci_low"], row[f"{name}_ci_high"], 0, 100.0))

    def median(row: pd.Series, name: str) -> str:
        if not math.isfinite(row[f"{name}_p50"]):
            return "-"
        text = f"{row[f'{name}_p50']:.2f}"
        if math.isfinite(row[f"{name}_ci_low"]):
            text += " " + interval(row[f"{name}_ci_low"], row[f"{name}_ci_high"])
            if row[f"{name}_ci_coverage"] < CONFIDENCE:  # too few runs for 95 %
                text += f" ({100 * row[f'{name}_ci_coverage']:.0f} %)"
        return text

    def follower(row: pd.Series) -> str:
        p95 = row.get(f"follower_decel_mps2_p{FOLLOWER_PERCENTILE}", math.nan)
        if not math.isfinite(p95):
            return "-"
        return f"{p95:.2f} / {row['follower_decel_mps2_max']:.2f}"

    def collisions(row: pd.Series) -> str:  # ours, then SUMO's in parentheses
        ours = pct(row, "collision")
        sumo = row.get("sumo_collision_rate", math.nan)
        return ours if not math.isfinite(sumo) else f"{ours} ({100 * sumo:.0f})"

    ours = summary[summary["plant"] != NO_PLANT]
    varying = [c for c in ("variant", "plant", "occupant", "mu")
               if (ours if c == "plant" else summary)[c].nunique() > 1]
    head = ["driver", *varying, "density (veh/km/lane)", "runs ok / failed",
            "unfinished", "success % of finished [95 % CI]",
            "collision % [95 % CI] (SUMO's %)", "SV-caused collision % [95 % CI]",
            "lane-change duration s: median [95 % CI]", "min TTC s: median [95 % CI]",
            "new follower's max decel m/s^2: p95 / max"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, row in summary.iterrows():
        cells = [str(row["driver"]), *(f"{row[c]}" for c in varying), f"{row['density']:g}",
                 f"{row['ok']} / {row['failed']}", f"{row.get('unfinished', 0)}",
                 pct(row, "success"), collisions(row),
                 pct(row, "sv_collision"), median(row, "lc_duration_s"),
                 median(row, "min_ttc_s"), follower(row)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_tables(runs: pd.DataFrame, summary: pd.DataFrame, out_dir: Path) -> None:
    """runs.csv, summary.csv, summary.md and comfort.md, each replaced atomically."""
    atomic_write_csv(out_dir / "runs.csv", runs)
    atomic_write_csv(out_dir / "summary.csv", summary)
    atomic_write_text(out_dir / "summary.md", summary_markdown(summary))
    atomic_write_text(out_dir / "comfort.md", comfort_markdown(summary))


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
