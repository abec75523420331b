"""The traffic's state along the route from SUMO's detectors (detectors.csv, cosim.traffic.
detectors): per SV lane (track) its flow, density and space-mean speed, and how much the
speed varies along the lane and over time (stop-and-go waves); metrics.csv's columns of a
run with `[detectors] enabled` (TRAFFIC_DOCS).

Only full periods on the run's clock count (begin_s >= 0, end_s - begin_s the period), and
of them those beginning at or after [detectors] measure_from_s: SUMO's last interval of
one step, the warm-up's and the start's transient are left out.

- flow: the mean over the lane's induction loops (E1) and periods of SUMO's flow (veh/h);
- density: the lane-area detectors' (E2) vehicles over their length, length-weighted
  over the lane's E2s, mean over periods (veh/km);
- space-mean speed: the E2s' mean speeds weighted by their vehicles (density x length),
  over the lane's E2s and periods: the mean speed of the vehicles on the lane at an
  instant, averaged over time (m/s);
- spatial spread: per period, the standard deviation (population, ddof 0) over the lane's
  loops of their mean speed (loops a vehicle passed; periods with two or more), mean over
  periods (m/s): a wave standing or moving along the lane shows as speeds that differ
  from loop to loop at one time;
- temporal spread: per loop, the standard deviation over the periods of its mean speed
  (periods a vehicle passed; loops with two or more), mean over the lane's loops (m/s): a
  wave passing a loop shows as its speed changing from period to period.

The road's values are the means over its lanes of theirs (flow and density per lane:
veh/h/lane, veh/km/lane, comparable with [traffic] density_veh_per_km_lane); its
space-mean speed is over all its E2s. Its outflow is what leaves the stretch measured: the
flow summed over the lanes at the route's last cross-section of loops that a vehicle
passed (a bottleneck's throughput, with loops placed downstream of it), mean over the
periods.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

S_SECTION = 1.0  # m, loops of different lanes this close along s are one cross-section
# the road's columns, then each lane's: (name, doc); <k> is the track
ROAD_DOCS: dict[str, str] = {
    "traffic_flow_veh_per_h_lane": "SUMO's detectors: the flow, mean over the SV lanes of "
    "each lane's mean over its induction loops and full periods (veh/h/lane)",
    "traffic_density_veh_per_km_lane": "the density, mean over the SV lanes of each lane's "
    "vehicles per km on its lane-area detectors (veh/km/lane)",
    "traffic_speed_mps": "space-mean speed: the lane-area detectors' mean speeds weighted "
    "by the vehicles on them, over all lanes and full periods (m/s; NaN: no vehicle)",
    "speed_spread_space_mps": "the speed's spread along the route: mean over the lanes of "
    "speed_spread_space_lane<k>_mps (m/s; NaN: no lane with two loops measuring)",
    "speed_spread_time_mps": "the speed's spread over time: mean over the lanes of "
    "speed_spread_time_lane<k>_mps (m/s; NaN: none)",
    "outflow_veh_per_h": "the outflow: the vehicles passing the route's last cross-section "
    "of loops a vehicle passed (outflow_s_m; every lane with a loop there), summed over its "
    "lanes, per hour, mean over full periods (veh/h; NaN: no loop passed)",
    "outflow_s_m": "where the outflow is counted: the largest s of an induction loop that "
    "a vehicle passed in a full period (a loop at the route's very end counts none: vehicles "
    "leave the network as they reach it) (m)",
}
LANE_DOCS: dict[str, str] = {
    "traffic_flow_lane<k>_veh_per_h": "lane k (track k, as detectors.csv's `track`): "
    "SUMO's flow, mean over its induction loops and full periods (veh/h)",
    "traffic_density_lane<k>_veh_per_km": "lane k: vehicles per km on its lane-area "
    "detectors, length-weighted, mean over full periods (veh/km)",
    "traffic_speed_lane<k>_mps": "lane k: space-mean speed, its lane-area detectors' mean "
    "speeds weighted by the vehicles on them (m/s; NaN: no vehicle)",
    "speed_spread_space_lane<k>_mps": "lane k: per full period the standard deviation "
    "(ddof 0) of the mean speeds of its loops a vehicle passed, mean over the periods with "
    "two or more such loops (m/s; NaN: none)",
    "speed_spread_time_lane<k>_mps": "lane k: per loop the standard deviation (ddof 0) of "
    "its mean speed over the full periods a vehicle passed it, mean over its loops with two "
    "or more such periods (m/s; NaN: none)",
}
TRAFFIC_DOCS: dict[str, str] = {**ROAD_DOCS, **LANE_DOCS}


def lane_column(pattern: str, track: int) -> str:
    """A lane's column name: `pattern` (a LANE_DOCS key) with <k> the track."""
    return pattern.replace("<k>", str(track))


