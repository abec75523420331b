"""`cosim bench fleet`: what the fleet's automated vehicles (AVs) cost per step.

By default a fixed number of AVs (`--avs`, default 1, 10, 20, 50, 100) in the fleet
scenario's dense traffic (scenarios/fleet_share20.toml with `[fleet] share = 1` and
`max_vehicles = N`: every vehicle SUMO inserts is automated until N drive, then as many
as keep N). Each case runs until N AVs drive, then `--window` s more; its figures are
those of that window alone (CPU and wall time per step, the AVs per step, the fleet's
parts per AV and step: `Fleet.observe`, `decide`, `advance`, `stepped`, each timed
around its call), beside its floor: SUMO with the SV and the same AVs moved along the
paths that run recorded by moveToXY, taken over and handed back at the same steps,
nothing read, planned, controlled or checked (cosim.traffic.takeover's `replay`, as
`cosim bench cosim`'s floor for one SV), timed over the same steps. The ratios: cosim /
floor per N (CPU), the marginal CPU per AV and step (least-squares slope of CPU per step
over the AVs per step, cosim's and the floor's) and how much faster than real time the
largest N runs. Medians over `--repeats`, the cases alternating so that drift hits all
alike.

`--shares` instead runs the scenario as it is at those shares (0 added: the same
traffic with no AV) over its whole duration: the marginal CPU per AV and step as the
slope over the mean AVs per step, the fleet's fixed cost, and one extra run's part
split at the highest share.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from cosim.commands import count, number_list, seconds
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides

DEFAULT_FLEET = "scenarios/fleet_share20.toml"
DEFAULT_AVS = (1, 10, 20, 50, 100)
PARTS = ("observe", "decide", "advance", "stepped")  # Fleet's methods, in step order
TARGETS = {"marginal CPU per AV and step (us)": "<= 60"}
N_TARGETS = {"marginal CPU per AV and step (us)": "<= 60 (at N = 20 and 100)",
             "cosim / floor at N = 20 (cpu)": "<= 2.0", "cosim / floor at N = 1 (cpu)": "<= 1.25"}
FILL_LIMIT = 150.0  # s simulated, at most, for the inflow to bring N AVs


avs_flag = number_list("--avs", int, 1, 1000, "numbers of AVs", "1,10,20")
shares_flag = number_list("--shares", float, 0.0, 1.0, "shares", "0,0.1,0.2")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", type=Path, default=None,
                        help=f"the fleet scenario (default {DEFAULT_FLEET})")
    parser.add_argument("--avs", default=DEFAULT_AVS,
                        type=avs_flag,
                        help="comma-separated numbers of AVs driving at once "
                             "(default 1,10,20,50,100)")
    parser.add_argument("--window", type=seconds("--window"), default=5.0,
                        help="simulated seconds measured once N AVs drive (default 5)")
    parser.add_argument("--shares", default=None,
                        type=shares_flag,
                        help="instead of --avs: comma-separated [fleet] shares over the "
                             "scenario's whole run, e.g. 0,0.1,0.2,0.4")
    parser.add_argument("--duration", type=seconds("--duration"), default=30.0,
                        help="with --shares: simulated seconds per run (default 30)")
    parser.add_argument("--repeats", type=count("--repeats"), default=1,
                        help="repeats (median; default 1)")


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
    if args.shares is None:
        return measure_avs(load_scenario(path), tuple(sorted(set(args.avs))),
                           float(args.window), max(int(args.repeats), 1))
    return measure_shares(load_scenario(path), args)


def measure_shares(scenario: Scenario, args: argparse.Namespace) -> dict[str, Any]:
    """The `--shares` figures (module docstring)."""
    base = with_overrides(scenario, duration=float(args.duration))
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


# ---------------------------------------------------------------- N AVs at once
class _Window:
    """A fleet run's clock: CPU and wall time at the top of each row, the AVs then and
    the fleet's parts; it ends the run `window` rows after N AVs first drive."""

    def __init__(self, n: int, window: int) -> None:
        self.n, self.window = n, window
        self.cpu: list[float] = []
        self.wall: list[float] = []
        self.avs: list[int] = []
        self.parts: list[dict[str, float]] = []
        self.first = -1  # the first row with N AVs driving (-1: not yet)

    def row(self, k: int, active: int) -> None:
        self.cpu.append(time.process_time())
        self.wall.append(time.perf_counter())
        self.avs.append(active)
        if self.first < 0 and active >= self.n:
            self.first = k

    def done(self, k: int) -> bool:
        return self.first >= 0 and k >= self.first + self.window

    def span(self) -> tuple[int, int]:
        """Rows (first, last) of the window (the whole run if N was never reached)."""
        if self.first < 0:
            return 0, len(self.cpu) - 1
        return self.first, min(self.first + self.window, len(self.cpu) - 1)


