"""`cosim bench fleet`: what the fleet's automated vehicles (AVs) cost per step.

The fleet scenario (scenarios/fleet_share20.toml by default) runs at several shares
(`--shares`, 0 first: the same traffic with no AV), medians of CPU time over repeats,
alternating so that drift hits all alike. Each row: the AVs taken over, the AVs driving
on average per step, CPU and wall time per step. The ratios: the marginal CPU per AV and
step (the least-squares slope of CPU per step over the mean AVs per step, the shares
with a fleet) and the fleet's fixed cost per step (its intercept over the run with none:
the whole-road read the fleet shares). One extra run at the highest share splits the
CPU per AV and step into the fleet's parts (`Fleet.observe`, `decide`, `advance`,
`stepped`), the policies' share being what a batched step of plants and controllers
cannot remove.

Not yet measured here: N fixed at 1, 10, 20, 50, 100 AVs, and the floor (SUMO with the
same AVs moved along their recorded paths).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from cosim.commands import count, seconds
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides

DEFAULT_FLEET = "scenarios/fleet_share20.toml"
DEFAULT_SHARES = (0.0, 0.1, 0.2, 0.4)
PARTS = ("observe", "decide", "advance", "stepped")  # Fleet's methods, in step order
TARGETS = {"marginal CPU per AV and step (us)": "<= 60"}


def _shares(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if not values or not all(0.0 <= v <= 1.0 for v in values):
        raise argparse.ArgumentTypeError(
            f"--shares {text!r}: comma-separated shares in [0, 1], e.g. 0,0.1,0.2")
    return values


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", type=Path, default=None,
                        help=f"the fleet scenario (default {DEFAULT_FLEET})")
    parser.add_argument("--shares", type=_shares, default=DEFAULT_SHARES,
                        help="comma-separated [fleet] shares (default 0,0.1,0.2,0.4)")
    parser.add_argument("--duration", type=seconds("--duration"), default=30.0,
                        help="simulated seconds per run (default 30)")
    parser.add_argument("--repeats", type=count("--repeats"), default=2,
                        help="repeats (median; default 2)")


def _with_share(scenario: Scenario, share: float) -> Scenario:
    return with_overrides(scenario, **{"fleet.share": share if share > 0 else None,
                                       "fleet.vtypes": None})


def fleet_run(scenario: Scenario) -> tuple[float, float, int, int, int]:
    """(wall s, CPU s, steps, AV-steps (trace rows of AVs), AVs taken over) of one run,
    nothing written."""
    from cosim.run.loop import simulate

    wall, cpu = time.perf_counter(), time.process_time()
    result = simulate(scenario)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    fleet = result.fleet
    av_steps = 0 if fleet is None else sum(len(t["t_s"]) for _, t, _ in fleet.traces)
    return wall, cpu, len(result.trace["t_s"]), av_steps, 0 if fleet is None else len(fleet.rows)


def part_split(scenario: Scenario) -> tuple[dict[str, float], tuple[float, float, int, int, int]]:
    """s of CPU time in each of the fleet's parts (PARTS) over one run, and that run's
    `fleet_run` figures."""
    from cosim.run.fleet import Fleet

    times = {name: 0.0 for name in PARTS}
    originals = {name: getattr(Fleet, name) for name in PARTS}

    def timed(name: str) -> Any:
        method = originals[name]

        def call(self: Fleet, *args: Any) -> Any:
            start = time.process_time()
            try:
                return method(self, *args)
            finally:
                times[name] += time.process_time() - start
        return call

    try:
        for name in PARTS:
            setattr(Fleet, name, timed(name))
        run = fleet_run(scenario)
    finally:
        for name, method in originals.items():
            setattr(Fleet, name, method)
    return times, run


def measure(args: argparse.Namespace) -> dict[str, Any]:
    path = args.scenario if args.scenario is not None else project_root() / DEFAULT_FLEET
    base = with_overrides(load_scenario(path), duration=float(args.duration))
    shares = tuple(sorted(set(args.shares) | {0.0}))
    repeats = max(int(args.repeats), 1)
    fleet_run(with_overrides(_with_share(base, max(shares)), duration=1.0))  # warm-up
    runs: dict[float, list[tuple[float, float, int, int, int]]] = {s: [] for s in shares}
    for _ in range(repeats):
        for share in shares:
            runs[share].append(fleet_run(_with_share(base, share)))
    rows, active, cpu_step = [], [], []
    for share in shares:
        wall = float(np.median([r[0] for r in runs[share]]))
        cpu = float(np.median([r[1] for r in runs[share]]))
        _, _, steps, av_steps, avs = runs[share][0]  # the same seed: the same fleet
        rows.append({"case": f"share {share:g}", "avs": avs,
                     "mean_avs_per_step": av_steps / steps,
                     "cpu_ms_per_step": 1e3 * cpu / steps,
                     "wall_ms_per_step": 1e3 * wall / steps})
        active.append(av_steps / steps)
        cpu_step.append(1e3 * cpu / steps)
    ratios: dict[str, float] = {}
    fleet_shares = [i for i, s in enumerate(shares) if s > 0]
    if len(fleet_shares) >= 2:
        x = np.array([active[i] for i in fleet_shares])
        y = np.array([cpu_step[i] for i in fleet_shares])
        slope, intercept = np.polyfit(x, y, 1)
        ratios["marginal CPU per AV and step (us)"] = float(1e3 * slope)
        ratios["fleet's fixed CPU per step (ms)"] = float(intercept - cpu_step[0])
    top = _with_share(base, max(shares))
    parts, (_, _, _, av_steps, _) = part_split(top)
    notes = [f"CPU per AV and step at share {max(shares):g}, by part: " + ", ".join(
        f"{name} {1e6 * parts[name] / max(av_steps, 1):.0f} us" for name in PARTS)]
    return {
        "title": f"fleet cost: {base.name}, {base.duration:g} s simulated, "
                 f"{base.traffic.density:g} veh/km/lane; median of {repeats}",
        "rows": rows, "ratios": ratios, "targets": TARGETS, "notes": notes,
        "parts_us_per_av_step": {k: 1e6 * v / max(av_steps, 1) for k, v in parts.items()},
    }
