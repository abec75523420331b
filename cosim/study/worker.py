"""One run of a study as its record: `execute_run` is the one function the workers of
both executors (cosim.study.pool, cosim.study.dask_cluster) call. It runs
`cosim.run.loop.run_scenario` and turns every exception into a failed record;
`failed_record` is the record of a run whose worker never returned."""

from __future__ import annotations

import math
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cosim.study.grid import RunSpec, apply_spec
from cosim.study.run_table import RunStatus

# What an executor calls with each finished run's record, in the parent process.
OnRecord = Callable[[dict[str, Any]], None]


def execute_run(spec: RunSpec, out_dir: str, tmp_root: str | None = None) -> dict[str, Any]:
    """Run one grid point and return its record; never raises.

    A run that raises is returned as a failed record with the error's type and message
    (and the traceback, kept in the JSON record only). `tmp_root`: the folder this
    process makes its temporary folders in (its executor removes it, whatever this process
    left); only for a process that runs this one run (cosim.study.pool's workers)."""
    start = time.perf_counter()
    if tmp_root is not None:
        import os
        import tempfile

        tempfile.tempdir = os.environ["TMPDIR"] = tmp_root
    record: dict[str, Any] = {"run_id": spec.run_id, **spec.parameters()}
    try:
        from cosim.run.loop import run_scenario

        scenario = apply_spec(spec)
        # Traces (trace.csv, plans.csv, metrics.csv, timing.csv) only when asked.
        run_dir = Path(out_dir) / "traces" / spec.run_id if spec.traces else None
        metrics = run_scenario(
            scenario, run_dir, write_trace=True, write_figures=False, progress=False, gui=False
        )
        record.update(status=RunStatus.OK, error="")
        for key, value in metrics.items():
            if key not in record:  # the grid's own values win over the scenario echo
                record[key] = _plain(value)
    except Exception as exc:
        record.update(
            status=RunStatus.FAILED, error=error_text(exc), traceback=traceback.format_exc()
        )
    record["wall_time_s"] = time.perf_counter() - start
    return record


def error_text(exc: BaseException) -> str:
    """One line: the exception's type and message."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def failed_record(spec: RunSpec, error: str, wall_time: float = math.nan) -> dict[str, Any]:
    """The record of a run whose worker never returned (its process died)."""
    return {
        "run_id": spec.run_id, **spec.parameters(), "status": RunStatus.FAILED,
        "error": error, "wall_time_s": wall_time,
    }


def _plain(value: Any) -> Any:
    """numpy scalars -> Python scalars, so records are plain JSON."""
    if isinstance(value, np.generic):
        return value.item()
    return value
