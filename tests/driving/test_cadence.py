"""When a policy keeping its lane decides again (cosim.driving.cadence): at its interval,
or at once on a new neighbour, a leader that changes speed, a gap that closes unpredicted."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cosim.driving.base import DrivingContext
from cosim.driving.cadence import Cadence, CadenceConfig
from cosim.driving.gap.policy import GapPolicy
from cosim.driving.layout import Neighbours
from cosim.params import RoadParams
from cosim.scenario import load_scenario, project_root
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import Scene, SVState

IDS = ("a", "b", "c")


def own(leader: int = 0, gap: float = 30.0, leader_speed: float = 25.0,
        follower: int = 1) -> Neighbours:
    return Neighbours(lane=1, leader=leader, gap_ahead=gap if leader >= 0 else math.inf,
                      leader_speed=leader_speed if leader >= 0 else math.nan,
                      follower=follower, gap_behind=20.0, follower_speed=25.0)


def decided_at_zero() -> Cadence:
    c = Cadence(CadenceConfig(interval=0.5))
    assert c.due(0.0, own(), IDS)  # never decided: due
    c.decided(0.0, 24.0, own(), IDS)
    return c


def test_nothing_changes_it_waits_for_its_interval() -> None:
    c = decided_at_zero()
    # the leader 1 m/s faster: the gap opens 1 m/s as predicted
    assert not any(c.due(t, own(gap=30.0 + t), IDS) for t in (0.05, 0.2, 0.45))
    assert c.due(0.5, own(gap=30.5), IDS)


def test_a_new_leader_or_follower_decides_at_once() -> None:
    c = decided_at_zero()
    assert c.due(0.05, own(leader=2), IDS)  # one cut in
    assert c.due(0.05, own(leader=-1), IDS)  # the leader left
    assert c.due(0.05, own(follower=2), IDS)
    assert c.due(0.05, own(follower=-1), IDS)


def test_a_braking_leader_or_an_unpredicted_gap_decides_at_once() -> None:
    c = decided_at_zero()
    assert not c.due(0.1, own(gap=30.1, leader_speed=24.6), IDS)  # within 0.5 m/s
    assert c.due(0.1, own(gap=30.1, leader_speed=24.4), IDS)
    assert c.due(0.1, own(gap=28.9), IDS)  # 1.2 m short of the prediction (30.1)


def test_without_a_leader_only_the_interval_and_new_neighbours_count() -> None:
    c = Cadence(CadenceConfig(interval=0.5))
    c.decided(0.0, 24.0, own(leader=-1), IDS)
    assert not c.due(0.4, own(leader=-1), IDS)
    assert c.due(0.4, own(leader=0), IDS)


def test_a_gap_policy_with_a_cadence_holds_its_decision_between_events() -> None:
    """Behind a leader in its lane (hand-made scenes, no SUMO): decided at t = 0, held
    (a lane-keeping reference, no decision) until the leader brakes; without a cadence
    (the SV) it never holds."""
    road, v = RoadParams(mu=0.8), 25.0
    base = load_scenario(project_root() / "scenarios/paper_case1_overtaking.toml")
    sc = replace(base, sv=replace(base.sv, lane_changes=(), decision=False, lane=0,
                                  speed=v, desired_speed=v), tvs=(), road=road)

    def scene(t: float, leader_speed: float) -> Scene:
        x, one = np.array([40.0 + v * t]), np.ones(1)
        snap = TrafficSnapshot(t, ("lead",), x, one * road.lane_center(0), 0 * one,
                               one * leader_speed, 0 * one, np.zeros(1, int), 0 * one,
                               one * 4.32, one * 1.8, np.zeros(1, int))
        sv = SVState(v * t, road.lane_center(0), 0.0, v, 0.0, 0.0)
        return Scene(t, sv, snap, snap, snap.speed)

    sv_policy = GapPolicy(DrivingContext.of(sc, road))
    assert sv_policy.hold(0.05, scene(0.05, v)) is None
    policy = GapPolicy(DrivingContext.of(sc, road, cadence=CadenceConfig(interval=0.5)))
    assert policy.hold(0.0, scene(0.0, v)) is None  # never decided
    policy.update(0.0, scene(0.0, v), None)  # type: ignore[arg-type]
    held = [policy.hold(t, scene(t, v)) for t in (0.05, 0.1, 0.15)]
    assert all(r is not None and r.width == 0.0 for r in held)  # lane keeping
    assert held[1].t0 == 0.1 and held[1].y0 == road.lane_center(0)  # type: ignore[union-attr]
    assert policy.hold(0.2, scene(0.2, v - 1.0)) is None  # the leader braked: decide
    assert policy.hold(0.5, scene(0.5, v)) is None  # its interval
