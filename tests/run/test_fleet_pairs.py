"""Pairs of automated vehicles in real SUMO (cosim.run.fleet with cosim.run.announcements):
two of them, each stuck behind a slow car, signalling into the same free lane at once,
from both sides or one behind the other in one lane, hearing each other through V2V
with latency and loss: both get over, one after the other, nobody collides and nobody
waits for good (who yields to whose C2 / C3 on hand-made scenes: test_announcements.py).
An automated vehicle asked by another for room makes it; SUMO's drivers make room for
one that asks."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from cosim.run.loop import simulate
from cosim.run.result import RunResult
from cosim.scenario import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parent))
from short_highway import short_highway  # noqa: E402

ROAD_LENGTH = 1200.0  # m
LATENCY = 0.1  # s
LOSS = 0.2


def demand(folder: Path, avs: dict[str, tuple[int, float]]) -> Path:
    """Slow cars (16 m/s) ahead in lanes 0 and 2; the automated vehicles `avs` (id ->
    lane, departure position m) inserted at t = 0.5 s at 22 m/s; lane 1 free. No SUMO
    lane changes of their own (they keep their lanes until taken over)."""
    keep = 'lcSpeedGain="0" lcKeepRight="0" lcCooperative="0" sigma="0"'
    cars = "".join(
        f'<vehicle id="{vid}" type="av" route="through" depart="0.5" departLane="{lane}" '
        f'departPos="{pos}" departSpeed="22"/>' for vid, (lane, pos) in avs.items())
    path = folder / "pairs.rou.xml"
    path.write_text(
        f'<routes><vType id="slow" length="4.5" width="1.8" maxSpeed="16" {keep}/>'
        f'<vType id="av" length="4.6" width="1.9" maxSpeed="22" {keep}/>'
        '<route id="through" edges="highway"/>'
        '<vehicle id="slow0" type="slow" route="through" depart="0" departLane="0" '
        'departPos="150" departSpeed="16"/>'
        '<vehicle id="slow2" type="slow" route="through" depart="0" departLane="2" '
        'departPos="150" departSpeed="16"/>'
        f'{cars}</routes>')
    return path


def pair_doc(network: Path, routes: Path) -> dict[str, Any]:
    """The SV far ahead in lane 1 (out of their way); the pair's V2V late and lossy."""
    return {
        "scenario": {"name": "pairs", "duration_s": 16.0, "seed": 3},
        "road": {"network": str(network), "lane_speeds_kmh": [[60, 90], [90, 110],
                                                               [110, 120]]},
        "sv": {"lane": 1, "position_m": 500.0, "speed_kmh": 110.0},
        "traffic": {"routes": [str(routes)]},
        "planner": {"policy": "gap"},
        "v2v": {"latency_s": LATENCY, "loss": LOSS},
        "fleet": {"vtypes": ["av"]},
    }


def run_pair(folder: Path, avs: dict[str, tuple[int, float]]) -> RunResult:
    network = short_highway(folder, ROAD_LENGTH)
    doc = pair_doc(network, demand(folder, avs))
    return simulate(scenario_from_dict(doc, path=folder / "pairs.toml"))


