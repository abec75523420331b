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
from collections.abc import Callable
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


STEP, SUBSTEPS = 0.05, 10  # s, a SUMO step; plant/controller substeps in it
START = PlantStart(0.0, 1.875, 0.0, kmh(80.0))  # case 5.1's start, lane 0


def _reference() -> LaneChangeTrajectory:
    """Case 5.1's lane change at the paper's tau_opt."""
    return LaneChangeTrajectory(
        t0=0.0, tau=6.25, x0=0.0, y0=1.875, vx0=kmh(80.0), vxf=kmh(90.0), width=3.75
    )


def _closed_loop_times(config: LoopConfig, n: int, repeats: int) -> tuple[float, float]:
    """(wall s, CPU s) medians of n steps of the closed loop on case 5.1's lane change."""
    vehicle, gains, ref = VehicleParams(), ControllerGains(), _reference()

    def run() -> None:
        loop = ClosedLoop(config, vehicle, gains, 0.4, START)
        for k in range(n):
            loop.advance(k * STEP, STEP, SUBSTEPS, ref)

    cpu = median_time(run, repeats, warmup=0, clock=time.process_time)
    return median_time(run, repeats), cpu


def _plant_alone(n: int) -> Callable[[], None]:
    """n steps of the two-track plant alone, under constant wheel forces."""
    vehicle = VehicleParams()

    def run() -> None:
        p = TwoTrackPlant(vehicle, 0.4, START)
        fx = (60.0, 60.0, 60.0, 60.0)
        for _ in range(n * SUBSTEPS):
            p.step(STEP / SUBSTEPS, 0.0, fx)

    return run


def _row(case: str, wall: float, cpu: float, duration: float, n: int) -> dict[str, Any]:
    return {"case": case, "wall_s": wall, "cpu_s": cpu, "realtime_factor": duration / wall,
            "us_per_sumo_step": wall / n * 1e6}


def measure(args: argparse.Namespace) -> dict[str, Any]:
    start = time.perf_counter()
    from cosim.control.warm import warm_up  # importing it compiles, or loads the cache

    warm_up()
    startup = time.perf_counter() - start
    n = int(round(args.duration / STEP))
    rows: list[dict[str, Any]] = []
    walls: dict[str, float] = {}
    load_before = os.getloadavg()[0]
    for plant in ("twotrack", "bicycle"):
        for controller in ("mimo", "siso"):
            wall, cpu = _closed_loop_times(LoopConfig(plant, controller), n, args.repeats)
            walls[f"{plant}_{controller}"] = wall
            rows.append(_row(f"{plant} + {controller}", wall, cpu, args.duration, n))
    plant_alone = _plant_alone(n)
    alone = median_time(plant_alone, args.repeats)
    rows.append(_row("twotrack plant alone", alone,
                     median_time(plant_alone, args.repeats, warmup=0, clock=time.process_time),
                     args.duration, n))
    load_after = os.getloadavg()[0]
    return {
        "title": f"plant + controller, {args.duration:g} s lane change (case 5.1), "
        f"{STEP:g} s steps x {SUBSTEPS} substeps, median of {args.repeats}",
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
