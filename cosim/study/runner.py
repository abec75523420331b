"""A study run (`cosim batch`): a grid of `cosim run`s over traffic density, seed,
occupant type p, friction mu, driver and plant, on local processes or a Dask cluster;
resumable; one CSV row per run and a summary per grid cell.

1. The grid is expanded into runs (cosim.study.grid); a run's id names its parameters
   and the base scenario file's bytes.
2. The study's folder says which runs are done and refuses runs made from another base
   (cosim.study.store).
3. The rest run on an executor, the local process pool (cosim.study.pool) or Dask
   (cosim.study.dask_cluster), each through `cosim.study.worker.execute_run`; the parent
   writes each run's record as soon as it finishes.
4. runs.csv is assembled from the records (cosim.study.store), summarised, and written
   with its tables and figure (cosim.study.report).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cosim.study.dask_cluster import close_dask, run_dask, start_dask
from cosim.study.grid import RunSpec
from cosim.study.pool import check_socket_room, run_local
from cosim.study.run_table import RunStatus
from cosim.study.store import (
    ResumeState,
    assemble,
    prepare_folder,
    provenance,
    resume_state,
    write_record,
)
from cosim.study.worker import OnRecord

if TYPE_CHECKING:  # pandas and scipy load lazily: a worker process needs neither
    import pandas as pd

    from cosim.progress import Bar


@dataclass(frozen=True)
class StudyOptions:
    """How a study runs and what it writes besides its records and tables."""

    workers: int | None = None  # local processes, or --dask local's (None: the cores)
    dask: str | None = None  # a Dask scheduler's address, or "local" (None: local pool)
    retry_failed: bool = False  # run the failed runs again
    restart: bool = False  # replace the runs the folder holds (another base allowed)
    progress: bool = True  # a progress bar on stderr
    plots: bool = True  # the density figure in DIR/plots/
    figure_format: str | None = None  # its format (None: png)
    title: str = "study"  # the bar's, study.json's and the figure's title


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


def run_study(specs: Sequence[RunSpec], out_dir: Path, options: StudyOptions | None = None,
              *, on_start: Callable[[int], None] | None = None) -> StudyResult:
    """Run what is not yet recorded, then write runs.csv, summary.csv and plots.

    `on_start(n_to_run)` is called once the input is known good (a Dask
    scheduler reached), just before anything is written. A folder whose runs were made
    from another base scenario (or duration, network, variant) is refused
    (`cosim.study.store.check_same_base`) unless `options.restart`, which removes its runs
    and starts afresh."""
    start = time.perf_counter()
    options = options or StudyOptions()
    out_dir = Path(out_dir)
    specs = list({s.run_id: s for s in specs}.values())  # a run listed twice runs once
    state = resume_state(specs, out_dir, restart=options.restart,
                         retry_failed=options.retry_failed)
    _run_pending(specs, out_dir, state, options, on_start)
    runs = assemble(specs, out_dir)
    from cosim.study.report import write_report  # pandas and scipy: the parent only

    summary, figures = write_report(runs, out_dir, title=options.title, plots=options.plots,
                                    figure_format=options.figure_format)
    return StudyResult(
        out_dir=out_dir, runs=runs, summary=summary, ran=len(state.todo), skipped=state.done,
        failed=int((runs["status"] != RunStatus.OK).sum()) if len(runs) else 0,
        wall_time=time.perf_counter() - start, plots=figures,
    )


def _run_pending(specs: Sequence[RunSpec], out_dir: Path, state: ResumeState,
                 options: StudyOptions, on_start: Callable[[int], None] | None) -> None:
    """Run `state.todo` on the chosen executor, each record written as its run finishes,
    the progress on a bar over the whole grid."""
    workers = options.workers or os.cpu_count() or 1
    # Connect first: a bad address is an input error, before anything is written.
    client = (start_dask(options.dask, workers)
              if options.dask is not None and state.todo else None)
    if options.dask is None and state.todo:
        check_socket_room()
    bar = None
    try:
        if on_start is not None:
            on_start(len(state.todo))
        prepare_folder(out_dir, specs, state.fingerprint, title=options.title,
                       restart=options.restart)
        bar = _progress_bar(len(specs), state, workers, options)
        on_record = _record_writer(out_dir, bar, state.failed)
        if client is not None:
            run_dask(state.todo, out_dir, client, on_record)
        elif state.todo:
            run_local(state.todo, out_dir, workers, on_record)
    finally:
        if bar is not None:
            bar.close()
        if client is not None:
            close_dask(client, options.dask)


def _progress_bar(total: int, state: ResumeState, workers: int, options: StudyOptions) -> Bar:
    """The study's bar, the runs done before already counted; its ETA from the rate after
    the first round of runs (the workers' start-up in it)."""
    from cosim.progress import Bar

    return Bar(total, initial=state.done, unit="run", desc=options.title,
               disable=not options.progress,
               warm=min(max(workers, 1), max(total - state.done, 1)))


def _record_writer(out_dir: Path, bar: Bar, failed_before: int) -> OnRecord:
    """The executors' `on_record`: write the record, with the code that made it (kept in
    the JSON only), and count it on the bar (failed ones apart)."""
    failed = [failed_before]
    code = provenance()

    def on_record(record: dict[str, Any]) -> None:
        record["code"] = code
        write_record(out_dir, record)
        if record["status"] != RunStatus.OK:
            failed[0] += 1
        bar.postfix(done=bar.n + 1, failed=failed[0])
        bar.update(1)

    bar.postfix(done=bar.n, failed=failed[0])
    return on_record
