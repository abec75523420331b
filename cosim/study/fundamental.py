"""The fundamental diagram of a study over traffic density whose runs had SUMO's detectors
(`[detectors] enabled` in the base scenario: runs.csv then holds each run's measured flow,
density and space-mean speed, cosim.traffic.traffic_measures): per line (driver and the
other grid values besides density and seed) and per lane (each SV lane k, and the road:
the mean over its lanes, per lane), the runs as points and, per density cell of the grid,
the medians of the measured density, flow and speed (fundamental.csv).

Capacity and critical density are read off the medians (`capacity`): the capacity is the
largest median flow over the grid's density cells, the critical density that cell's
median measured density, so both are as fine as the grid (a cell's median of a few seeds,
not a fitted curve); the flow at the densest cell below it says whether the peak was
passed (`past_peak`: the densest cell's median flow is below the capacity).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pandas as pd

from cosim.study.run_table import NO_VARIANT, RunStatus
from cosim.traffic.traffic_measures import TRAFFIC_DOCS

LINE = ("driver", "variant", "plant", "occupant", "mu")  # a line: a cell without its density
ROAD = "all"  # the lane label of the road's values (the mean over its lanes, per lane)
# (density, flow, speed) columns of runs.csv: the road's, then lane k's
ROAD_COLUMNS = ("traffic_density_veh_per_km_lane", "traffic_flow_veh_per_h_lane",
                "traffic_speed_mps")
LANE_PATTERNS = ("traffic_density_lane<k>_veh_per_km", "traffic_flow_lane<k>_veh_per_h",
                 "traffic_speed_lane<k>_mps")
FD_COLUMNS = (*LINE, "lane", "density", "runs", "density_veh_per_km_p50",
              "flow_veh_per_h_p50", "speed_mps_p50")
CAPACITY_COLUMNS = (*LINE, "lane", "capacity_veh_per_h", "critical_density_veh_per_km",
                    "speed_at_capacity_mps", "density_cell", "past_peak")


def _pattern(doc_key: str) -> re.Pattern[str]:
    return re.compile("^" + re.escape(doc_key).replace("<k>", r"(\d+)") + "$")


TRAFFIC_PATTERNS = tuple(_pattern(k) for k in TRAFFIC_DOCS)


def traffic_columns(runs: pd.DataFrame) -> list[str]:
    """runs.csv's columns that are traffic measures (TRAFFIC_DOCS), in their order."""
    return [c for c in runs.columns if any(p.match(c) for p in TRAFFIC_PATTERNS)]


def lanes(runs: pd.DataFrame) -> list[int]:
    """The SV lanes (tracks) runs.csv has traffic columns of, ascending."""
    flow = _pattern(LANE_PATTERNS[1])
    return sorted({int(m.group(1)) for c in runs.columns if (m := flow.match(c))})


def lane_columns(lane: int | str) -> tuple[str, str, str]:
    """(density, flow, speed) columns of runs.csv for lane k or the road (ROAD)."""
    if lane == ROAD:
        return ROAD_COLUMNS
    d, q, v = (p.replace("<k>", str(lane)) for p in LANE_PATTERNS)
    return d, q, v


def points(runs: pd.DataFrame) -> pd.DataFrame:
    """The finished runs' points: LINE, lane, density (the grid's), seed and the measured
    density_veh_per_km, flow_veh_per_h, speed_mps (one row per run and lane)."""
    ok = runs[runs["status"] == RunStatus.OK]
    if "variant" not in ok:
        ok = ok.assign(variant=NO_VARIANT)
    ok = ok.assign(variant=ok["variant"].fillna(NO_VARIANT).astype(str))
    frames = []
    for lane in [*lanes(runs), ROAD]:
        d, q, v = lane_columns(lane)
        if not {d, q, v} <= set(ok.columns):
            continue
        frame = ok[[*LINE, "density", "seed"]].copy()
        frame.insert(len(LINE), "lane", str(lane))
        frame["density_veh_per_km"] = pd.to_numeric(ok[d], errors="coerce")
        frame["flow_veh_per_h"] = pd.to_numeric(ok[q], errors="coerce")
        frame["speed_mps"] = pd.to_numeric(ok[v], errors="coerce")
        frames.append(frame)
    columns = [*LINE, "lane", "density", "seed", "density_veh_per_km", "flow_veh_per_h",
               "speed_mps"]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=columns)


def _median(values: pd.Series) -> float:
    v = values.to_numpy(float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if len(v) else math.nan


def medians(pts: pd.DataFrame) -> pd.DataFrame:
    """fundamental.csv: per line, lane and density cell the number of runs and the
    medians of the measured density, flow and speed (FD_COLUMNS)."""
    rows = []
    for key, group in pts.groupby([*LINE, "lane", "density"], sort=True):
        rows.append((*key, len(group), _median(group.density_veh_per_km),
                     _median(group.flow_veh_per_h), _median(group.speed_mps)))
    return pd.DataFrame(rows, columns=list(FD_COLUMNS))


def capacity(fd: pd.DataFrame) -> pd.DataFrame:
    """Per line and lane: the capacity (the largest median flow over the density cells),
    the critical density (that cell's median measured density), the speed there, the
    cell's grid density and whether a denser cell flowed less (`past_peak`: 1 / 0)."""
    rows = []
    for key, group in fd.groupby([*LINE, "lane"], sort=True):
        flows = group.flow_veh_per_h_p50.to_numpy(float)
        if not np.isfinite(flows).any():
            continue
        k = int(np.nanargmax(flows))
        peak = group.iloc[k]
        denser = group[group.density > peak.density]
        rows.append((*key, float(peak.flow_veh_per_h_p50), float(peak.density_veh_per_km_p50),
                     float(peak.speed_mps_p50), float(peak.density),
                     int(len(denser) > 0 and bool((denser.flow_veh_per_h_p50
                                                   < peak.flow_veh_per_h_p50).any()))))
    return pd.DataFrame(rows, columns=list(CAPACITY_COLUMNS))


def traffic_summary(ok: pd.DataFrame, columns: list[str]) -> dict[str, Any]:
    """summary.csv's traffic columns of one cell's finished runs: `<column>_p50`, the
    median over the runs of each traffic measure in `columns` (NaN: none finite)."""
    return {f"{c}_p50": _median(pd.to_numeric(ok[c], errors="coerce")) if c in ok
            else math.nan for c in columns}


def capacity_markdown(cap: pd.DataFrame) -> str:
    """fundamental.md: the capacity table, one row per line and lane."""
    head = ["driver", "variant", "plant", "occupant", "mu", "lane",
            "capacity veh/h (per lane for all)", "critical density veh/km (per lane for all)",
            "speed at capacity km/h", "at grid density veh/km/lane", "denser cells flow less"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in cap.itertuples():
        lines.append("| " + " | ".join([
            str(r.driver), str(r.variant), str(r.plant), f"{r.occupant:g}", f"{r.mu:g}",
            str(r.lane), f"{r.capacity_veh_per_h:.0f}", f"{r.critical_density_veh_per_km:.1f}",
            f"{3.6 * r.speed_at_capacity_mps:.0f}", f"{r.density_cell:g}",
            "yes" if r.past_peak else "no (the peak may lie beyond the grid)"]) + " |")
    return ("Capacity: the largest median flow over the study's density cells; critical "
            "density: that cell's median measured density (cosim.study.fundamental).\n\n"
            + "\n".join(lines) + "\n")
