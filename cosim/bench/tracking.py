"""`cosim bench tracking`: how far the plant's rectangle strays from the planned one.

The planner checks the planned trajectory's rectangle; the plant follows it with a
tracking error. This runs the shipped single-run scenarios (the paper's three
cases and traffic_low / medium / high) on both plants (twotrack, bicycle) with both
of our controllers (mimo, siso) and, at every step of a lane change under way,
measures how far the plant's rectangle reaches past the planned one (the
reference at the same time):

- across the path: |ye| + (l/2) |sin phi_e| + (w/2) (1 - cos phi_e), ye the lateral
  offset (eq. 16), phi_e the heading error: the corner motion the heading error adds;
- along the path: |e_along| + (w/2) |sin phi_e| + (l/2) (1 - cos phi_e), e_along the
  plant's lead or lag on the reference point.

`[planner] safety_margin_m` grows every rectangle by the margin on all sides, so
a margin covers the tracking error when it is at least the larger of the two. The
bench prints per run and pooled the 95th percentile and the maximum; the default
margin (`[planner] safety_margin_m`, `params.PlannerConfig.safety_margin`) is the
largest of them all, rounded up to the centimetre (docs/planning_results.md).
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import numpy as np

from cosim.control.closed_loop import CONTROLLERS, PLANTS
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides

SCENARIOS = ("paper_case1_overtaking", "paper_case2_tv_lane_change",
             "paper_case3_lane_exchange", "traffic_low", "traffic_medium", "traffic_high")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenarios", default=",".join(SCENARIOS),
                        help="comma-separated scenario names under scenarios/")
    parser.add_argument("--duration", type=float, default=None,
                        help="s, shorten every run to this (default: the scenario's)")


def corner_errors(trace: dict[str, np.ndarray], length: float,
                  width: float) -> tuple[np.ndarray, np.ndarray]:
    """m, (across the path, along the path) how far the plant's rectangle reaches past
    the planned one, at the steps of a lane change under way."""
    on = (trace["changing"] > 0.5) & np.isfinite(trace["x_ref_m"])
    ye = trace["ye_m"][on]
    phi = np.radians(trace["phie_deg"][on])
    psi_ref = np.radians(trace["psi_ref_deg"][on])
    dx = trace["x_m"][on] - trace["x_ref_m"][on]
    dy = trace["y_m"][on] - trace["y_ref_m"][on]
    along = dx * np.cos(psi_ref) + dy * np.sin(psi_ref)
    s, c = np.abs(np.sin(phi)), np.cos(phi)
    across = np.abs(ye) + 0.5 * length * s + 0.5 * width * (1.0 - c)
    lengthwise = np.abs(along) + 0.5 * width * s + 0.5 * length * (1.0 - c)
    return across, lengthwise


def _percentile(a: np.ndarray, p: float) -> float:
    return float(np.percentile(a, p)) if a.size else math.nan


def _case_errors(sc: Scenario, case: str) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
    """(the case's row, its across and along errors per step of a lane change, m)."""
    from cosim.run.loop import simulate

    result = simulate(sc)
    across, along = corner_errors(result.trace, sc.vehicle.length, sc.vehicle.width)
    q = _percentile
    return ({"case": case, "steps": float(across.size),
             "across_p95_m": q(across, 95), "across_max_m": q(across, 100),
             "along_p95_m": q(along, 95), "along_max_m": q(along, 100)}, across, along)


def measure(args: argparse.Namespace) -> dict[str, Any]:
    start = time.perf_counter()
    rows = []
    pooled_across: list[np.ndarray] = []
    pooled_along: list[np.ndarray] = []
    for name in args.scenarios.split(","):
        base = load_scenario(project_root() / "scenarios" / f"{name}.toml")
        for plant in PLANTS:
            for controller in CONTROLLERS:
                changes: dict[str, Any] = {"plant": plant, "controller": controller}
                if args.duration is not None:
                    changes["duration"] = float(args.duration)
                row, across, along = _case_errors(with_overrides(base, **changes),
                                                  f"{name} {plant} {controller}")
                rows.append(row)
                pooled_across.append(across)
                pooled_along.append(along)
    a = np.concatenate(pooled_across) if pooled_across else np.zeros(0)
    b = np.concatenate(pooled_along) if pooled_along else np.zeros(0)
    p95 = float(np.percentile(a, 95)) if a.size else math.nan
    ratios = {
        "across_p95_m": p95,
        "across_max_m": float(a.max()) if a.size else math.nan,
        "along_p95_m": float(np.percentile(b, 95)) if b.size else math.nan,
        "along_max_m": float(b.max()) if b.size else math.nan,
    }
    worst = max(ratios["across_max_m"], ratios["along_max_m"])
    ratios["margin_covering_m"] = math.ceil(worst * 100.0 - 1e-9) / 100.0
    return {
        "title": "tracking: how far the plant's rectangle strays from the planned one (m)",
        "rows": rows, "ratios": ratios, "targets": {},
        "notes": [
            "steps of a lane change under way, pooled over scenarios x plants x controllers",
            "across: |ye| + (l/2)|sin phi_e| + (w/2)(1 - cos phi_e); along: |e_along| + "
            "(w/2)|sin phi_e| + (l/2)(1 - cos phi_e)",
            "margin_covering_m: the largest of all, rounded up to the cm (the default "
            "[planner] safety_margin_m of a scenario file)",
            f"wall time {time.perf_counter() - start:.1f} s",
        ],
    }
