"""The traffic's flow, density, speed and speed spread from SUMO's detectors
(cosim.traffic.traffic_measures) in metrics.csv: recomputed here by hand from the run's
detectors.csv, and against what the vehicles did (the FCD's speeds)."""

from __future__ import annotations

import math
import statistics
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from cosim.run.loop import run_scenario
from cosim.scenario import load_scenario, with_overrides
from cosim.traffic.traffic_measures import LANE_DOCS, ROAD_DOCS, lane_column, traffic_columns

ROOT = Path(__file__).resolve().parents[2]
PERIOD = 2.5  # s


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """traffic_jam (its queue forms from 5 s), 20 s with SUMO's driver, loops every 200 m,
    2.5 s periods."""
    out = tmp_path_factory.mktemp("jam")
    sc = with_overrides(load_scenario(ROOT / "scenarios" / "traffic_jam.toml"),
                        controller="sumo", duration=20.0,
                        **{"detectors.enabled": True, "detectors.period_s": PERIOD,
                           "detectors.spacing_m": 200.0, "detectors.areas": "stretches"})
    run_scenario(sc, out, write_figures=False)
    return {"metrics": pd.read_csv(out / "metrics.csv").iloc[0],
            "detectors": pd.read_csv(out / "detectors.csv")}


def _hand(det: pd.DataFrame, track: int, since: float = 0.0) -> dict[str, float]:
    """One lane's values as the docs define them, with plain loops over the rows (the
    full periods beginning at or after `since`)."""
    full = [r for r in det.itertuples() if r.track == track and r.begin_s >= since
            and abs(r.end_s - r.begin_s - PERIOD) < 1e-9]
    loops = [r for r in full if r.kind == "e1"]
    areas = [r for r in full if r.kind == "e2"]
    flow = statistics.fmean(r.flow_veh_per_h for r in loops)
    periods = sorted({r.begin_s for r in areas})
    density = statistics.fmean(
        sum(r.density_veh_per_km * r.length_m for r in areas if r.begin_s == b)
        / sum(r.length_m for r in areas if r.begin_s == b) for b in periods)
    moving = [r for r in areas if not math.isnan(r.mean_speed_mps)]
    speed = (sum(r.mean_speed_mps * r.density_veh_per_km * r.length_m for r in moving)
             / sum(r.density_veh_per_km * r.length_m for r in moving))
    passed = [r for r in loops if not math.isnan(r.mean_speed_mps)]

    def spread(key: str) -> float:
        groups: dict[Any, list[float]] = {}
        for r in passed:
            groups.setdefault(getattr(r, key), []).append(r.mean_speed_mps)
        stds = [statistics.pstdev(v) for v in groups.values() if len(v) >= 2]
        return statistics.fmean(stds) if stds else math.nan

    return {"traffic_flow_lane<k>_veh_per_h": flow,
            "traffic_density_lane<k>_veh_per_km": density,
            "traffic_speed_lane<k>_mps": speed,
            "speed_spread_space_lane<k>_mps": spread("begin_s"),
            "speed_spread_time_lane<k>_mps": spread("detector")}


def test_metrics_are_the_hand_computation_from_detectors_csv(run: dict[str, Any]) -> None:
    m, det = run["metrics"], run["detectors"]
    tracks = sorted(set(det.track))
    assert tracks == [0, 1, 2]
    hand = {k: _hand(det, k) for k in tracks}
    for k in tracks:
        for pattern in LANE_DOCS:
            assert m[lane_column(pattern, k)] == pytest.approx(hand[k][pattern], rel=1e-6), (
                pattern, k)
    for road, pattern in (("traffic_flow_veh_per_h_lane", "traffic_flow_lane<k>_veh_per_h"),
                          ("traffic_density_veh_per_km_lane",
                           "traffic_density_lane<k>_veh_per_km"),
                          ("speed_spread_space_mps", "speed_spread_space_lane<k>_mps"),
                          ("speed_spread_time_mps", "speed_spread_time_lane<k>_mps")):
        assert m[road] == pytest.approx(np.mean([hand[k][pattern] for k in tracks]), rel=1e-6)
    # the outflow: the loops at the largest s, summed over the lanes, mean over periods
    full = det[(det.kind == "e1") & (det.begin_s >= 0)
               & ((det.end_s - det.begin_s - PERIOD).abs() < 1e-9)]
    passed = full.groupby("s_m").vehicles.sum()
    last = passed[passed > 0].index.max()
    assert last < full.s_m.max()  # the loops at the route's end (6 km) count no one
    assert m["outflow_s_m"] == last
    sums = [sum(r.flow_veh_per_h for r in full.itertuples() if r.begin_s == b and r.s_m == last)
            for b in sorted(set(full.begin_s))]
    assert m["outflow_veh_per_h"] == pytest.approx(statistics.fmean(sums), rel=1e-9)
    # [detectors] measure_from_s: only the periods from then on
    late = traffic_columns(det, since=10.0)
    for k in tracks:
        for pattern, value in _hand(det, k, since=10.0).items():
            assert late[lane_column(pattern, k)] == pytest.approx(value, rel=1e-6, nan_ok=True)
    assert late["traffic_speed_lane1_mps"] != pytest.approx(m["traffic_speed_lane1_mps"])
    # the columns: METRIC_DOCS' first, then the road's, then each lane's
    names = list(m.index)
    lanes = [lane_column(p, k) for k in tracks for p in LANE_DOCS]
    assert names[-len(lanes) - len(ROAD_DOCS):] == [*ROAD_DOCS, *lanes]


