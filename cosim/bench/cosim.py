"""`cosim bench cosim`: what our SV costs on top of the traffic simulation.

Side by side in one run, medians over repeats, each from SUMO start to close:

- "sumo alone": the scenario's random traffic (same network, density, seed,
  inflow, lane-change settings, band rule) stepped by SumoSim with no SV, and
  the same with an SV that SUMO drives (no co-simulation loop at all);
- "cosim": the same scenario with our SV (planner, controller, plant, V2V,
  decision rule, moveToXY write-back, per-step trace and collision check);
- "cosim, SUMO drives the SV": the same loop with the SUMO-native baseline SV
  (what the loop's bookkeeping costs without planner, controller and plant);
- "the floor": SUMO with the same traffic and the SV moved along the path our SV
  drove (recorded in the cosim run just before) by moveToXY and nothing else: what
  SUMO's step costs with an externally moved vehicle (more than SUMO alone), so that
  cosim / floor is the loop's own cost (target <= 1.25, CPU);
- "the floor and the loop's scene read": the floor plus the scene read exactly as the
  cosim run read it each step (every vehicle within the observer's radius: the near
  scene, NEAR_RANGE + 2 SV lengths with five libsumo getters each, or the V2V range
  with seven when the channel runs every step). Any SV of the loop makes these SUMO
  calls whatever it plans, so floor-and-read / floor is the least cosim / floor can
  be, and cosim / floor-and-read is what our own planning, control and recording add;
- "curved twin": the dense scenario's twin on the curved motorway (targets: CPU within
  1.3x of the straight road's, median plan() within 2x);
- a paper case (5.1 by default): its real-time factor, simulated / wall time.

Targets: cosim / sumo alone <= 1.25, cosim / floor <= 1.25 on CPU time; the paper case
>= 50x real time. One extra cosim run, not in the
rows, splits the loop's wall time into its parts (`phase_split`, a note and `phases`).

The closed loop is compiled (numba): its start-up in this process is timed once
before the warm-up runs and reported apart (`numba_startup_s`), not in the rows.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from cosim.commands import count, seconds
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides

DEFAULT_DENSE = "scenarios/traffic_high.toml"
DEFAULT_PAPER = "scenarios/paper_case1_overtaking.toml"
DEFAULT_CURVED = "scenarios/curved_traffic_high.toml"  # traffic_high's curved twin


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", type=Path, default=None,
                        help=f"dense traffic scenario (default {DEFAULT_DENSE})")
    parser.add_argument("--curved", type=Path, default=None,
                        help=f"the dense scenario's twin on a curved route (default: "
                             f"{DEFAULT_CURVED}); run for as long")
    parser.add_argument("--paper", type=Path, default=None,
                        help=f"paper case for the real-time factor (default {DEFAULT_PAPER})")
    parser.add_argument("--duration", type=seconds("--duration"), default=30.0,
                        help="simulated seconds of the dense run (default 30)")
    parser.add_argument("--repeats", type=count("--repeats"), default=3,
                        help="repeats (median; default 3)")


def sumo_alone(scenario: Scenario, *, with_sv: bool = False) -> tuple[float, float]:
    """s, wall and CPU time of the scenario's traffic stepped by SumoSim alone, SUMO
    start to close; with_sv: an SV of the scenario's size at its start, driven by
    SUMO's own models (no co-simulation loop at all)."""
    from cosim.traffic.demand import populate, start_zone
    from cosim.traffic.process import SumoOptions
    from cosim.traffic.route_lanes import sv_start
    from cosim.traffic.sumo import SumoSim
    from cosim.traffic.world import SV_ID, SV_LENGTH_MARGIN

    start, cpu = time.perf_counter(), time.process_time()
    tr = scenario.traffic
    sim = SumoSim(scenario.network, scenario.step, scenario.seed,
                  SumoOptions(lanechange_duration=tr.lanechange_duration, sublane=tr.sublane),
                  speed_bands=scenario.road.speed_bands)
    with sim:
        _, x0 = sv_start(sim.lanes.route_road, scenario.sv.edge, scenario.sv.lane,
                         scenario.sv.position)
        margin = SV_LENGTH_MARGIN * scenario.vehicle.length
        if tr.density > 0:
            sv = scenario.sv
            zone = start_zone(x0, scenario.vehicle.length, sv.speed,
                              scenario.road.speed_bands[sv.lane][1])
            populate(sim, sim.road(), tr.density, scenario.seed, tr.length,
                     exclude_zone=(x0 - margin, x0 + margin), lane_zones={sv.lane: zone})
        if with_sv:
            sv = scenario.sv
            desired = sv.desired_speed or scenario.road.speed_bands[sv.lane][1]
            sim.add_driven(SV_ID, sv.lane, sim.centre_pose(sv.lane, x0), sv.speed, desired,
                           scenario.vehicle.length, scenario.vehicle.width,
                           own_lane_changes=sv.decision)
            sim.step()
            sim.controlled.release(SV_ID)
        for _ in range(scenario.n_steps + (0 if with_sv else 1)):
            sim.step()
    return time.perf_counter() - start, time.process_time() - cpu


