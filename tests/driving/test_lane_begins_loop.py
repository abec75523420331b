"""Routes whose SV lanes begin along the route, through the whole loop in real SUMO
(plant, controller, moveToXY) on a netconvert motorway with ramps (tests/road/ramps.py):
the SV starts on an on-ramp, drives it, enters the acceleration lane and merges into the
mainline once it runs beside it (also from a ramp lane that ends before the acceleration
lane); it leaves the mainline over an off-ramp, changing into the deceleration lane
once it begins, then driving onto the ramp; and it does both on one route."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.run.loop import simulate
from cosim.scenario.load import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parents[1] / "road"))
from ramps import build, build_dropped, build_weave  # noqa: E402

pytestmark = pytest.mark.sumo


@pytest.fixture(scope="module")
def network(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build(tmp_path_factory.mktemp("ramps"))


def _edges(result) -> list[str]:  # type: ignore[no-untyped-def]
    return [result.edges[int(k)] for k in result.trace["edge"]]


def _no_move_before(result, lane: int, begin: float) -> None:  # type: ignore[no-untyped-def]
    """The SV keeps its lane's centre until its rear is past `begin` (m of s)."""
    tr, half = result.trace, 0.5 * result.scenario.vehicle.length
    before = np.asarray(tr["s_m"]) - half < begin
    assert before.any()
    centre = result.road.lane_center(lane)
    assert np.max(np.abs(np.asarray(tr["d_m"])[before] - centre)) < 0.02


def test_the_sv_drives_an_on_ramp_and_merges_into_the_mainline(
        network: Path, tmp_path: Path) -> None:
    doc = {"scenario": {"name": "from_onramp", "duration_s": 11.0, "seed": 2},
           "road": {"network": str(network), "route": ["onramp", "acc", "b"], "mu": 0.8,
                    "lane_speeds_kmh": [[60, 90], [90, 120]]},
           "sv": {"edge": "onramp", "lane": 0, "position_m": 140.0, "speed_kmh": 80.0,
                  "decision": False},
           "traffic": {"density_veh_per_km_lane": 15.0, "length_m": 800.0},
           "planner": {"policy": "gap", "replanning": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "on.toml"))
    m, road = result.metrics, result.road
    edges = _edges(result)
    assert edges[0] == "onramp" and edges[-1] in ("acc", "b")
    assert road.lane_begin(1) > 200.0  # the mainline begins beside the ramp's lane
    _no_move_before(result, 0, road.lane_begin(1))
    assert m["merge_success"] == 1 and m["lane_end_reached"] == 0
    assert result.plans[0]["trigger"] == "mandatory"
    # on the mainline: its right lane (SUMO's acc_1 there)
    assert m["final_lane"] == 1 and int(result.trace["lane"][-1]) == 1
    assert int(result.trace["sumo_lane"][-1]) == (1 if edges[-1] == "acc" else 0)
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    assert int(np.max(result.trace["n_tvs"])) > 0  # with the mainline's traffic about


def test_the_sv_leaves_over_an_off_ramp_from_the_deceleration_lane(
        network: Path, tmp_path: Path) -> None:
    (tmp_path / "flows.rou.xml").write_text(
        '<routes><route id="main" edges="b dec c"/><flow id="m" route="main" begin="0" '
        'end="3600" vehsPerHour="1800" departLane="random" departSpeed="max"/></routes>',
        encoding="utf-8")
    doc = {"scenario": {"name": "to_offramp", "duration_s": 15.0, "seed": 1},
           "road": {"network": str(network), "route": ["b", "dec", "offramp"], "mu": 0.8,
                    "lane_speeds_kmh": [[60, 80], [90, 110], [110, 120]]},
           "sv": {"edge": "b", "lane": 0, "position_m": 550.0, "speed_kmh": 100.0,
                  "decision": True},
           "traffic": {"routes": ["flows.rou.xml"], "warmup_s": 30.0},
           "planner": {"policy": "gap", "replanning": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "off.toml"))
    m, road, tr = result.metrics, result.road, result.trace
    assert int(tr["lane"][0]) == 1  # SUMO's b_0, beside which the deceleration lane begins
    _no_move_before(result, 1, road.lane_begin(0))
    assert m["merge_success"] == 1 and m["final_lane"] == 0 and m["lane_end_reached"] == 0
    # in the deceleration lane before the diverge, then onto the ramp
    first = int(np.argmax(np.asarray(tr["lane"]) == 0))
    assert float(tr["s_m"][first]) < road.lane_end(1) - 50.0
    assert _edges(result)[-1] == "offramp"
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    assert int(np.max(tr["n_tvs"])) > 0  # SUMO's flow on the mainline beside it