def test_the_queue_shows_as_spread(run: dict[str, Any]) -> None:
    """The three TVs brake to a stop from 5 s: the loops behind them see lower speeds
    than the others, so every lane's speed varies along it and over time; the values
    are speeds the traffic had (0 to the fastest band, 120 km/h)."""
    m = run["metrics"]
    for k in range(3):
        for name in ("speed_spread_space_lane<k>_mps", "speed_spread_time_lane<k>_mps"):
            assert 0.5 < m[lane_column(name, k)] < 120 / 3.6, (name, k)
        assert 0.0 < m[lane_column("traffic_speed_lane<k>_mps", k)] < 120 / 3.6
        assert m[lane_column("traffic_flow_lane<k>_veh_per_h", k)] > 0.0


def test_one_loop_and_one_period_give_no_spread() -> None:
    """A lane with one loop has no spatial spread, one full period no temporal one (NaN,
    not 0); periods that are not full (the last step's) are left out."""
    rows = [(0.0, 10.0, "e1_a", "e1", "l_0", 0, 0.0, math.nan, 900.0, math.nan, 5.0, 20.0, 3),
            (0.0, 10.0, "e2_a", "e2", "l_0", 0, 0.0, 100.0, math.nan, 12.0, 8.0, 18.0, 2),
            (10.0, 10.05, "e1_a", "e1", "l_0", 0, 0.0, math.nan, 0.0, math.nan, 0.0, 3.0, 0)]
    from cosim.traffic.detectors import COLUMNS

    out = traffic_columns(pd.DataFrame(rows, columns=list(COLUMNS)))
    assert out["traffic_flow_lane0_veh_per_h"] == 900.0
    assert out["traffic_density_lane0_veh_per_km"] == 12.0
    assert out["traffic_speed_lane0_mps"] == 18.0
    assert math.isnan(out["speed_spread_space_lane0_mps"])
    assert math.isnan(out["speed_spread_time_lane0_mps"])


def test_the_bottlenecks_outflow_is_counted_past_the_drop(tmp_path: Path) -> None:
    """scenarios/bottleneck.toml, 6 s: the outflow is counted at s = 4500 m, 1 km past
    the lane drop, over the two lanes that run on (the loops at the route's end, 5 km,
    count no one), and is their flows' sum."""
    sc = with_overrides(load_scenario(ROOT / "scenarios" / "bottleneck.toml"), duration=6.0,
                        **{"detectors.period_s": 3.0, "detectors.measure_from_s": 0.0})
    run_scenario(sc, tmp_path, write_figures=False)
    m = pd.read_csv(tmp_path / "metrics.csv").iloc[0]
    det = pd.read_csv(tmp_path / "detectors.csv")
    assert m["outflow_s_m"] == pytest.approx(4500.0, abs=0.5)
    at = det[(det.kind == "e1") & (abs(det.s_m - 4500.0) < 0.5) & (det.end_s - det.begin_s == 3.0)]
    assert sorted(set(at.track)) == [0, 1]
    assert m["outflow_veh_per_h"] == pytest.approx(at.groupby("begin_s").flow_veh_per_h.sum()
                                                   .mean())
    assert m["outflow_veh_per_h"] > 1000.0  # the 16 veh/km/lane filled in at t = 0
    assert {2} <= set(det.track) and det[det.track == 2].s_m.max() < 3500.0  # the drop