def fleet_window_run(scenario: Scenario, n: int, window: int
                     ) -> tuple[_Window, dict[str, Any], Any]:
    """One run of `scenario` (share 1, max_vehicles n) until `window` rows after n AVs
    drive: its clock, the parts' CPU time (s) over the window, and its RunResult."""
    from cosim.run.fleet import Fleet
    from cosim.run.loop import CoSimulation

    clock = _Window(n, window)
    parts = {name: 0.0 for name in PARTS}
    originals = {name: getattr(Fleet, name) for name in PARTS}

    def timed(name: str) -> Any:
        method = originals[name]

        def call(self: Fleet, *args: Any) -> Any:
            if name == "observe":
                clock.row(args[0], len(self.active))
            start = time.process_time()
            try:
                return method(self, *args)
            finally:
                if clock.first >= 0 and len(clock.cpu) - 1 < clock.first + window:
                    parts[name] += time.process_time() - start
        return call

    class WindowStop:
        """The run's stop rules, and the end of the window."""

        def __init__(self, rules: Any) -> None:
            self.rules = rules

        def __getattr__(self, name: str) -> Any:
            return getattr(self.rules, name)

        def stops(self, k: int, *args: Any) -> bool:
            if self.rules.stops(k, *args):
                return True
            if clock.done(k):
                self.rules.last_row = k
                return True
            return False

    class Windowed(CoSimulation):
        def _start(self) -> None:
            super()._start()
            self.stop = WindowStop(self.stop)  # type: ignore[assignment]

    try:
        for name in PARTS:
            setattr(Fleet, name, timed(name))
        result = Windowed(scenario).run()
    finally:
        for name, method in originals.items():
            setattr(Fleet, name, method)
    return clock, parts, result


def _path(vehicle_id: str, k0: int, trace: dict[str, Any], handed_back: bool = False) -> Any:
    from cosim.traffic.takeover import RecordedPath

    return RecordedPath(vehicle_id, k0, trace["x_m"].tolist(), trace["y_m"].tolist(),
                        np.radians(trace["psi_deg"]).tolist(), trace["vx_mps"].tolist(),
                        trace["ax_mps2"].tolist(), handed_back)


def fleet_floor(scenario: Scenario, result: Any, span: tuple[int, int]
                ) -> tuple[float, float, int]:
    """(CPU s, wall s over the rows `span`, AVs missing at their takeover) of the floor
    of a fleet run's `result`: the same scenario's SUMO with the SV and the AVs moved
    along their recorded paths (cosim.traffic.takeover.Takeovers.replay)."""
    from cosim.traffic.takeover import Takeovers
    from cosim.traffic.world import SV_ID, World

    sc = scenario
    sv = _path(SV_ID, 0, result.trace)
    fleet = result.fleet
    ends = {row["vehicle_id"]: row["end"] for row in fleet.rows}
    step = sc.step
    avs = [_path(vid, round(float(trace["t_s"][0]) / step), trace,
                 ends[vid] == "handed_back") for vid, trace, _ in fleet.traces]
    cpu: dict[int, float] = {}
    wall: dict[int, float] = {}

    def on_row(k: int) -> None:
        if k in span:
            cpu[k], wall[k] = time.process_time(), time.perf_counter()

    world = World(sc)
    try:
        road = world.start()
        world.add_controlled(SV_ID, world.sv_start_x, road.lane_center(sc.sv.lane), 0.0,
                             sc.sv.speed, (sc.vehicle.length, sc.vehicle.width), sc.sv.lane)
        world.insert()
        missing = Takeovers(world).replay(sv, avs, (sc.vehicle.length, sc.vehicle.width),
                                          on_row)
    finally:
        world.close()
    first, last = span
    return cpu[last] - cpu[first], wall[last] - wall[first], missing