def full_periods(table: Any, since: float = 0.0) -> Any:
    """The rows of detectors.csv's table over full periods beginning at or after `since`
    (s, on the run's clock; at least 0)."""
    span = table.end_s - table.begin_s
    if not len(table):
        return table
    period = float(span.max())
    return table[(table.begin_s >= max(since, 0.0) - 1e-9)
                 & np.isclose(span, period, rtol=0.0, atol=1e-6)]


def _mean(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.mean(finite)) if len(finite) else math.nan


def _weighted(values: np.ndarray, weights: np.ndarray) -> float:
    ok = np.isfinite(values) & (weights > 0)
    return float(np.sum(values[ok] * weights[ok]) / np.sum(weights[ok])) if ok.any() else math.nan


def _spread(loops: Any, by: str) -> float:
    """The mean over the groups of `by` of the standard deviation (ddof 0) of the loops'
    mean speed within each group (its finite values; groups with two or more)."""
    speeds = loops[np.isfinite(loops.mean_speed_mps)]
    stds = [float(np.std(g.mean_speed_mps.to_numpy(float)))
            for _, g in speeds.groupby(by, sort=True) if len(g) >= 2]
    return float(np.mean(stds)) if stds else math.nan


def lane_measures(rows: Any) -> dict[str, float]:
    """One lane's values (LANE_DOCS' patterns as keys) from its full-period rows."""
    loops, areas = rows[rows.kind == "e1"], rows[rows.kind == "e2"]
    density = areas.density_veh_per_km.to_numpy(float)
    length = areas.length_m.to_numpy(float)
    per_period = [_weighted(g.density_veh_per_km.to_numpy(float), g.length_m.to_numpy(float))
                  for _, g in areas.groupby("begin_s", sort=True)]
    return {
        "traffic_flow_lane<k>_veh_per_h": _mean(loops.flow_veh_per_h.to_numpy(float)),
        "traffic_density_lane<k>_veh_per_km": _mean(np.array(per_period, dtype=float)),
        "traffic_speed_lane<k>_mps": _weighted(areas.mean_speed_mps.to_numpy(float),
                                               density * length),
        "speed_spread_space_lane<k>_mps": _spread(loops, "begin_s"),
        "speed_spread_time_lane<k>_mps": _spread(loops, "detector"),
    }


def traffic_columns(table: Any, since: float = 0.0) -> dict[str, float]:
    """metrics.csv's traffic columns (TRAFFIC_DOCS: the road's, then each lane's by track)
    from detectors.csv's table, over its full periods beginning at or after `since` (s;
    [detectors] measure_from_s)."""
    rows = full_periods(table, since)
    tracks = sorted(int(k) for k in set(table.track))
    lanes = {k: lane_measures(rows[rows.track == k]) for k in tracks}
    areas = rows[rows.kind == "e2"]

    def over_lanes(pattern: str) -> float:
        return _mean(np.array([lanes[k][pattern] for k in tracks], dtype=float))

    out = {
        "traffic_flow_veh_per_h_lane": over_lanes("traffic_flow_lane<k>_veh_per_h"),
        "traffic_density_veh_per_km_lane": over_lanes("traffic_density_lane<k>_veh_per_km"),
        "traffic_speed_mps": _weighted(
            areas.mean_speed_mps.to_numpy(float),
            areas.density_veh_per_km.to_numpy(float) * areas.length_m.to_numpy(float)),
        "speed_spread_space_mps": over_lanes("speed_spread_space_lane<k>_mps"),
        "speed_spread_time_mps": over_lanes("speed_spread_time_lane<k>_mps"),
    }
    out.update(zip(("outflow_veh_per_h", "outflow_s_m"), outflow(rows), strict=True))
    for k in tracks:
        out.update({lane_column(p, k): v for p, v in lanes[k].items()})
    return out


def outflow(rows: Any) -> tuple[float, float]:
    """(veh/h, m): the flow over the last cross-section of loops a vehicle passed, summed
    over the lanes whose loop lies there (within S_SECTION of its s), mean over the periods
    of `rows` (full ones), and that s."""
    loops = rows[rows.kind == "e1"]
    passed = loops.groupby("s_m").vehicles.sum()
    passed = passed[passed > 0]
    if not len(passed):
        return math.nan, math.nan
    # a loop at the route's very end counts no one (vehicles leave the network there)
    last = float(passed.index.max())
    section = loops[loops.s_m >= last - S_SECTION]
    per_period = section.groupby("begin_s", sort=True).flow_veh_per_h.sum()
    return float(per_period.mean()), last
