"""A study's fleet and traffic figures per grid cell (summary.csv): the means over a
cell's finished runs of the automated vehicles' metrics.csv columns (cosim.run.fleet's
`fleet_*`) and of the traffic's (outflow, space-mean speed, speed spread, SSM conflicts
per vehicle-km), each with its Student-t 95 % interval: what a penetration study compares
across shares and fleet drivers. A run's value is one sample (its vehicles are not
independent of each other), so an interval is over runs, i.e. seeds."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from cosim.study.intervals import mean_ci

# metrics.csv columns summarised as means (those present in the runs)
FLEET_MEANS = (
    "fleet_vehicles", "fleet_lane_changes", "fleet_collisions", "fleet_caused_collisions",
    "fleet_sumo_collisions", "fleet_mean_speed_mps", "fleet_max_long_jerk_mps3",
    "fleet_follower_max_decel_mps2",
    "traffic_speed_mps", "outflow_veh_per_h", "speed_spread_space_mps",
    "speed_spread_time_mps", "ssm_conflicts",
)
# per-run ratios: name -> (numerator, denominator) columns (NaN where the denominator is 0)
RATIOS = {
    "fleet_lane_changes_per_vehicle": ("fleet_lane_changes", "fleet_vehicles"),
    "ssm_conflicts_per_vehicle_km": ("ssm_conflicts", "vehicle_km"),
}
SUMMARY_DOCS = {
    "fleet_lane_changes_per_vehicle": "lane changes per automated vehicle in a run (-)",
    "ssm_conflicts_per_vehicle_km": "SSM conflicts per vehicle-km all vehicles drove in a "
                                    "run (1/km)",
}


def _column(ok: pd.DataFrame, name: str) -> np.ndarray | None:
    if name in RATIOS:
        top, bottom = (_column(ok, c) for c in RATIOS[name])
        if top is None or bottom is None:
            return None
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(bottom > 0, top / bottom, np.nan)
    if name not in ok:
        return None
    return pd.to_numeric(ok[name], errors="coerce").to_numpy(float)


def fleet_summary(ok: pd.DataFrame) -> dict[str, float]:
    """`<name>_mean`, `_ci_low`, `_ci_high` (Student-t, 95 %; NaN below two finite runs)
    and `_n` (runs with a finite value) for each of FLEET_MEANS and RATIOS the runs have."""

    out: dict[str, float] = {}
    for name in (*FLEET_MEANS, *RATIOS):
        values = _column(ok, name)
        if values is None:
            continue
        out[f"{name}_n"] = float(np.isfinite(values).sum())
        (out[f"{name}_mean"], out[f"{name}_ci_low"], out[f"{name}_ci_high"]) = mean_ci(values)
    return out


def mean_text(row: pd.Series, name: str, digits: int = 2) -> str:
    """"mean [low, high]" of a summary row (the mean alone below two runs; "-": none)."""
    mean = row.get(f"{name}_mean", math.nan)
    if not (isinstance(mean, float | int) and math.isfinite(mean)):
        return "-"
    low, high = row.get(f"{name}_ci_low", math.nan), row.get(f"{name}_ci_high", math.nan)
    if not math.isfinite(low):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"
