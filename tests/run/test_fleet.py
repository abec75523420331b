"""The fleet (cosim.run.fleet) in real SUMO: vehicles SUMO inserts during the run taken
over by the scenario's driver, driven to the route's end and handed back; trace.csv's
rows per vehicle, fleet.csv; the same seed, the same fleet."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from cosim.run.encounters import COLUMNS as ENCOUNTER_COLUMNS
from cosim.run.fleet import FLEET_COLUMNS, HANDBACK_DISTANCE, TAKEOVER_CLEARANCE, driver_scenario
from cosim.run.loop import CoSimulation, run_scenario, simulate
from cosim.run.result import RunResult
from cosim.scenario import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parent))
from short_highway import short_highway  # noqa: E402

ROAD_LENGTH = 900.0  # m: an AV inserted at the start reaches the hand-back within the run


def fleet_doc(network: Path, **fleet: Any) -> dict[str, Any]:
    """Medium traffic on the short highway; the SV cruises in lane 0 at 60 km/h (it
    stays on the road); the fleet decides its own lane changes (gap policy)."""
    return {
        "scenario": {"name": "fleet", "duration_s": 30.0, "seed": 2},
        "road": {"network": str(network), "lane_speeds_kmh": [[60, 90], [90, 110],
                                                               [110, 120]]},
        "sv": {"lane": 0, "position_m": 100.0, "speed_kmh": 60.0},
        "traffic": {"density_veh_per_km_lane": 14.0, "length_m": ROAD_LENGTH},
        "planner": {"policy": "gap"},
        "fleet": fleet,
    }


@pytest.fixture(scope="module")
def network(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return short_highway(tmp_path_factory.mktemp("net"), ROAD_LENGTH)


@pytest.fixture(scope="module")
def run(network: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[RunResult, Path]:
    folder = tmp_path_factory.mktemp("fleet")
    sc = scenario_from_dict(fleet_doc(network, share=0.4), path=folder / "fleet.toml")
    result = simulate(sc)
    from cosim.run.outputs import write_outputs

    write_outputs(result, folder / "out", write_figures=False)
    return result, folder / "out"


def test_automated_vehicles_are_taken_over_driven_and_handed_back(
        run: tuple[RunResult, Path]) -> None:
    result, _ = run
    rows = pd.DataFrame(result.fleet.rows)
    assert len(rows) >= 5  # 40 % of the inflow (about 2 vehicles a second on 3 lanes)
    assert (rows["inserted_t_s"] > 0).all()  # inserted during the run, not at t = 0
    # taken over once clear of where the inflow enters (near s = 0)
    assert (rows["s_start_m"] >= TAKEOVER_CLEARANCE).all()
    assert (rows["s_start_m"] < TAKEOVER_CLEARANCE + 10.0).all()
    handed = rows[rows["end"] == "handed_back"]
    assert len(handed) >= 1
    assert (handed["s_end_m"] >= ROAD_LENGTH - HANDBACK_DISTANCE).all()
    assert set(rows["end"]) <= {"handed_back", "running"}
    # none teleported or lost, no collision of an AV (our check and SUMO's), none caused
    assert result.events == []
    assert (rows[["collisions", "caused_collisions", "sumo_collisions", "teleported"]]
            == 0).all().all()
    assert rows["lane_changes"].sum() >= 1  # their own decisions, planned and flown
    # each AV's trace: its own rows from its takeover, tracking its references closely
    for vid, trace, _ in result.fleet.traces:
        row = rows[rows["vehicle_id"] == vid].iloc[0]
        t = trace["t_s"]
        assert t[0] == row["taken_over_t_s"] and t[-1] == row["end_t_s"]
        assert np.allclose(np.diff(t), 0.05)
        assert np.nanmax(np.abs(trace["ye_m"])) < 0.5
        assert (trace["collisions"] == 0).all()


def test_trace_has_every_vehicle_by_time_then_id_and_fleet_csv(
        run: tuple[RunResult, Path]) -> None:
    result, out = run
    trace = pd.read_csv(out / "trace.csv", keep_default_na=False)
    assert list(trace.columns)[-1] == "vehicle_id"
    keys = list(zip(trace["t_s"], trace["vehicle_id"], strict=True))
    assert keys == sorted(keys)
    counts = trace["vehicle_id"].value_counts()
    assert counts["sv"] == len(result.trace["t_s"])
    for vid, tr, _ in result.fleet.traces:
        assert counts[vid] == len(tr["t_s"])
    fleet = pd.read_csv(out / "fleet.csv")
    assert list(fleet.columns) == list(FLEET_COLUMNS)
    assert len(fleet) == len(result.fleet.rows)
    # plans.csv: every vehicle's plans, by time then id; metrics.csv: the fleet's sums
    plans = pd.read_csv(out / "plans.csv", keep_default_na=False)
    assert list(plans.columns)[-1] == "vehicle_id"
    keys = list(zip(plans["t_s"], plans["vehicle_id"], strict=True))
    assert keys == sorted(keys)
    adopted = plans[(plans["vehicle_id"] != "sv") & (plans["ok"] == 1)]
    assert len(adopted) >= fleet["lane_changes"].sum()
    metrics = pd.read_csv(out / "metrics.csv").iloc[0]
    assert metrics["fleet_vehicles"] == len(fleet)
    assert metrics["fleet_lane_changes"] == fleet["lane_changes"].sum()
    assert metrics["fleet_caused_collisions"] == 0 and metrics["fleet_teleported"] == 0


def test_an_automated_vehicles_driver_rechecks_its_change_under_way(
        network: Path, tmp_path: Path) -> None:
    # [planner] replanning off (the paper's one-shot plan, the SV's): an AV re-checks all
    # the same (flown blind, penetration_open's AVs at 24 veh/km/lane ran into SUMO's car
    # ahead that braked and cut into their target lane during their 7 s change)
    sc = scenario_from_dict(fleet_doc(network, share=0.4), path=tmp_path / "fleet.toml")
    assert not sc.planner.replanning
    av = driver_scenario(sc, 2, 25.0)
    assert av.planner.replanning and av.sv.decision
    assert (av.sv.lane, av.sv.speed, av.sv.lane_changes, av.sv.desired_speed) == (
        2, 25.0, (), None)
    assert av.planner.policy == sc.planner.policy


def test_no_fleet_writes_what_it_always_wrote(network: Path, tmp_path: Path) -> None:
    """Without [fleet] no vehicle_id column and no fleet.csv (a short run)."""
    doc = fleet_doc(network)
    doc["scenario"]["duration_s"] = 2.0
    sc = scenario_from_dict(doc, path=tmp_path / "none.toml")
    run_scenario(sc, tmp_path / "out", write_figures=False)
    assert "vehicle_id" not in pd.read_csv(tmp_path / "out" / "trace.csv").columns
    assert not (tmp_path / "out" / "fleet.csv").exists()


def test_the_same_seed_gives_the_same_fleet_byte_for_byte(network: Path, tmp_path: Path
                                                          ) -> None:
    doc = fleet_doc(network, share=0.5)
    doc["scenario"]["duration_s"] = 12.0
    sc = scenario_from_dict(doc, path=tmp_path / "twice.toml")
    for name in ("a", "b"):
        run_scenario(sc, tmp_path / name, write_figures=False)
    assert len(pd.read_csv(tmp_path / "a" / "fleet.csv")) >= 2
    for csv in ("trace.csv", "plans.csv", "metrics.csv", "fleet.csv"):
        assert (tmp_path / "a" / csv).read_bytes() == (tmp_path / "b" / csv).read_bytes(), csv


@pytest.fixture(scope="module")
def own(network: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """[fleet] vtypes = ["av"] in the user's own demand (2400 cars/h, 600 avs/h), 25 s
    after a 30 s warm-up; SUMO's SSM device on the SV and the av vehicles ([ssm]
    vehicles = "fleet"), 100 m range, TTC threshold 60 s so that following is logged."""
    folder = tmp_path_factory.mktemp("own")
    (folder / "own.rou.xml").write_text(
        '<routes><vType id="car" length="4.5" width="1.8" sigma="0.5" maxSpeed="36.1"/>'
        '<vType id="av" length="4.6" width="1.9" maxSpeed="36.1"/>'
        '<route id="through" edges="highway"/>'
        '<flow id="cars" type="car" route="through" begin="0" end="3600" vehsPerHour="2400" '
        'departLane="random" departSpeed="max"/>'
        '<flow id="avs" type="av" route="through" begin="0" end="3600" vehsPerHour="600" '
        'departLane="random" departSpeed="max"/></routes>')
    doc = fleet_doc(network, vtypes=["av"])
    doc["scenario"]["duration_s"] = 25.0
    doc["traffic"] = {"routes": [str(folder / "own.rou.xml")], "warmup_s": 30.0}
    doc["ssm"] = {"enabled": True, "vehicles": "fleet", "ttc_s": 60.0, "range_m": 100.0}
    sim = CoSimulation(scenario_from_dict(doc, path=folder / "own.toml"),
                       detector_output=folder)
    result = sim.run()
    from cosim.run.outputs import write_outputs

    write_outputs(result, folder / "out", write_figures=False)
    return {"result": result, "steps": sim.encounters.steps(), "dt": 0.05,
            "out": folder / "out"}


def test_vtypes_of_the_users_own_demand_are_automated(own: dict[str, Any]) -> None:
    """[fleet] vtypes: every vehicle of the named vType SUMO inserts after the warm-up is
    automated (one of another size given the scenario's), the others stay SUMO's."""
    result = own["result"]
    rows = pd.DataFrame(result.fleet.rows)
    assert len(rows) >= 2 and set(rows["vtype"]) == {"av"}
    assert (rows["inserted_t_s"] > 0).all()  # after the warm-up, on the run's clock
    assert result.events == []
    assert (rows[["collisions", "caused_collisions", "sumo_collisions"]] == 0).all().all()
    for _, trace, _ in result.fleet.traces:  # the car it drives is the scenario's
        assert np.nanmax(np.abs(trace["ye_m"])) < 0.5


def test_sumos_ttc_for_the_automated_vehicles_against_ours(own: dict[str, Any]) -> None:
    """SUMO's device is on the SV and the av vehicles alone; ours (fleet_conflicts.csv)
    is on the SV and each AV from its takeover. Every SUMO conflict of an automated ego
    within ours is a following one, and within a step of SUMO's minimum (SUMO sees the
    pair a step apart) our TTC is SUMO's within 2 % (SUMO's two decimals), as for the SV
    alone (tests/traffic/test_ssm.py), but where SUMO's minimum came as a lane change put
    the two on one lane while their rectangles were still beside each other (SUMO's
    lanes, our strips); our encounter's minimum is no higher.
    SUMO has no PET on one road's lanes; ours measures the AVs' lane changes."""
    result, steps, dt = own["result"], own["steps"], own["dt"]
    sumo, ours = result.conflicts, result.fleet_conflicts
    rows = pd.DataFrame(result.fleet.rows)
    taken = dict(zip(rows["vehicle_id"], rows["taken_over_t_s"], strict=True))
    assert set(sumo["ego"]) <= {"sv"} | {f"avs.{i}" for i in range(100)}
    assert "sv" in set(sumo["ego"]) and set(taken) & set(sumo["ego"])
    assert list(ours.columns) == list(ENCOUNTER_COLUMNS)
    written = pd.read_csv(own["out"] / "fleet_conflicts.csv")
    assert list(written.columns) == list(ENCOUNTER_COLUMNS) and len(written) == len(ours)
    assert set(ours["ego"]) <= {"sv", *taken} and set(taken) & set(ours["ego"])
    compared = changing = 0
    for row in sumo.itertuples():
        since = 0.0 if row.ego == "sv" else taken.get(row.ego, np.inf)
        if not np.isfinite(row.ttc_min_s) or row.ttc_min_t_s < since + dt:
            continue  # before the takeover: SUMO drove it, ours does not look
        assert row.ttc_min_type in ("following_follower", "following_leader")
        pair = steps[(steps.ego == row.ego) & (steps.foe == row.foe)]
        around = np.abs(pair["t_s"].to_numpy() - row.ttc_min_t_s) <= dt + 1e-6  # a step apart
        ttc = pair["ttc_s"].to_numpy()[around]
        assert around.any(), row  # in our range and beside or in the ego's strip
        if not np.isfinite(ttc).any():  # a lane change: SUMO has them on one lane, their
            changing += 1  # rectangles do not share a strip yet (or any more)
            continue
        assert np.min(np.abs(ttc - row.ttc_min_s)) <= 0.02 * row.ttc_min_s, row
        mine = ours[(ours.ego == row.ego) & (ours.foe == row.foe)
                    & (ours.begin_s <= row.ttc_min_t_s + dt + 1e-6)
                    & (ours.end_s >= row.ttc_min_t_s - dt - 1e-6)]
        assert len(mine) == 1 and mine.ttc_min_s.iloc[0] <= 1.02 * row.ttc_min_s, row
        compared += 1
    assert compared >= 5 and changing <= 2
    assert sumo["pet_s"].isna().all()
    assert rows["lane_changes"].sum() >= 1 and ours["pet_s"].notna().any()