def measure_avs(scenario: Scenario, counts: tuple[int, ...], window_s: float,
                repeats: int) -> dict[str, Any]:
    """The default figures (module docstring): one row per number of AVs."""
    step = scenario.step
    window = max(int(round(window_s / step)), 1)

    def case(n: int) -> Scenario:
        return with_overrides(scenario, duration=FILL_LIMIT + window_s,
                              **{"fleet.share": 1.0, "fleet.vtypes": None,
                                 "fleet.max_vehicles": n})

    fleet_window_run(with_overrides(case(1), duration=1.0), 1, 1)  # warm-up (numba, SUMO)
    got: dict[int, list[dict[str, Any]]] = {n: [] for n in counts}
    for _ in range(repeats):
        for n in counts:
            sc = case(n)
            clock, parts, result = fleet_window_run(sc, n, window)
            first, last = clock.span()
            steps = max(last - first, 1)
            floor_cpu, floor_wall, missing = fleet_floor(sc, result, (first, last))
            avs = float(np.mean(clock.avs[first:last])) if last > first else 0.0
            got[n].append({
                "cpu": (clock.cpu[last] - clock.cpu[first]) / steps,
                "wall": (clock.wall[last] - clock.wall[first]) / steps,
                "floor_cpu": floor_cpu / steps, "floor_wall": floor_wall / steps,
                "avs": avs, "reached": clock.first >= 0, "t_reached": first * step,
                "missing": missing,
                "parts": {k: v / max(avs * steps, 1.0) for k, v in parts.items()}})
    rows, x, y, y_floor = [], [], [], []
    for n in counts:
        runs = got[n]

        def med(key: str, runs: list[dict[str, Any]] = runs) -> float:
            return float(np.median([r[key] for r in runs]))

        cpu, floor = med("cpu"), med("floor_cpu")
        rows.append({"case": f"N = {n}" + ("" if runs[0]["reached"] else " (not reached)"),
                     "avs_per_step": med("avs"), "from_t_s": runs[0]["t_reached"],
                     "cpu_ms_per_step": 1e3 * cpu, "wall_ms_per_step": 1e3 * med("wall"),
                     "floor_cpu_ms_per_step": 1e3 * floor,
                     "floor_wall_ms_per_step": 1e3 * med("floor_wall"),
                     "cosim_over_floor_cpu": cpu / floor,
                     **{f"{k}_us_per_av": 1e6 * float(np.median([r["parts"][k] for r in runs]))
                        for k in PARTS}})
        x.append(med("avs"))
        y.append(1e3 * cpu)
        y_floor.append(1e3 * floor)
    ratios: dict[str, float] = {}
    for row, n in zip(rows, counts, strict=True):
        ratios[f"cosim / floor at N = {n} (cpu)"] = row["cosim_over_floor_cpu"]
    if len(counts) >= 2:
        ratios["marginal CPU per AV and step (us)"] = float(1e3 * np.polyfit(x, y, 1)[0])
        ratios["floor's marginal CPU per AV and step (us)"] = float(
            1e3 * np.polyfit(x, y_floor, 1)[0])
    top = rows[-1]
    ratios[f"real-time factor at N = {counts[-1]} (cpu)"] = (
        1e3 * step / top["cpu_ms_per_step"])
    missing = sum(r["missing"] for runs in got.values() for r in runs)
    import os

    notes = [
        f"each case: share 1 and max_vehicles N in {scenario.name}'s traffic, measured over "
        f"{window_s:g} s from the step N AVs first drove (from_t_s); the floor over the same "
        "steps",
        "parts: CPU per AV and step of the fleet's methods in the window (cosim.run.fleet)",
        f"AVs not on the network at their takeover in the floor (its SUMO traffic drifted "
        f"from the run's): {missing}",
        f"1-min load average {os.getloadavg()[0]:.2f} at the end, {os.cpu_count()} cores",
    ]
    return {
        "title": f"fleet cost at N AVs: {scenario.name}, "
                 f"{scenario.traffic.density:g} veh/km/lane; median of {repeats}",
        "rows": rows, "ratios": ratios, "targets": N_TARGETS, "notes": notes,
    }