@pytest.fixture(scope="module")
def both_sides(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """a in lane 0, b in lane 2, level: both want lane 1 at the same step."""
    return run_pair(tmp_path_factory.mktemp("sides"), {"a": (0, 0.0), "b": (2, 0.0)})


@pytest.fixture(scope="module")
def one_gap(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """a and b in lane 0, b 25 m behind a: both aim at the free lane beside them."""
    return run_pair(tmp_path_factory.mktemp("gap"), {"a": (0, 25.0), "b": (0, 0.0)})


def changes(result: RunResult) -> pd.DataFrame:
    """The first adopted plan of each of the pair (start t_s, origin and target lane), in
    time order."""
    plans = pd.DataFrame(result.fleet.plans)
    return plans[plans["ok"] == 1].sort_values("t_s").drop_duplicates("vehicle_id")


def no_collision(result: RunResult) -> None:
    rows = pd.DataFrame(result.fleet.rows)
    assert set(rows["vehicle_id"]) == {"a", "b"}
    assert result.events == []  # none teleported or removed by SUMO
    assert (rows[["collisions", "caused_collisions", "sumo_collisions"]] == 0).all().all()
    assert result.metrics["collisions"] == 0  # the SV's


def test_both_sides_one_goes_first_the_other_follows(both_sides: RunResult) -> None:
    """Both get into lane 1 (nobody waits for good), one after the other: the second
    starts only once the first's change is under way and heard (its C3, the latency
    later), planned around it."""
    no_collision(both_sides)
    # no abort: each hears the other at its real speed (SUMO holds a vehicle's speed to
    # its maximum, 22 m/s for these, unless a taken-over one gets the controlled cap)
    plans = pd.DataFrame(both_sides.fleet.plans)
    assert (plans.loc[plans["ok"] == 1, "target_lane"] == 1).all()
    adopted = changes(both_sides)
    assert sorted(adopted["vehicle_id"]) == ["a", "b"]
    assert (adopted["target_lane"] == 1).all()
    t_first, t_second = adopted["t_s"].tolist()
    assert t_second >= t_first + LATENCY
    # the first is in lane 1 from its start on (its broadcast change): the second goes
    # behind it, at least its secure gap (0.6 s headway, 2.5 m) back when it starts
    first, second = adopted["vehicle_id"].tolist()
    at = {vid: pd.DataFrame(trace).set_index("t_s").loc[t_second]
          for vid, trace, _ in both_sides.fleet.traces}
    gap = at[first]["s_m"] - at[second]["s_m"] - 4.6
    assert gap >= 0.6 * at[second]["vx_mps"] + 2.5


def test_one_gap_two_in_one_lane_go_in_turn(one_gap: RunResult) -> None:
    no_collision(one_gap)
    adopted = changes(one_gap)
    assert sorted(adopted["vehicle_id"]) == ["a", "b"]
    assert (adopted["target_lane"] == 1).all()


def slow_car_doc(folder: Path, name: str, keep: str, car_speed: float,
                 vehicles: str) -> dict[str, Any]:
    """A scene of `vehicles` (route file XML: "car" SUMO drivers at car_speed m/s, "av"
    automated at 20) with a slow car (12 m/s) 150 m in, in lane 0; SUMO's lane-change
    attributes `keep` on every vType; the SV out of the way in lane 2, 14 s."""
    routes = folder / f"{name}.rou.xml"
    routes.write_text(
        f'<routes><vType id="slow" length="4.5" width="1.8" maxSpeed="12" {keep}/>'
        f'<vType id="car" length="4.5" width="1.8" maxSpeed="{car_speed:g}" {keep}/>'
        f'<vType id="av" length="4.6" width="1.9" maxSpeed="20" {keep}/>'
        '<route id="through" edges="highway"/>'
        '<vehicle id="slow0" type="slow" route="through" depart="0" departLane="0" '
        f'departPos="150" departSpeed="12"/>{vehicles}</routes>')
    doc = pair_doc(short_highway(folder, ROAD_LENGTH), routes)
    doc["sv"] = {"lane": 2, "position_m": 500.0, "speed_kmh": 110.0}
    doc["scenario"]["duration_s"] = 14.0
    return doc


def platoon_doc(folder: Path, courtesy: bool) -> dict[str, Any]:
    """One AV in lane 0 behind a slow car; lane 1 a platoon of SUMO's drivers 30 m
    apart at 22 m/s (no gap an AV takes unasked); lane 2 empty."""
    doc = slow_car_doc(folder, "platoon", 'lcSpeedGain="0" lcKeepRight="0" sigma="0"', 22,
                       '<flow id="platoon" type="car" route="through" begin="0" end="30" '
                       'period="1.364" departLane="1" departPos="0" departSpeed="22"/>'
                       '<vehicle id="a" type="av" route="through" depart="0.5" departLane="0" '
                       'departPos="0" departSpeed="20"/>')
    doc["traffic"]["courtesy"] = courtesy
    return doc


@pytest.mark.parametrize("courtesy", [True, False])
def test_sumo_drivers_make_room_for_an_automated_vehicle_that_asks(
        tmp_path: Path, courtesy: bool) -> None:
    """An AV seeking a gap asks the SUMO driver blocking it to make room, as the SV does
    (the traffic's courtesy): with it the AV gets into the dense lane, without it (no
    gap opens: SUMO's own courtesy never reaches a vehicle moved by moveToXY) it stays
    behind its slow car."""
    result = simulate(scenario_from_dict(platoon_doc(tmp_path, courtesy),
                                         path=tmp_path / "platoon.toml"))
    rows = pd.DataFrame(result.fleet.rows)
    assert list(rows["vehicle_id"]) == ["a"] and result.events == []
    assert (rows[["collisions", "sumo_collisions"]] == 0).all().all()
    assert (rows["lane_changes"].iloc[0] >= 1) == courtesy


def test_an_automated_vehicle_asked_for_room_makes_it(tmp_path: Path) -> None:
    """a (lane 0, a slow car ahead) wants lane 1, where b (automated) drives level with
    it behind a SUMO car 40 m ahead (lane 2 no faster: b wants no change itself): a
    asks b for room over V2V (latency, loss), b falls back as SUMO's drivers do for the
    courtesy (braking 2 m/s^2 at most) and a changes in ahead of it. (b not making
    room: a slows behind its slow car and ends up behind b.)"""
    doc = slow_car_doc(tmp_path, "room", 'lcSpeedGain="0" lcKeepRight="0" lcCooperative="0" '
                       'sigma="0"', 20,
                       '<vehicle id="c" type="car" route="through" depart="0.5" departLane="1" '
                       'departPos="40" departSpeed="20"/>'
                       '<vehicle id="d" type="car" route="through" depart="0.5" departLane="2" '
                       'departPos="60" departSpeed="20"/>'
                       '<vehicle id="a" type="av" route="through" depart="0.5" departLane="0" '
                       'departPos="5" departSpeed="20"/>'
                       '<vehicle id="b" type="av" route="through" depart="0.5" departLane="1" '
                       'departPos="0" departSpeed="20"/>')
    result = simulate(scenario_from_dict(doc, path=tmp_path / "room.toml"))
    no_collision(result)
    traces = {vid: trace for vid, trace, _ in result.fleet.traces}
    a, b = traces["a"], traces["b"]
    assert changes(result)["vehicle_id"].tolist() == ["a"]
    assert a["lane"][-1] == 1 and a["s_m"][-1] > b["s_m"][-1] + 5.0  # in, ahead of b
    assert b["vx_mps"].min() < 17.0  # b fell back for it ...
    assert -np.diff(b["vx_mps"]).max() / 0.05 < 2.5  # ... braking about 2 m/s^2 at most