def test_the_sv_leaves_a_ramp_lane_that_ends_then_merges_from_the_acceleration_lane(
        tmp_path: Path) -> None:
    """onramp ramp2 acc b (tests/road/ramps.py `build_dropped`): the ramp's lane runs on
    as ramp2's right lane, which ends at the gore. The SV on it changes (mandatory) into
    ramp2's left lane once that runs beside it, keeps it onto the acceleration lane and
    merges into the mainline once the mainline runs beside it: two changes, both
    completed, the first before the ramp lane's end, the second before the
    acceleration lane's. The ramp's 80 km/h is kept while the SV's front is on it."""
    network = build_dropped(tmp_path)
    doc = {"scenario": {"name": "dropped_ramp_lane", "duration_s": 13.0, "seed": 1},
           "road": {"network": str(network), "route": ["onramp", "ramp2", "acc", "b"],
                    "lane_speeds_kmh": [[90, 110], [110, 120]]},
           "sv": {"edge": "onramp", "lane": 0, "position_m": 235.0, "speed_kmh": 80.0,
                  "decision": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "dropped.toml"))
    m, road, tr = result.metrics, result.road, result.trace
    assert _edges(result)[0] == "onramp" and {"ramp2", "acc"} <= set(_edges(result))
    _no_move_before(result, 0, road.lane_begin(1))
    lane, s = np.asarray(tr["lane"]), np.asarray(tr["s_m"])
    assert [p["trigger"] for p in result.plans[:2]] == ["mandatory", "mandatory"]
    half = 0.5 * result.scenario.vehicle.length
    assert float(s[np.argmax(lane == 1)]) + half < road.lane_end(0)  # off the ramp lane
    assert float(s[np.argmax(lane == 2)]) + half < road.lane_end(1)  # merged
    assert m["lane_changes"] == 2 and m["lane_change_status"] == "completed"
    assert m["final_lane"] == 2 and m["lane_end_reached"] == 0
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.02
    front, vx = s + half, np.asarray(tr["vx_mps"])
    for k, zones in enumerate(road.speed_limits):
        for lo, hi, v in zones:
            on = (lane == k) & (front >= lo) & (front < hi)
            assert float(np.max(vx[on], initial=0.0)) <= v + 0.3


def test_the_sv_drives_from_an_on_ramp_over_the_mainline_to_an_off_ramp(
        tmp_path: Path) -> None:
    """onramp acc b dec offramp (tests/road/ramps.py `build_weave`: the acceleration lane
    ends 100 m before the deceleration lane begins), SUMO's flow of 1800 veh/h on the
    mainline: the SV drives the ramp, merges (mandatory) into the mainline's right lane
    once it runs beside it, keeps it until the deceleration lane (its SV lane 0 again)
    runs beside it, changes into it (mandatory) before the mainline lane exits, and
    leaves over the off-ramp: two changes, both completed, no collision."""
    network = build_weave(tmp_path)
    (tmp_path / "flows.rou.xml").write_text(
        '<routes><route id="main" edges="a acc b dec c"/><flow id="m" route="main" '
        'begin="0" end="3600" vehsPerHour="1800" departLane="random" departSpeed="max"/>'
        '</routes>', encoding="utf-8")
    doc = {"scenario": {"name": "weave", "duration_s": 21.5, "seed": 1},
           "road": {"network": str(network),
                    "route": ["onramp", "acc", "b", "dec", "offramp"], "mu": 0.8,
                    "lane_speeds_kmh": [[60, 80], [90, 110], [110, 120]]},
           "sv": {"edge": "onramp", "lane": 0, "position_m": 230.0, "speed_kmh": 80.0,
                  "decision": True},
           "traffic": {"routes": ["flows.rou.xml"], "warmup_s": 30.0},
           "planner": {"policy": "gap", "replanning": True}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "weave.toml"))
    m, road, tr = result.metrics, result.road, result.trace
    edges = _edges(result)
    assert edges[0] == "onramp" and edges[-1] == "offramp"
    assert road.lane_end(0) < road.lane_begin(0)  # the acceleration lane, then the exit's
    _no_move_before(result, 0, road.lane_begin(1))
    lane, s = np.asarray(tr["lane"]), np.asarray(tr["s_m"])
    half = 0.5 * result.scenario.vehicle.length
    changes = np.flatnonzero(np.diff(lane)) + 1
    assert [(int(lane[k - 1]), int(lane[k])) for k in changes] == [(0, 1), (1, 0)]
    merged, exited = changes
    assert s[merged] + half < road.lane_end(0)  # merged before the acceleration lane's end
    # into the deceleration lane once it runs beside the SV, before the mainline's exit
    assert s[exited] - half > road.lane_begin(0) and s[exited] + half < road.lane_end(1)
    assert [p["trigger"] for p in result.plans[:2]] == ["mandatory", "mandatory"]
    assert m["lane_changes"] == 2 and m["lane_change_status"] == "completed"
    assert m["merge_success"] == 1 and m["final_lane"] == 0 and m["lane_end_reached"] == 0
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.02
    assert int(np.max(tr["n_tvs"])) > 0  # SUMO's flow on the mainline beside it
