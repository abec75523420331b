"""Vehicles moved by moveToXY (cosim.traffic.controlled) in real SUMO: a SUMO car that an
automated vehicle, moved across the lane line out of the car's lane, passes in the
next lane drives on without braking (SUMO takes it for a leader overlapping its lane
while it keeps a stale shadow lane there), and SUMO sees no collision of it."""

from __future__ import annotations

import sys
from pathlib import Path

import libsumo
import pytest

from cosim.run.loop import CoSimulation
from cosim.run.result import RunResult
from cosim.scenario import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parents[1] / "run"))
from short_highway import short_highway  # noqa: E402

pytestmark = pytest.mark.sumo


def routes(folder: Path) -> Path:
    """In lane 0 a slow leader (16 m/s) and the car behind it, which changes to lane 1
    ahead of the automated vehicle `a` (22 m/s): `a` moves on to lane 2 and passes it."""
    keep = 'sigma="0"'
    path = folder / "pass.rou.xml"
    path.write_text(
        f'<routes><vType id="slow" length="4.5" width="1.8" maxSpeed="16" {keep}/>'
        f'<vType id="av" length="4.6" width="1.9" maxSpeed="22" {keep}/>'
        f'<vType id="car" length="4.5" width="1.8" maxSpeed="25" {keep}/>'
        '<route id="through" edges="highway"/>'
        '<vehicle id="lead0" type="slow" route="through" depart="0" departLane="0" '
        'departPos="80" departSpeed="16"/>'
        '<vehicle id="car" type="car" route="through" depart="0" departLane="0" '
        'departPos="50" departSpeed="16"/>'
        '<vehicle id="a" type="av" route="through" depart="0.5" departLane="1" '
        'departPos="0" departSpeed="22"/></routes>')
    return path


@pytest.fixture(scope="module")
def passing(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunResult, list[tuple]]:
    """The run and, each step with both on the road: (t, car's acceleration m/s^2, car's
    lane, a's lane, a's front ahead of the car's m)."""
    folder = tmp_path_factory.mktemp("pass")
    doc = {
        "scenario": {"name": "pass", "duration_s": 15.5, "seed": 3},
        "road": {"network": str(short_highway(folder, 1200.0)),
                 "lane_speeds_kmh": [[60, 90], [90, 110], [110, 120]]},
        "sv": {"lane": 2, "position_m": 100.0, "speed_kmh": 110.0},
        "traffic": {"routes": [str(routes(folder))]},
        "planner": {"policy": "gap"},
        "v2v": {"latency_s": 0.1, "loss": 0.2},
        "fleet": {"vtypes": ["av"]},
    }
    sim = CoSimulation(scenario_from_dict(doc, path=folder / "pass.toml"))
    seen: list[tuple] = []
    vehicle = libsumo.vehicle

    def watch(_: int) -> None:
        if {"car", "a"} <= set(vehicle.getIDList()):
            seen.append((libsumo.simulation.getTime(), vehicle.getAcceleration("car"),
                         vehicle.getLaneIndex("car"), vehicle.getLaneIndex("a"),
                         vehicle.getLanePosition("a") - vehicle.getLanePosition("car")))

    return sim.run(progress=watch), seen


def test_a_car_passed_by_a_vehicle_moved_out_of_its_lane_does_not_brake(
        passing: tuple[RunResult, list[tuple]]) -> None:
    result, seen = passing
    assert result.events == []
    assert [row["sumo_collisions"] for row in result.fleet.rows] == [0]
    before = [row for row in seen if row[2] == row[3]]  # a behind the car in its lane
    assert before and seen[-1][3] == before[-1][3] + 1  # then moved out of it
    assert seen[-1][4] > 4.6  # and passed the car: its rear ahead of the car's front
    assert min(row[1] for row in seen) > -3.0  # m/s^2 (was SUMO's emergency 9)
