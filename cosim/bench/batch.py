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
from pathlib import Path
from typing import Any

import numpy as np

from cosim.commands import count, max_workers, seconds
from cosim.scenario import project_root
from cosim.study.grid import GridValues, expand
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
    from cosim.commands.batch import parse_list
    from cosim.study.spec import DENSITY

    densities = parse_list(args.densities, "--densities", DENSITY) or (10.0,)
    from cosim.scenario import load_scenario

    load_scenario(args.scenario)  # a bad base scenario: one line now, not failed runs
    specs = expand(args.scenario, GridValues(
        densities=densities, seeds=range(1, args.seeds + 1), occupants=(0.5,), mus=(0.8,),
        drivers=(args.driver,), plants=("twotrack",), duration=args.duration,
    ))
    start_fork_server()  # the fork server's one-off start-up is no part of either case
    load_before = os.getloadavg()[0]
    cases = (1, args.workers)
    times: dict[int, list[float]] = {n: [] for n in cases}
    run_times: dict[int, list[float]] = {n: [] for n in cases}
    failed = 0
    ceilings = []
    for _ in range(args.repeats):
        ceilings.append(ceiling(args.workers))
        for n in cases:
            with tempfile.TemporaryDirectory(prefix="cosim-bench-batch-") as tmp:
                start = time.perf_counter()
                result = run_study(specs, Path(tmp),
                                   StudyOptions(workers=n, progress=False, plots=False))
                times[n].append(time.perf_counter() - start)
                run_times[n] += result.runs["wall_time_s"].tolist()
                failed += result.failed
    rows = []
    for n in cases:
        wall = float(np.median(times[n]))
        rows.append({"case": f"{n} worker{'s' if n > 1 else ''}", "runs": len(specs),
                     "wall_s": wall, "wall_per_run_s": wall / len(specs),
                     "run_median_s": float(np.median(run_times[n]))})
    # Ratio of each repeat's pair (measured back to back), then the median: more
    # robust to other jobs on a shared machine than a ratio of medians.
    paired = [a / b for a, b in zip(times[cases[0]], times[cases[1]], strict=True)]
    speedup = float(np.median(paired))
    notes = [
        f"{len(specs)} runs: densities {', '.join(f'{d:g}' for d in densities)} veh/km/lane x "
        f"seeds 1-{args.seeds}, driver {args.driver}, {args.duration:g} s simulated each, "
        f"base {args.scenario.name}; one fresh process per run; run_median_s: a run's own "
        "wall time (load, simulate) - it grows in the parallel case when the cores are shared",
        f"speed-up per repeat: {', '.join(f'{r:.2f}' for r in paired)} (reported: the median); "
        f"a pure-Python CPU loop on the same pool sizes just before each repeat: "
        f"{', '.join(f'{c:.2f}' for c in ceilings)} (what the machine gave then)",
        f"{os.cpu_count()} cores; median of {args.repeats} repeat(s); 1-min load average "
        f"{load_before:.1f} before, {os.getloadavg()[0]:.1f} after (other processes on the "
        "machine take cores from the 2-worker case and lower the ratio)",
    ]
    if failed:
        notes.append(f"{failed} runs failed (their time still counts)")
    return {
        "title": f"cosim bench batch: the same study on 1 and {args.workers} local processes",
        "rows": rows,
        "ratios": {f"speedup_{args.workers}_workers": speedup,
                   f"cpu_loop_speedup_{args.workers}_workers": float(np.median(ceilings))},
        "targets": {f"speedup_{args.workers}_workers": ">= 1.7 on 2 cores"},
        "notes": notes,
    }
