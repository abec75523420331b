"""A study's summary: per grid cell of runs.csv (every parameter but the seed), the rates
of success and of both collision checks with Wilson intervals, lane-change duration and
minimum TTC as means, percentiles and medians with distribution-free intervals, the new
follower's braking, and the comfort and merge figures: the table of summary.csv
(cosim.study.report writes it, with summary.md and comfort.md).

Rates are over the runs that finished (status ok): a failed run is a fault of the tool,
not an outcome of the manoeuvre, and is counted apart."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from cosim.run.metrics import FOLLOWER_PERCENTILE
from cosim.study.fleet_summary import fleet_summary
from cosim.study.intervals import mean_ci, median_ci, wilson
from cosim.study.run_table import NO_FLEET_DRIVER, NO_VARIANT, RunStatus

# Parameters that define a grid cell of summary.csv (every parameter but the seed).
CELL = ("driver", "variant", "plant", "occupant", "mu", "share", "fleet_driver", "density")
# Metrics summarised per grid cell (names as cosim.run.metrics writes them).
SUCCESS_METRIC = "lane_change_completed"  # bool: the commanded lane change ended in its lane
COLLISION_METRIC = "collision"  # bool: our geometric check saw an overlap
SUMO_COLLISION_METRIC = "sumo_collision"  # bool: SUMO's getCollisions saw one (cross-check)
UNFINISHED_METRIC = "lane_change_unfinished"  # bool: the run ended during the lane change
SV_COLLISION_METRIC = "collisions_sv"  # count: collisions the SV caused (cosim.run.loop)
MANOEUVRE_COLLISION_METRIC = "collisions_manoeuvre"  # count: ... while changing lanes
DURATION_METRIC = "lane_change_duration_s"  # s
TTC_METRIC = "min_ttc_s"  # s
FOLLOWER_METRIC = "follower_max_decel_mps2"  # m/s^2, the SV's new follower
PERCENTILES = (10, 50, 90)


def _finite(ok: pd.DataFrame, metric: str) -> np.ndarray:
    """The finite values of a metric column (none if the runs predate it)."""
    if metric not in ok:
        return np.empty(0)
    v = pd.to_numeric(ok[metric], errors="coerce").to_numpy(float)
    return v[np.isfinite(v)]


def _stat(values: np.ndarray, fn: Callable[[np.ndarray], Any]) -> float:
    """`fn(values)` as a float (a median, a maximum, ...); NaN for no values."""
    return float(fn(values)) if len(values) else math.nan


def _p95_max(decel: np.ndarray, prefix: str) -> dict[str, float]:
    """`<prefix>_p95` (FOLLOWER_PERCENTILE) and `<prefix>_max` of a follower's largest
    decelerations, one per run (NaN: none)."""
    return {f"{prefix}_p{FOLLOWER_PERCENTILE}":
            _stat(decel, lambda v: np.percentile(v, FOLLOWER_PERCENTILE)),
            f"{prefix}_max": _stat(decel, np.max)}


def _as_bool(column: pd.Series) -> pd.Series:
    if column.dtype == object:
        return column.map(lambda v: str(v).strip().lower() in ("true", "1", "1.0", "yes"))
    return column.fillna(0).astype(float) != 0


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """summary.csv: per grid cell (all parameters but the seed), the number of
    runs, failed runs, runs whose lane change the end cut short (`unfinished`), the
    success rate over the other (finished) runs, the collision rates of both checks
    (ours `collision`, SUMO's `sumo_collision`) and the SV-caused one, with Wilson
    intervals, and
    lane-change duration and minimum TTC: mean, percentiles, and the median's
    distribution-free interval (`median_ci`); the new follower's largest deceleration:
    count, 95th percentile and maximum; with SUMO's detectors in the runs, the median
    of each traffic measure (cosim.study.fundamental.traffic_summary).

    Rates are over the runs that finished (status ok): a failed run is a fault
    of the tool, not an outcome of the manoeuvre, and is counted apart."""
    rows = []
    if "variant" not in runs:
        runs = runs.assign(variant=NO_VARIANT)
    runs = runs.assign(variant=runs["variant"].fillna(NO_VARIANT).astype(str))
    if "share" not in runs:  # runs.csv of a study made before the share was a grid value
        runs = runs.assign(share=0.0)
    if "fleet_driver" not in runs:
        runs = runs.assign(fleet_driver=NO_FLEET_DRIVER)
    from cosim.study.fundamental import traffic_columns, traffic_summary

    traffic = traffic_columns(runs)  # runs with SUMO's detectors: their measures' medians
    for cell, group in runs.groupby(list(CELL), sort=True):
        ok = group[group["status"] == RunStatus.OK]
        n = len(ok)
        row: dict[str, Any] = dict(zip(CELL, cell, strict=True))
        row.update(runs=len(group), ok=n, failed=len(group) - n)
        # lane changes the run's end cut short are neither successes nor failures
        unfinished = (int(_as_bool(ok[UNFINISHED_METRIC]).sum())
                      if UNFINISHED_METRIC in ok and n else 0)
        row["unfinished"] = unfinished
        for name, metric in (("success", SUCCESS_METRIC), ("collision", COLLISION_METRIC),
                             ("sumo_collision", SUMO_COLLISION_METRIC),
                             ("sv_collision", SV_COLLISION_METRIC),
                             ("manoeuvre_collision", MANOEUVRE_COLLISION_METRIC)):
            hits = int(_as_bool(ok[metric]).sum()) if metric in ok and n else 0
            known = metric in ok or name in ("success", "collision")  # older records lack some
            of = n - unfinished if name == "success" else n
            row[f"{name}_rate"] = hits / of if of and known else math.nan
            row[f"{name}_ci_low"], row[f"{name}_ci_high"] = wilson(hits, of if known else 0)
        for name, metric in (("lc_duration_s", DURATION_METRIC), ("min_ttc_s", TTC_METRIC)):
            finite = _finite(ok, metric)
            row[f"{name}_n"] = len(finite)
            row[f"{name}_mean"] = _stat(finite, np.mean)
            for q in PERCENTILES:
                row[f"{name}_p{q}"] = _stat(finite, lambda v, q=q: np.percentile(v, q))
            # the median and its interval: the statistic of summary.md and the plots
            (_, row[f"{name}_ci_low"], row[f"{name}_ci_high"],
             row[f"{name}_ci_coverage"]) = median_ci(finite)
        decel = _finite(ok, FOLLOWER_METRIC)
        row["follower_decel_mps2_n"] = len(decel)
        row.update(_p95_max(decel, "follower_decel_mps2"))
        row.update(entry_summary(ok))
        row.update(comfort_summary(ok))
        row.update(merge_summary(ok))
        if traffic:
            row.update(traffic_summary(ok, traffic))
        row.update(ssm_summary(ok))
        row.update(fleet_summary(ok))
        rows.append(row)
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ entry
HARD_FOLLOWER_BRAKE = 3.0  # m/s^2, a new follower braking this hard counts as forced


def entry_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's entry columns of one cell's finished runs (cosim.run.metrics.ENTRY_DOCS):
    the smallest follower gap and time gap at entry and TTC after it (over runs where
    they are finite), the largest deceleration a follower needed then (NaN before these
    metrics existed) and `hard_follower_brakes` (runs whose new follower
    braked harder than HARD_FOLLOWER_BRAKE)."""
    row: dict[str, float] = {}
    for metric in ("entry_follower_gap_m", "entry_follower_time_gap_s", "entry_min_ttc_s"):
        row[f"{metric}_min"] = _stat(_finite(ok, metric), np.min)
    # inf (a follower closing within SUMO's minimum gap) is the worst case: kept
    need = (pd.to_numeric(ok["entry_follower_needed_decel_mps2"], errors="coerce").to_numpy(float)
            if "entry_follower_needed_decel_mps2" in ok else np.empty(0))
    row["entry_follower_needed_decel_mps2_max"] = _stat(need[~np.isnan(need)], np.max)
    decel = _finite(ok, FOLLOWER_METRIC)
    row["hard_follower_brakes"] = (float(np.sum(decel > HARD_FOLLOWER_BRAKE))
                                   if FOLLOWER_METRIC in ok else math.nan)
    return row


# ------------------------------------------------------------------ comfort
# Per grid cell: medians (p50) and worst values of the SV's comfort metrics
# (cosim.run.metrics.COMFORT_COLUMNS), over the finished runs where the metric is finite.
COMFORT_MEDIANS = ("rms_long_accel_mps2", "rms_long_jerk_mps3", "max_long_jerk_mps3",
                   "long_accel_jump_share", "merge_time_gap_s", "post_change_max_decel_mps2",
                   "request_to_lane_s")
HARD_BRAKE = 3.0  # m/s^2, a deceleration after the change this large counts as hard braking


def comfort_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's comfort columns of one cell's finished runs: `<metric>_p50` for each
    of COMFORT_MEDIANS, `max_long_jerk_mps3_max`, `merge_time_gap_s_min`,
    `post_change_max_decel_mps2_max` and `hard_post_change_brakes` (runs that braked
    harder than HARD_BRAKE after a change; NaN before these metrics existed)."""
    row: dict[str, float] = {}
    for metric in COMFORT_MEDIANS:
        v = _finite(ok, metric)
        row[f"{metric}_p50"] = _stat(v, np.median)
    jerk, gap, decel = (_finite(ok, m) for m in ("max_long_jerk_mps3", "merge_time_gap_s",
                                                 "post_change_max_decel_mps2"))
    row["max_long_jerk_mps3_max"] = _stat(jerk, np.max)
    row["merge_time_gap_s_min"] = _stat(gap, np.min)
    row["post_change_max_decel_mps2_max"] = _stat(decel, np.max)
    row["hard_post_change_brakes"] = (float(np.sum(decel > HARD_BRAKE))
                                      if "post_change_max_decel_mps2" in ok else math.nan)
    return row


# ------------------------------------------------------------------ merges
MERGE_METRIC = "merge_success"  # 1 / 0; empty when the SV's start lane does not end


def merge_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's merge columns of one cell's finished runs (cosim.run.metrics.MERGE_DOCS):
    `merge_n` runs whose start lane ends, `merge_success_rate` among them with its Wilson
    interval, the medians of `merge_distance_to_end_m` and `stopped_time_s`, and the
    target lane follower's largest deceleration: 95th percentile and maximum (all NaN
    when no run started in a lane that ends)."""
    success = _finite(ok, MERGE_METRIC)
    n, hits = len(success), int(np.sum(success > 0.5))
    row: dict[str, float] = {"merge_n": float(n),
                             "merge_success_rate": hits / n if n else math.nan}
    row["merge_success_ci_low"], row["merge_success_ci_high"] = wilson(hits, n)
    for metric in ("merge_distance_to_end_m", "stopped_time_s"):
        v = _finite(ok, metric) if n else np.empty(0)
        row[f"{metric}_p50"] = _stat(v, np.median)
    row.update(_p95_max(_finite(ok, "merge_follower_max_decel_mps2"),
                        "merge_follower_decel_mps2"))
    return row


# ------------------------------------------------------------------ surrogate safety
# Per grid cell: the mean count of SUMO's SSM conflicts per run (cosim.traffic.ssm
# COUNT_DOCS) with its Student-t interval; only for studies whose runs measured them.
SSM_COUNTS = ("ssm_conflicts", "ssm_ttc_conflicts", "ssm_drac_conflicts",
              "ssm_pet_conflicts", "ssm_sv_conflicts")


def ssm_summary(ok: pd.DataFrame) -> dict[str, float]:
    """summary.csv's SSM columns of one cell's finished runs: for each of SSM_COUNTS
    present in the runs, `<count>_mean` per run with its `_ci_low` / `_ci_high`
    (`mean_ci`: NaN for fewer than two runs); none without [ssm] runs."""
    out: dict[str, float] = {}
    for metric in SSM_COUNTS:
        if metric not in ok:
            continue
        values = pd.to_numeric(ok[metric], errors="coerce").to_numpy(float)
        (out[f"{metric}_mean"], out[f"{metric}_ci_low"],
         out[f"{metric}_ci_high"]) = mean_ci(values)
    return out