SvPath = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def cosim_run(scenario: Scenario) -> tuple[float, float, dict[str, Any]]:
    """s, wall and CPU time of the full co-simulation (nothing written), its timing row
    with the scene reads' part of wall_sumo_s (`wall_read_s`), the SV's path
    (`path`: x, y, heading, speed, acceleration per step, as written to SUMO) and how
    the loop read the scene (`scene_read`: radius in m, accelerations and signals)."""
    from cosim.planning.planner import LaneChangePlanner
    from cosim.run.loop import CoSimulation

    plan_times: list[float] = []
    plan = LaneChangePlanner.plan

    def timed(self: LaneChangePlanner, *args: Any, **kwargs: Any) -> Any:
        made = plan(self, *args, **kwargs)
        plan_times.append(made.planning_time_s)
        return made

    start, cpu = time.perf_counter(), time.process_time()
    LaneChangePlanner.plan = timed  # type: ignore[method-assign]
    try:
        sim = CoSimulation(scenario)
        result = sim.run()
    finally:
        LaneChangePlanner.plan = plan  # type: ignore[method-assign]
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    tr = result.trace
    path = (tr["x_m"], tr["y_m"], np.radians(tr["psi_deg"]), tr["vx_mps"], tr["ax_mps2"])
    return wall, cpu, {**result.timing, "wall_read_s": sim.world.wall_read, "path": path,
                       "plan_times": plan_times,
                       "scene_read": (sim.observer.radius, sim.observer.full_scene)}


# The loop's parts timed by `phase_split`: (name, the CoSimulation attribute, its method).
PHASES = (("sumo_step", "world", "step"), ("scene_read", "world", "read"),
          ("record", "recorder", "record"), ("policy", "policy", "update"),
          ("control", "ego", "advance"))


