"""`cosim bench batch`: the same study on 1 and on N local worker processes.

The study (densities x seeds on one base scenario, one driver) runs into a
fresh temporary folder each time, so nothing is skipped; the ratio of the wall
times is the speed-up of the process pool on this machine (target: >= 1.7 on
2 cores). Repeats alternate 1 and N workers and report medians.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cosim.commands import count, max_workers, seconds
from cosim.scenario import project_root
from cosim.study.grid import GridValues, RunSpec, expand
from cosim.study.pool import start_fork_server
from cosim.study.run_table import Driver
from cosim.study.runner import StudyOptions, run_study


def _spin(n: int) -> float:
    """s, wall time of a pure-Python CPU loop (the machine's parallel ceiling)."""
    start = time.perf_counter()
    total = 0
    for i in range(n):
        total += i
    return time.perf_counter() - start


def ceiling(workers: int, tasks: int = 4, n: int = 10_000_000) -> float:
    """Speed-up of `tasks` CPU loops on `workers` processes over 1, measured now:
    what the machine gives at this moment (other jobs take cores too)."""
    walls = []
    for w in (1, workers):
        with cf.ProcessPoolExecutor(w) as pool:
            start = time.perf_counter()
            list(pool.map(_spin, [n] * tasks))
            walls.append(time.perf_counter() - start)
    return walls[0] / walls[1]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", type=Path,
                        default=project_root() / "scenarios" / "study_density_base.toml",
                        help="base scenario (default: scenarios/study_density_base.toml)")
    parser.add_argument("--densities", default="10,20", help="veh/km/lane, comma-separated")
    parser.add_argument("--seeds", type=count("--seeds", hi=1000), default=8,
                        help="seeds 1..N per density (at most 1000)")
    parser.add_argument("--driver", default=Driver.MIMO, choices=tuple(Driver),
                        help="mimo, siso or sumo")
    parser.add_argument("--duration", type=seconds("--duration"), default=20.0,
                        help="s, simulated time per run")
    parser.add_argument("--workers", type=count("--workers", hi=max_workers()),
                        default=os.cpu_count() or 2, help="workers of the parallel case "
                        f"(default: the machine's cores; at most {max_workers()})")
    parser.add_argument("--repeats", type=count("--repeats"), default=3,
                        help="repeats of each case")


def measure(args: argparse.Namespace) -> dict[str, Any]:
    densities, specs = _specs(args)
    start_fork_server()  # the fork server's one-off start-up is no part of either case
    load_before = os.getloadavg()[0]
    timed = _time_cases(specs, args)
    # Ratio of each repeat's pair (measured back to back), then the median: more
    # robust to other jobs on a shared machine than a ratio of medians.
    paired = [a / b for a, b in zip(timed.times[1], timed.times[args.workers], strict=True)]
    notes = [
        f"{len(specs)} runs: densities {', '.join(f'{d:g}' for d in densities)} veh/km/lane x "
        f"seeds 1-{args.seeds}, driver {args.driver}, {args.duration:g} s simulated each, "
        f"base {args.scenario.name}; one fresh process per run; run_median_s: a run's own "
        "wall time (load, simulate) - it grows in the parallel case when the cores are shared",
        f"speed-up per repeat: {', '.join(f'{r:.2f}' for r in paired)} (reported: the median); "
        f"a pure-Python CPU loop on the same pool sizes just before each repeat: "
        f"{', '.join(f'{c:.2f}' for c in timed.ceilings)} (what the machine gave then)",
        f"{os.cpu_count()} cores; median of {args.repeats} repeat(s); 1-min load average "
        f"{load_before:.1f} before, {os.getloadavg()[0]:.1f} after (other processes on the "
        "machine take cores from the 2-worker case and lower the ratio)",
    ]
    if timed.failed:
        notes.append(f"{timed.failed} runs failed (their time still counts)")
    return {
        "title": f"cosim bench batch: the same study on 1 and {args.workers} local processes",
        "rows": _rows(timed, len(specs)),
        "ratios": {f"speedup_{args.workers}_workers": float(np.median(paired)),
                   f"cpu_loop_speedup_{args.workers}_workers": float(np.median(timed.ceilings))},
        "targets": {f"speedup_{args.workers}_workers": ">= 1.7 on 2 cores"},
        "notes": notes,
    }


def _specs(args: argparse.Namespace) -> tuple[tuple[float, ...], list[RunSpec]]:
    """The densities and the runs of the benchmark's study."""
    from cosim.commands.batch import parse_list
    from cosim.scenario import load_scenario
    from cosim.study.spec import DENSITY

    densities = parse_list(args.densities, "--densities", DENSITY) or (10.0,)
    load_scenario(args.scenario)  # a bad base scenario: one line now, not failed runs
    specs = expand(args.scenario, GridValues(
        densities=densities, seeds=range(1, args.seeds + 1), occupants=(0.5,), mus=(0.8,),
        drivers=(args.driver,), plants=("twotrack",), duration=args.duration,
    ))
    return densities, specs


@dataclass
class _Timings:
    """Per case (1 and N workers): each repeat's wall time and every run's own."""

    cases: tuple[int, int]  # workers: 1, then N
    times: dict[int, list[float]]  # s, the study's wall time per repeat
    run_times: dict[int, list[float]]  # s, each run's `wall_time_s`
    failed: int  # failed runs over all cases and repeats
    ceilings: list[float]  # the CPU loop's speed-up measured before each repeat


def _time_cases(specs: list[RunSpec], args: argparse.Namespace) -> _Timings:
    """The study on 1 and on `args.workers` workers, `args.repeats` times, alternating."""
    cases = (1, args.workers)
    timed = _Timings(cases, {n: [] for n in cases}, {n: [] for n in cases}, 0, [])
    for _ in range(args.repeats):
        timed.ceilings.append(ceiling(args.workers))
        for n in cases:
            with tempfile.TemporaryDirectory(prefix="cosim-bench-batch-") as tmp:
                start = time.perf_counter()
                result = run_study(specs, Path(tmp),
                                   StudyOptions(workers=n, progress=False, plots=False))
                timed.times[n].append(time.perf_counter() - start)
                timed.run_times[n] += result.runs["wall_time_s"].tolist()
                timed.failed += result.failed
    return timed


def _rows(timed: _Timings, n_runs: int) -> list[dict[str, Any]]:
    rows = []
    for n in timed.cases:
        wall = float(np.median(timed.times[n]))
        rows.append({"case": f"{n} worker{'s' if n > 1 else ''}", "runs": n_runs,
                     "wall_s": wall, "wall_per_run_s": wall / n_runs,
                     "run_median_s": float(np.median(timed.run_times[n]))})
    return rows
