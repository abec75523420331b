"""The fleet's baselines (cosim.run.fleet_watch, [fleet] driver) in real SUMO: the same
drawn vehicles driven by cosim, by SUMO's own driver and by SUMO's ACC / CACC models,
each measured in fleet.csv's columns and metrics.csv's fleet_* alike."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import libsumo
import numpy as np
import pandas as pd
import pytest

from cosim.errors import InputError
from cosim.run.fleet import FLEET_COLUMNS, FLEET_METRIC_DOCS
from cosim.run.fleet_watch import Watched
from cosim.run.loop import CoSimulation
from cosim.run.result import RunResult
from cosim.scenario import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parent))
from short_highway import short_highway  # noqa: E402

ROAD_LENGTH = 900.0  # m
DRIVERS = ("cosim", "sumo", "acc", "cacc")


def doc(network: Path, driver: str, controller: str = "mimo") -> dict[str, Any]:
    return {
        "scenario": {"name": "fleet", "duration_s": 16.0, "seed": 2},
        "road": {"network": str(network), "lane_speeds_kmh": [[60, 90], [90, 110],
                                                               [110, 120]]},
        "sv": {"lane": 0, "position_m": 100.0, "speed_kmh": 60.0, "controller": controller},
        "traffic": {"density_veh_per_km_lane": 14.0, "length_m": ROAD_LENGTH},
        "planner": {"policy": "gap"},
        "fleet": {"share": 0.4, "driver": driver},
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[RunResult, set[str]]]:
    """One run per driver; beside each, the vTypes SUMO had the drawn vehicles in."""
    folder = tmp_path_factory.mktemp("net")
    network = short_highway(folder, ROAD_LENGTH)
    out = {}
    for driver in DRIVERS:
        sim = CoSimulation(scenario_from_dict(doc(network, driver),
                                              path=folder / f"{driver}.toml"))
        types: set[str] = set()

        def seen(_: int, sim: CoSimulation = sim, types: set[str] = types) -> None:
            fleet = sim.fleet
            if fleet is not None:
                types.update(libsumo.vehicle.getTypeID(v) for v in fleet.watch.active)

        out[driver] = (sim.run(progress=seen), types)
    return out


def test_every_driver_gets_the_same_drawn_vehicles(runs: dict[str, Any]) -> None:
    ids = {d: [r["vehicle_id"] for r in runs[d][0].fleet.rows] for d in DRIVERS}
    assert len(ids["cosim"]) >= 4
    assert all(ids[d] == ids["cosim"] for d in DRIVERS)
    rows = {d: pd.DataFrame(runs[d][0].fleet.rows).set_index("vehicle_id") for d in DRIVERS}
    # drawn at the same insertion, taken over (watched) from the same row on
    for d in DRIVERS:
        assert set(rows[d].columns) == set(FLEET_COLUMNS) - {"vehicle_id"}
        assert (rows[d]["driver"] == d).all()
        np.testing.assert_array_equal(rows[d]["inserted_t_s"], rows["cosim"]["inserted_t_s"])
    first = rows["cosim"]["taken_over_t_s"].min()
    assert all(rows[d]["taken_over_t_s"].min() == first for d in DRIVERS)


def test_acc_and_cacc_drive_copies_of_their_vtype_with_sumos_model(
        runs: dict[str, Any]) -> None:
    for d in ("sumo", "acc", "cacc"):
        types = {t.split("@")[0] for t in runs[d][1]}
        assert types == ({"tv"} if d == "sumo" else {f"tv_{d}"})
    # SUMO's models drive them: their speeds differ from SUMO's own driver's
    speeds = {d: [r["mean_speed_mps"] for r in runs[d][0].fleet.rows] for d in DRIVERS}
    assert speeds["acc"] != speeds["sumo"] and speeds["cacc"] != speeds["sumo"]


def test_baselines_are_measured_like_the_fleet(runs: dict[str, Any]) -> None:
    for d in DRIVERS:
        result = runs[d][0]
        metrics = result.metrics
        assert set(FLEET_METRIC_DOCS) <= set(metrics)
        rows = pd.DataFrame(result.fleet.rows)
        assert metrics["fleet_vehicles"] == len(rows)
        assert metrics["fleet_collisions"] == 0 and metrics["fleet_teleported"] == 0
        assert 15.0 < metrics["fleet_mean_speed_mps"] < 34.0
        assert np.isfinite(rows["max_long_jerk_mps3"]).all()
        assert (rows["max_long_jerk_mps3"] >= 0).all()
        # a new follower's braking, SUMO's (not that of a vehicle cosim moves): within
        # SUMO's emergency deceleration
        follower = rows["follower_max_decel_mps2"].to_numpy(float)
        assert (follower[np.isfinite(follower)] <= 9.0).all()
    # a baseline has no trace rows of its own (SUMO drives it)
    assert runs["acc"][0].fleet.traces == [] and runs["cosim"][0].fleet.traces


def test_a_baseline_fleet_may_have_sumo_drive_the_sv(tmp_path: Path) -> None:
    network = Path(__file__).parents[2] / "networks" / "highway.net.xml"
    scenario_from_dict(doc(network, "acc", controller="sumo"), path=tmp_path / "a.toml")
    with pytest.raises(InputError) as info:
        scenario_from_dict(doc(network, "cosim", controller="sumo"), path=tmp_path / "b.toml")
    assert info.value.key == "sv.controller"
    with pytest.raises(InputError) as info:
        scenario_from_dict(doc(network, "idm"), path=tmp_path / "c.toml")
    assert info.value.key == "fleet.driver"


def test_a_new_follower_is_the_one_behind_in_its_lane_at_the_change() -> None:
    """At an AV's change (row 2: lane 0 -> 1) its new follower is "f", keeping lane 1:
    its braking counts while it stays that follower and keeps its lane; "g", arriving
    behind the AV by a change of its own, and "f" braking for a change of its own
    later, do not."""
    w = Watched("av", "tv", 0.0, 0, baseline=False)
    w.lane = [0, 0, 1, 1, 1, 1, 1, 1]
    w.follower = ["", "", "f", "f", "f", "g", "f", "f"]
    w.follower_changing = [False, False, False, False, False, False, True, False]
    w.follower_decel = [9.0, 9.0, 1.0, 2.0, 1.5, 8.0, 9.0, 0.5]
    assert w.new_follower_decel(1.0) == 2.0
    # a follower arriving by its own change at the AV's is not a new follower
    w.follower_changing[2] = True
    assert math.isnan(w.new_follower_decel(1.0))
