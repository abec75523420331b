"""`cosim bench road`: the road frame's cost (not yet on the loop's path).

Builds the road of the curved motorway (networks/curved_motorway.net.xml, route
e1-e4) and of the straight highway, then times the conversions the loop will make
every step: `to_frenet` of 100 points (a step's TVs) with each point's s of the step
before as the hint, the same without hints (from the nearest of all knots), `to_cartesian` of 100
points, and one point at a time (the SV). Medians of CPU time per call.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np

from cosim.bench import median_time
from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR

CURVED = (NETWORK_DIR / "curved_motorway.net.xml", ("e1", "e2", "e3", "e4"))
STRAIGHT = (NETWORK_DIR / "highway.net.xml", None)
N_POINTS = 100


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=int, default=2000, help="calls per figure")


def _row(case: str, network: Any, route: Any, repeats: int) -> dict[str, Any]:
    w0 = time.process_time()
    road = load_road(network, route)
    build = time.process_time() - w0
    frame = road.frame
    rng = np.random.default_rng(0)
    s = rng.uniform(100.0, frame.length - 100.0, N_POINTS)
    d = rng.uniform(-2.0, 11.0, N_POINTS)
    x, y, _ = frame.to_cartesian(s, d)
    hint = s - 1.5  # where each was a step (0.05 s at 30 m/s) before
    x0, y0, s0 = float(x[0]), float(y[0]), float(hint[0])
    cpu = time.process_time
    per = {
        "to_frenet_100_hint_us": median_time(lambda: frame.to_frenet(x, y, hint), repeats,
                                             clock=cpu),
        "to_frenet_100_us": median_time(lambda: frame.to_frenet(x, y), max(20, repeats // 50),
                                        clock=cpu),
        "to_cartesian_100_us": median_time(lambda: frame.to_cartesian(s, d), repeats,
                                           clock=cpu),
        "to_frenet_1_us": median_time(lambda: frame.to_frenet(x0, y0, s0), repeats, clock=cpu),
    }
    q = frame.quality
    return {"case": case, "frame": type(frame).__name__, "build_s": build,
            **{k: v * 1e6 for k, v in per.items()},
            "deviation_m": road.max_deviation, "min_radius_m": q.min_radius}


def measure(args: argparse.Namespace) -> dict[str, Any]:
    repeats = int(getattr(args, "repeats", 2000))
    load_road(*CURVED).frame.to_frenet(0.0, 0.0)  # numba: compile or load once, untimed
    rows = [_row("curved_motorway e1-e4", *CURVED, repeats),
            _row("highway (straight)", *STRAIGHT, repeats)]
    return {"title": f"road frame conversions, CPU per call (median; load "
                     f"{os.getloadavg()[0]:.1f})",
            "rows": rows, "ratios": {}, "targets": {},
            "notes": ["the hint is each point's s a step before (1.5 m back); without it "
                      "the search starts at the nearest of all the table's knots"]}
