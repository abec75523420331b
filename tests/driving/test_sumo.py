"""The SUMO-driven SV's policy (cosim.driving.sumo) on hand-made scenes, without SUMO:
scripted requests go to SUMO through the change_lane port, one a step; lane changes
are read off the path."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cosim.driving.base import DrivingContext, WorldPorts
from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig
from cosim.driving.sumo import SumoPolicy, excursions
from cosim.params import RoadParams
from cosim.scenario import LaneChangeCommand, Scenario, load_scenario, project_root
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import Scene, SVState

ROAD = RoadParams(mu=0.8)
CFG = DecisionConfig()
BASE = load_scenario(project_root() / "scenarios/paper_case1_overtaking.toml")
X0 = 200.0


def scenario(*requests: tuple[float, int]) -> Scenario:
    sv = replace(BASE.sv, lane_changes=tuple(LaneChangeCommand(at=a, target_lane=b)
                                             for a, b in requests), decision=False, lane=0)
    return replace(BASE, sv=sv, tvs=(), road=ROAD)


def scene_of(t: float, sv: SVState) -> Scene:
    none = np.zeros(0)
    snap = TrafficSnapshot(t, (), none, none, none, none, none, np.zeros(0, int), none, none,
                           none, np.zeros(0, int))
    return Scene(t, sv, snap, snap, np.zeros(0))


class Inbox:
    def read(self) -> list[object]:
        raise AssertionError("the SUMO-driven SV reads no message")


def test_the_sumo_policy_hands_scripted_requests_to_sumo_one_a_step() -> None:
    sc = scenario((0.0, 1), (0.0, 2), (5.0, 0))
    asked: list[int] = []
    pol = SumoPolicy(DrivingContext.of(sc, ROAD, decision=CFG,
                                       ports=WorldPorts(change_lane=asked.append)))
    sv = SVState(X0, ROAD.lane_center(0), 0.0, 20.0, 0.0, 0.0)
    assert pol.update(0.0, scene_of(0.0, sv), Inbox()) is None  # SUMO drives
    assert asked == [1]
    pol.update(0.05, scene_of(0.05, sv), Inbox())
    assert asked == [1, 2]  # the next due one, a step later
    pol.update(1.0, scene_of(1.0, sv), Inbox())
    assert asked == [1, 2]  # lane 0 at 5 s: not due yet (and already there then)
    assert [r["target_lane"] for r in pol.plans] == [1, 2] and pol.requests == 2
    assert not pol.status(sv).changing and not pol.status(sv).manoeuvring
    assert pol.status(replace(sv, vy=0.5)).manoeuvring  # moving sideways: changing lanes


def test_lane_changes_are_read_off_the_path() -> None:
    lanes = LaneLayout(ROAD)
    t = np.arange(0.0, 10.0, 0.5)
    y = np.full(t.size, lanes.centre(0))
    y[8:12] = np.linspace(lanes.centre(0), lanes.centre(1), 6)[1:5]  # on its way over
    y[12:] = lanes.centre(1)
    starts, targets, ends = excursions(t, y, lanes)
    assert starts == [t[7]] and targets == [lanes.centre(1)] and ends == [t[-1]]


def test_a_change_read_off_the_path_is_watched_until_the_next_one_starts() -> None:
    """Lane 0 -> 1 (settled at 4 s) -> 2 (from 6 s): the first change's window ends where
    the second starts, so it reads as settled and the run as completed (a window to the
    run's end read the first as never settled, the run as failed)."""
    from cosim.run.metrics import lane_change_durations

    lanes = LaneLayout(ROAD)
    t = np.arange(0.0, 12.0, 0.5)
    y = np.interp(t, [0.0, 1.0, 4.0, 6.0, 9.0],
                  [lanes.centre(0), lanes.centre(0), lanes.centre(1), lanes.centre(1),
                   lanes.centre(2)])
    starts, targets, ends = excursions(t, y, lanes)
    assert starts == [1.0, 6.0] and ends == [6.0, t[-1]]
    assert targets == [lanes.centre(1), lanes.centre(2)]
    durations = lane_change_durations(t, y, starts, targets, ends)
    assert durations.tolist() == [3.0, 3.0]
    assert excursions(t, np.full(t.size, lanes.centre(1)), lanes) == ([], [], [])
