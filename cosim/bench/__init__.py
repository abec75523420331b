"""Benchmarks for `cosim bench NAME`.

A benchmark's `measure(args)` returns
``{"title": str, "rows": [{"case": str, <figure>: float, ...}, ...],
"ratios": {name: float}, "targets": {name: str}, "notes": [str]}``:
rows of medians, and ratios measured side by side in the same run.
`report` prints it as a table, or as one JSON object of the same figures.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

BENCHMARKS = {
    "planner": "planning time: paper cases and a dense case, against a loop transcription",
    "control": "plant + controller wall time for a 10 s manoeuvre",
    "cosim": "a dense traffic run with our SV against SUMO alone",
    "batch": "the same study on 1 and on 2 workers",
    "tracking": "the plant's tracking error as corner motion: the default safety margin",
    "road": "the road frame's conversions (s, d) <-> (x, y) on the curved motorway",
    "measures": "what SUMO's detectors and SSM device cost a dense run",
    "fleet": "the fleet's automated vehicles: CPU per step over the share, per AV and part",
}


def median_time(
    fn: Callable[[], Any],
    repeats: int,
    warmup: int = 1,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """s, median time of `fn()` over `repeats` calls after `warmup` calls: wall time by
    default; `clock=time.process_time` gives CPU time, less sensitive to other
    processes competing for the cores."""
    for _ in range(warmup):
        fn()
    times = np.empty(repeats)
    for i in range(repeats):
        start = clock()
        fn()
        times[i] = clock() - start
    return float(np.median(times))


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "-"
        if value == 0 or 1e-3 <= abs(value) < 1e5:
            return f"{value:.4g}"
        return f"{value:.3e}"
    return str(value)


def report(result: dict[str, Any], *, as_json: bool = False) -> str:
    """The benchmark result as a readable table, or as one JSON object."""
    if as_json:
        return json.dumps(result, sort_keys=True)
    rows: list[dict[str, Any]] = result.get("rows", [])
    lines = [result.get("title", "benchmark"), ""]
    if rows:
        columns: list[str] = []
        for row in rows:
            columns += [k for k in row if k not in columns]
        cells = [[_fmt(row.get(c, "")) for c in columns] for row in rows]
        widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(columns)]
        lines.append("  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True)))
        lines.append("  ".join("-" * w for w in widths))
        lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    targets = result.get("targets", {})
    if result.get("ratios"):
        lines.append("")
        for name, value in result["ratios"].items():
            target = f"   (target: {targets[name]})" if name in targets else ""
            lines.append(f"{name}: {_fmt(float(value))}{target}")
    for note in result.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)
