"""`cosim bench measures`: what measuring the traffic costs a run.

The same dense run (our SV, planner, controller and plant; SUMO's traffic), from SUMO's
start to its close, with and without each measure, side by side: the cases alternate
within each repeat so that drift and other jobs on the machine hit them alike, and each
ratio is the median over the repeats of the ratio of a case's CPU time to the plain run's
measured just before it (more robust on a shared machine than a ratio of medians), and
the ratio of the fastest runs of each case (contention only ever adds CPU time).

Cases (CASES): the plain run; `[detectors]` with its defaults (induction loops); with a
lane-area detector per lane (`areas = "lanes"`), or per stretch between loops
(`"stretches"`); SUMO's SSM device on every vehicle (`[ssm]`); on the SV alone
(`ssm.vehicles = "sv"`). And a fleet (FLEET_CASES, `scenarios/fleet_vtypes.toml`: the
user's own demand, its `av` vType automated): without SSM, SSM on every vehicle, on the
SV and the AVs (`ssm.vehicles = "fleet"`, with our fleet_conflicts.csv), each to the
fleet's run without SSM. Targets: detectors at most 5 % more CPU than the plain run;
SSM's cost measured, the device limited to the automated vehicles at most 20 %.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cosim.commands import count, seconds
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides

DEFAULT_SCENARIO = "scenarios/traffic_high.toml"
# (key, label, overrides of the dense scenario); the first is the plain run
CASES: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("plain", "no measures", {}),
    ("detectors", "[detectors] defaults: induction loops", {"detectors.enabled": True}),
    ("lanes", "[detectors] areas = lanes: and an E2 per lane",
     {"detectors.enabled": True, "detectors.areas": "lanes"}),
    ("stretches", "[detectors] areas = stretches: and an E2 between each two loops",
     {"detectors.enabled": True, "detectors.areas": "stretches"}),
    ("ssm", "[ssm] SSM device on every vehicle", {"ssm.enabled": True}),
    ("ssm_sv", "[ssm] vehicles = sv: on the SV alone",
     {"ssm.enabled": True, "ssm.vehicles": "sv"}),
)
DEFAULT_FLEET_SCENARIO = "scenarios/fleet_vtypes.toml"
# (key, label, overrides of the fleet scenario); the first is its run without SSM, the
# others' ratios are to it
FLEET_CASES: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("fleet", "fleet_vtypes: no SSM", {"ssm.enabled": False}),
    ("fleet_ssm", "fleet_vtypes: [ssm] device on every vehicle",
     {"ssm.enabled": True, "ssm.vehicles": "all"}),
    ("fleet_ssm_fleet", "fleet_vtypes: [ssm] vehicles = fleet: the SV and the AVs (and ours)",
     {"ssm.enabled": True, "ssm.vehicles": "fleet"}),
)
TARGETS = {"detectors / plain (cpu)": "<= 1.05", "fleet_ssm_fleet / fleet (cpu)": "<= 1.20"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", type=Path, default=None,
                        help=f"dense traffic scenario (default {DEFAULT_SCENARIO})")
    parser.add_argument("--duration", type=seconds("--duration"), default=60.0,
                        help="simulated seconds per run (default 60)")
    parser.add_argument("--repeats", type=count("--repeats"), default=5,
                        help="repeats of every case (median; default 5)")
    parser.add_argument("--fleet-scenario", type=Path, default=None,
                        help="a fleet with [fleet] vtypes for the fleet's SSM cases, run "
                             f"for its own duration (default {DEFAULT_FLEET_SCENARIO})")
    parser.add_argument("--no-fleet", dest="fleet", action="store_false",
                        help="leave out the fleet's cases")


def timed_run(scenario: Scenario) -> tuple[float, float]:
    """s, wall and CPU time of one run, SUMO start to close, its measures' outputs
    written by SUMO into a temporary folder and read in as `cosim run` reads them."""
    from cosim.run.loop import simulate

    with tempfile.TemporaryDirectory(prefix="cosim-bench-measures-") as tmp:
        start, cpu = time.perf_counter(), time.process_time()
        simulate(scenario, detector_output=Path(tmp))
        return time.perf_counter() - start, time.process_time() - cpu


def repeated(cases: dict[str, Scenario], repeats: int,
             run: Callable[[Scenario], tuple[float, float]] = timed_run,
             warm: tuple[str, ...] = ()) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """(wall s, CPU s) of every case per repeat: a short warm-up run (of the first case,
    and of each case in `warm`), then the cases in turn, `repeats` times."""
    for key in (next(iter(cases)), *warm):
        # compiled code loaded, SUMO's files cached
        run(with_overrides(cases[key], duration=1.0))
    walls: dict[str, list[float]] = {k: [] for k in cases}
    cpus: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(repeats):
        for key, scenario in cases.items():
            wall, cpu = run(scenario)
            walls[key].append(wall)
            cpus[key].append(cpu)
    return walls, cpus


def measure(args: argparse.Namespace) -> dict[str, Any]:
    path = args.scenario if args.scenario is not None else project_root() / DEFAULT_SCENARIO
    dense = with_overrides(load_scenario(path), duration=float(args.duration))
    cases = {key: with_overrides(dense, **keys) for key, _, keys in CASES}
    groups = [(CASES, "plain", dense)]
    if getattr(args, "fleet", True):
        fleet_path = getattr(args, "fleet_scenario", None) or \
            project_root() / DEFAULT_FLEET_SCENARIO
        fleet = load_scenario(fleet_path)  # its own duration (the warm-up comes first)
        cases.update({key: with_overrides(fleet, **keys) for key, _, keys in FLEET_CASES})
        groups.append((FLEET_CASES, "fleet", fleet))
    repeats = max(int(args.repeats), 1)
    load_before = os.getloadavg()[0]
    walls, cpus = repeated(cases, repeats, warm=tuple(g[1] for g in groups[1:]))
    rows, ratios, per_repeat = [], {}, []
    for group, base, sc in groups:
        plain = np.array(cpus[base])
        for key, label, _ in group:
            cpu = np.array(cpus[key])
            rows.append({"case": label, "wall_s": float(np.median(walls[key])),
                         "cpu_s": float(np.median(cpu)), "cpu_min_s": float(cpu.min()),
                         "cpu_per_step_ms": 1e3 * float(np.median(cpu)) / sc.n_steps,
                         "cpu_vs_plain": float(np.median(cpu / plain))})
            if key != base:
                ratios[f"{key} / {base} (cpu)"] = float(np.median(cpu / plain))
                ratios[f"{key} / {base} (cpu, fastest)"] = float(cpu.min() / plain.min())
                per_repeat.append(f"{key} " + ", ".join(
                    f"{c / p:.3f}" for c, p in zip(cpu, plain, strict=True)))
    return {
        "title": f"the cost of measuring: {dense.name}, {dense.duration:g} s simulated, "
                 f"{dense.traffic.density:g} veh/km/lane"
                 + (f"; {groups[1][2].name} (its own demand, [fleet] vtypes), "
                    f"{groups[1][2].duration:g} s" if len(groups) > 1 else "")
                 + f"; median of {repeats}",
        "rows": rows,
        "ratios": ratios,
        "targets": TARGETS if len(groups) > 1 else {
            k: v for k, v in TARGETS.items() if not k.startswith("fleet")},
        "notes": [
            "cpu: process CPU time of a whole run (libsumo runs in-process), SUMO start "
            "to close (the fleet's: its own demand's warm-up too); cpu_vs_plain and the "
            "ratios: the median over the repeats of each run's CPU over its group's run "
            "without measures (plain, fleet) of the same repeat; '(cpu, fastest)': the "
            "ratio of the fastest runs (cpu_min_s), what other jobs slowed least: other "
            "processes on the cores only ever add CPU time (caches, shared cores)",
            "per-repeat ratios: " + "; ".join(per_repeat),
            f"{os.cpu_count()} cores; 1-min load average {load_before:.1f} before, "
            f"{os.getloadavg()[0]:.1f} after",
        ],
    }
