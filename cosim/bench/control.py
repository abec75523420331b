"""`cosim bench control`: wall time of plant + controller for a 10 s lane change.

The closed loop is stepped as the co-simulation steps it (0.05 s SUMO steps, 10
substeps, controller every substep) on the paper's case 5.1 reference. Rows:
each plant x controller, and the two-track plant alone (no controller) to show
the split. Target: under 0.2 s of wall time for 10 s simulated on the two-track
plant, well under the SUMO step cost it runs beside.

The closed loop is compiled (numba, `cosim.compiled`): numba's start-up
in this process (import, compiler set-up, compiling or loading the cached code)
is timed first, once, and reported apart; the rows are the steady state.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

from cosim.bench import median_time
from cosim.commands import count, seconds
from cosim.control.closed_loop import ClosedLoop, LoopConfig
from cosim.params import ControllerGains, VehicleParams, kmh
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.plant import PlantStart
from cosim.vehicle.twotrack import TwoTrackPlant


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=count("--repeats"), default=7,
                        help="timed repeats (median)")
    parser.add_argument("--duration", type=seconds("--duration", 600.0), default=10.0,
                        help="s simulated per repeat")


def measure(args: argparse.Namespace) -> dict[str, Any]:

    start = time.perf_counter()
    from cosim.control.warm import warm_up  # importing it compiles, or loads the cache

    warm_up()
    startup = time.perf_counter() - start
    vehicle, gains = VehicleParams(), ControllerGains()
    step, substeps = 0.05, 10
    n = int(round(args.duration / step))
    ref = LaneChangeTrajectory(
        t0=0.0, tau=6.25, x0=0.0, y0=1.875, vx0=kmh(80.0), vxf=kmh(90.0), width=3.75
    )

    def closed_loop(plant: str, controller: str) -> tuple[float, float]:
        def run() -> None:
            loop = ClosedLoop(LoopConfig(plant, controller), vehicle, gains, 0.4,
                              PlantStart(0.0, 1.875, 0.0, kmh(80.0)))
            for k in range(n):
                loop.advance(k * step, step, substeps, ref)

        cpu = median_time(run, args.repeats, warmup=0, clock=time.process_time)
        return median_time(run, args.repeats), cpu

    def plant_alone() -> None:
        p = TwoTrackPlant(vehicle, 0.4, PlantStart(0.0, 1.875, 0.0, kmh(80.0)))
        fx = (60.0, 60.0, 60.0, 60.0)
        for _ in range(n * substeps):
            p.step(step / substeps, 0.0, fx)

    rows: list[dict[str, Any]] = []
    walls: dict[str, float] = {}
    load_before = os.getloadavg()[0]
    for plant in ("twotrack", "bicycle"):
        for controller in ("mimo", "siso"):
            wall, cpu = closed_loop(plant, controller)
            walls[f"{plant}_{controller}"] = wall
            rows.append({
                "case": f"{plant} + {controller}",
                "wall_s": wall,
                "cpu_s": cpu,
                "realtime_factor": args.duration / wall,
                "us_per_sumo_step": wall / n * 1e6,
            })
    alone = median_time(plant_alone, args.repeats)
    rows.append({
        "case": "twotrack plant alone",
        "wall_s": alone,
        "cpu_s": median_time(plant_alone, args.repeats, warmup=0, clock=time.process_time),
        "realtime_factor": args.duration / alone,
        "us_per_sumo_step": alone / n * 1e6,
    })
    load_after = os.getloadavg()[0]
    return {
        "title": f"plant + controller, {args.duration:g} s lane change (case 5.1), "
        f"{step:g} s steps x {substeps} substeps, median of {args.repeats}",
        "rows": rows,
        "ratios": {
            "twotrack_mimo_wall_s": walls["twotrack_mimo"],
            "twotrack_mimo_realtime_factor": args.duration / walls["twotrack_mimo"],
            "twotrack_over_bicycle": walls["twotrack_mimo"] / walls["bicycle_mimo"],
            "plant_share_of_twotrack_mimo": alone / walls["twotrack_mimo"],
            "numba_startup_s": startup,
        },
        "targets": {"twotrack_mimo_wall_s": "< 0.2 s for 10 s simulated"},
        "notes": [
            "controller every substep (200 Hz); two-track RK4 steps <= 2.4 / the fastest "
            "tyre rate (wheel spin on the tyre, relaxation) and <= 5 ms",
            f"compiled with numba; start-up in this process {startup:.2f} s (import, compiler "
            "set-up, compile or cached load: about 10 s the first time on a machine, about "
            "1 s in a fresh process with the cache), not in the rows",
            f"1-min load average {load_before:.2f} before, {load_after:.2f} after, on "
            f"{os.cpu_count()} cores: wall times grow when other processes compete; cpu_s "
            "is the process CPU time",
        ],
    }