def phase_split(scenario: Scenario) -> dict[str, float]:
    """s of wall time per part of one extra cosim run (not in the rows): SUMO's step with
    its hooks and SUMO's collisions (`World.step`), the scene read (`World.read`), the
    trace row with the overlap check (`Recorder.record`), the policy (`update`: decision
    rule, gap choice, planning), control + plant + moveToXY (`Ego.advance`), and `other`:
    the rest of the run (SUMO start and traffic, the scene's TVs and the SV's state, the
    ego's trace columns, gap requests, the scripted TVs, the run's result). Each part is
    timed by a wrapper around that method of this run's objects (about 0.2 us a call)."""
    from cosim.run.loop import CoSimulation

    times = {name: 0.0 for name, _, _ in PHASES}

    def timed(fn: Any, name: str) -> Any:
        def call(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                times[name] += time.perf_counter() - start
        return call

    class Timed(CoSimulation):
        def _start(self) -> None:
            super()._start()
            for name, owner, method in PHASES:
                obj = getattr(self, owner)
                setattr(obj, method, timed(getattr(obj, method), name))

    start = time.perf_counter()
    Timed(scenario).run()
    times["other"] = time.perf_counter() - start - sum(times.values())
    return times


def sumo_floor(scenario: Scenario, path: SvPath,
               read: tuple[float, bool] | None = None) -> tuple[float, float]:
    """s, wall and CPU time of SUMO with the scenario's traffic and the SV moved along
    `path` by moveToXY, SUMO start to close: the World's start and insertion, then per
    step one move and one SUMO step (its hooks included), nothing planned, controlled
    or recorded; nothing read, or with `read` (radius in m, full; `cosim_run`'s
    `scene_read`) the scene as the loop reads it each step: the SUMO calls every SV
    of the loop makes, whatever it plans."""
    from cosim.traffic.world import SV_ID, World

    x, y, heading, speed, accel = (a.tolist() for a in path)
    start, cpu = time.perf_counter(), time.process_time()
    world = World(scenario)
    try:
        road = world.start()
        sc = scenario
        world.add_controlled(SV_ID, world.sv_start_x, road.lane_center(sc.sv.lane), 0.0,
                             sc.sv.speed, (sc.vehicle.length, sc.vehicle.width), sc.sv.lane)
        world.insert()
        n = min(scenario.n_steps + 1, len(x))
        world.replay_sv(x[:n], y[:n], heading[:n], speed[:n], accel[:n], read)
    finally:
        world.close()
    return time.perf_counter() - start, time.process_time() - cpu


def _rest(timing: dict[str, Any]) -> float:
    """s, a run's wall time outside SUMO's steps and reads, control and planning."""
    parts = ("wall_sumo_s", "wall_control_s", "wall_planning_s")
    return float(timing.get("wall_time_s", 0.0)) - sum(float(timing.get(k, 0.0)) for k in parts)


def _median(values: list[float]) -> float:
    """The median, NaN for none (a run that planned nothing)."""
    return float(np.median(values)) if values else float("nan")


def _path(given: Path | None, default: str) -> Path:
    return given if given is not None else project_root() / default


class Cases(NamedTuple):
    """The scenarios the bench runs."""

    dense: Scenario  # the dense traffic of the comparison (--scenario)
    curved: Scenario  # its twin on the curved motorway (--curved)
    baseline: Scenario  # the dense one with the SUMO-native baseline SV
    paper: Scenario  # a paper case, for its real-time factor (--paper)


ROW_KEYS = ("alone", "alone_sv", "floor", "floor_read", "ours", "curved", "baseline", "paper")
TARGETS = {"cosim / sumo alone": "<= 1.25", "cosim / floor (cpu)": "<= 1.25",
           "curved / straight (cpu)": "<= 1.3", "median plan() curved / straight": "<= 2",
           "paper case real-time factor": ">= 50"}


def _cases(args: argparse.Namespace) -> Cases:
    dense = with_overrides(load_scenario(_path(args.scenario, DEFAULT_DENSE)),
                           duration=float(args.duration))
    paper = load_scenario(_path(args.paper, DEFAULT_PAPER))
    curved = with_overrides(load_scenario(_path(args.curved, DEFAULT_CURVED)),
                            duration=float(args.duration))
    return Cases(dense, curved, with_overrides(dense, controller="sumo"), paper)


def _repeated(cases: Cases, repeats: int) -> tuple[dict[str, list[float]], dict[str, list[float]],
                                                   dict[str, list[float]], dict[str, Any]]:
    """(wall s, CPU s per row key, plan() s of the straight and curved runs, the last
    cosim run's timing): a warm-up, then every case once per repeat, alternating so
    that drift hits all alike."""
    dense = cases.dense
    sumo_alone(with_overrides(dense, duration=1.0), with_sv=True)
    cosim_run(with_overrides(dense, duration=1.0))
    plans: dict[str, list[float]] = {"ours": [], "curved": []}  # s, every plan() call
    walls: dict[str, list[float]] = {k: [] for k in ROW_KEYS}
    cpus: dict[str, list[float]] = {k: [] for k in ROW_KEYS}

    def timed(key: str, measured: tuple[Any, ...]) -> tuple[Any, ...]:
        walls[key].append(measured[0])
        cpus[key].append(measured[1])
        return measured

    timing: dict[str, Any] = {}
    for _ in range(repeats):
        timed("alone", sumo_alone(dense))
        timed("alone_sv", sumo_alone(dense, with_sv=True))
        timing = timed("ours", cosim_run(dense))[2]
        plans["ours"] += timing["plan_times"]
        timed("floor", sumo_floor(dense, timing["path"]))  # the path just driven
        timed("floor_read", sumo_floor(dense, timing["path"], timing["scene_read"]))
        plans["curved"] += timed("curved", cosim_run(cases.curved))[2]["plan_times"]
        timed("baseline", cosim_run(cases.baseline))
        timed("paper", cosim_run(cases.paper))
    return walls, cpus, plans, timing


def _rows(cases: Cases, w: dict[str, float], c: dict[str, float]) -> list[dict[str, Any]]:
    """One row per case: median wall and CPU time, per step, real-time factors."""
    dense, curved, baseline, paper = cases
    rows = []
    for key, label, sc in (("alone", f"sumo alone ({dense.name})", dense),
                           ("alone_sv", f"sumo alone, with a SUMO-driven SV ({dense.name})",
                            dense),
                           ("floor", f"the floor: SUMO, the SV moved along its path by "
                            f"moveToXY ({dense.name})", dense),
                           ("floor_read", f"the floor and the loop's scene read "
                            f"({dense.name})", dense),
                           ("ours", f"cosim, our SV ({dense.name})", dense),
                           ("curved", f"cosim, our SV, curved twin ({curved.name})", curved),
                           ("baseline", f"cosim, SUMO drives the SV ({dense.name})", baseline),
                           ("paper", f"paper case ({paper.name})", paper)):
        rows.append({"case": label, "wall_s": w[key], "cpu_s": c[key],
                     "per_step_ms": 1e3 * w[key] / sc.n_steps,
                     "realtime_x": sc.duration / w[key], "realtime_cpu_x": sc.duration / c[key]})
    return rows


def _ratios(cases: Cases, w: dict[str, float], c: dict[str, float],
            plans: dict[str, list[float]], startup: float) -> dict[str, float]:
    t_alone, t_ours, t_paper = w["alone"], w["ours"], w["paper"]
    paper = cases.paper
    return {
        "cosim / sumo alone": t_ours / t_alone,
        "cosim / sumo alone (cpu)": c["ours"] / c["alone"],
        "cosim / sumo alone with a SUMO-driven SV": t_ours / w["alone_sv"],
        "cosim / floor": t_ours / w["floor"],
        "cosim / floor (cpu)": c["ours"] / c["floor"],
        "floor / sumo alone (cpu)": c["floor"] / c["alone"],
        "floor and scene read / floor (cpu)": c["floor_read"] / c["floor"],
        "cosim / floor and scene read (cpu)": c["ours"] / c["floor_read"],
        "cosim / cosim with the SUMO baseline SV": t_ours / w["baseline"],
        "curved / straight (cpu)": c["curved"] / c["ours"],
        "median plan() curved / straight": _median(plans["curved"]) / _median(plans["ours"]),
        "median plan() straight (ms)": 1e3 * _median(plans["ours"]),
        "paper case real-time factor": paper.duration / t_paper,
        "paper case real-time factor (cpu)": paper.duration / c["paper"],
        "numba_startup_s": startup,
    }


def _notes(dense: Scenario, timing: dict[str, Any], phases: dict[str, float],
           startup: float) -> list[str]:
    return [
        "wall times from SUMO start to close; 'sumo alone' steps the same traffic "
        "(network, density, seed, inflow, band rule) through SumoSim without an SV",
        "cpu: process CPU time (libsumo runs in-process), less sensitive to other load",
        f"last cosim run split (s): SUMO step with its hooks "
        f"{timing.get('wall_sumo_s', 0) - timing.get('wall_read_s', 0):.3f}, "
        f"scene read (SumoSim.snapshot_near) {timing.get('wall_read_s', 0):.3f}, "
        f"control+plant {timing.get('wall_control_s', 0):.3f}, "
        f"planning {timing.get('wall_planning_s', 0):.3f}, the rest (SUMO start and "
        f"traffic, trace rows and overlap check, decision rule, write-back) "
        f"{_rest(timing):.3f}",
        "the loop's parts in one extra cosim run (s, wall; cosim.bench.cosim.phase_split): "
        + ", ".join(f"{name} {value:.3f}" for name, value in phases.items()),
        f"plant {dense.sv.plant}, controller {dense.sv.controller}, "
        f"{dense.substeps} substeps per {dense.step:g} s step",
        f"closed loop compiled with numba: start-up in this process {startup:.2f} s "
        "(once per process; the batch fork server pays it for all its runs), not in the rows",
        f"1-min load average {os.getloadavg()[0]:.2f} at the end, {os.cpu_count()} cores",
    ]


def measure(args: argparse.Namespace) -> dict[str, Any]:
    cases = _cases(args)
    repeats = max(int(args.repeats), 1)
    start = time.perf_counter()
    from cosim.control.warm import warm_up  # importing it compiles, or loads the cache

    warm_up()
    startup = time.perf_counter() - start
    walls, cpus, plans, timing = _repeated(cases, repeats)
    phases = phase_split(cases.dense)
    w = {k: float(np.median(v)) for k, v in walls.items()}
    c = {k: float(np.median(v)) for k, v in cpus.items()}
    dense = cases.dense
    return {
        "title": f"co-simulation cost: {dense.name}, {dense.duration:g} s simulated, "
                 f"{dense.traffic.density:g} veh/km/lane; median of {repeats}",
        "rows": _rows(cases, w, c),
        "ratios": _ratios(cases, w, c, plans, startup),
        "targets": TARGETS,
        "phases": phases,
        "notes": _notes(dense, timing, phases, startup),
    }
