"""Car following in the SV's lane (cosim.driving.following) on hand-made scenes: the
acceleration the reference asks for is rate-limited and within the road's grip, and
the lane-keeping reference runs along the lane centre near the car's speed."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cosim.driving.base import DrivingContext
from cosim.driving.following import (
    FOLLOW_GRIP,
    MAX_FOLLOW_JERK,
    REF_SPEED_BAND,
    CarFollowing,
)
from cosim.params import G, RoadParams
from cosim.scenario import load_scenario, project_root
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import Scene, SVState

ROAD = RoadParams(mu=0.5)
BASE = load_scenario(project_root() / "scenarios/paper_case1_overtaking.toml")


def following() -> CarFollowing:
    sc = replace(BASE, sv=replace(BASE.sv, decision=False, lane_changes=(), lane=0), tvs=())
    return CarFollowing(DrivingContext.of(sc, ROAD), DrivingContext.of(sc, ROAD).decision)


def scene(sv: SVState, leader_x: float, leader_speed: float) -> Scene:
    one = np.ones(1)
    snap = TrafficSnapshot(0.0, ("lead",), np.array([leader_x]),
                           np.array([ROAD.lane_center(0)]), np.zeros(1), leader_speed * one,
                           np.zeros(1), np.zeros(1, int), np.zeros(1), 4.32 * one, 1.8 * one,
                           np.zeros(1, int))
    return Scene(0.0, sv, snap, snap, leader_speed * one)


def test_a_standing_leader_close_ahead_brakes_within_grip_and_jerk() -> None:
    f = following()
    sv = SVState(0.0, ROAD.lane_center(0), 0.0, 25.0, 0.0, 0.0)
    accels, ramping = [], []
    for _ in range(40):
        f.update(sv, scene(sv, 30.0, 0.0), allow_change=False)
        accels.append(f.accel)
        ramping.append(f.ramping)
    steps = np.diff([0.0, *accels])
    assert np.all(np.abs(steps) <= MAX_FOLLOW_JERK * f.dt + 1e-12)  # rate-limited
    assert min(accels) == pytest.approx(-FOLLOW_GRIP * ROAD.mu * G)  # grip-limited
    # ramping (a cadence must not hold the decision) until the braking asked for is reached
    reached = int(np.argmax(np.isclose(accels, min(accels))))
    assert all(ramping[:reached]) and not any(ramping[reached:])
    assert f.leader_gap == pytest.approx(30.0 - 4.32)


def test_the_reference_runs_along_the_lane_centre_near_the_car_speed() -> None:
    f = following()
    f.v_ref = 40.0  # wound up far above the car
    sv = SVState(10.0, ROAD.lane_center(0) + 0.3, 0.0, 25.0, 0.0, 0.0)
    ref = f.reference(0.0, sv)
    assert ref.y0 == ROAD.lane_center(0) and ref.width == 0.0
    assert ref.vx0 == pytest.approx(25.0 + REF_SPEED_BAND)


def test_behind_a_standing_leader_within_the_standstill_gap_it_holds_at_zero() -> None:
    # the car creeps at 0.05 m/s, 1.9 m (bumper) behind a standing leader: the IDM's s0
    # is 2 m; the reference speed is held at 0 and asks no acceleration
    f = following()
    s0 = f.cfg.idm_min_gap
    sv = SVState(0.0, ROAD.lane_center(0), 0.0, 0.05, 0.0, 0.0)
    f.v_ref = 0.05
    f.update(sv, scene(sv, 4.32 + s0 - 0.1, 0.0), allow_change=False)
    assert f.holding()
    ref = f.reference(0.0, sv)
    assert ref.vx0 == 0.0 and f.v_ref == 0.0 and f.accel <= 0.0
    # the same gap behind a leader that drives off: no hold
    g = following()
    g.update(sv, scene(sv, 4.32 + s0 - 0.1, 1.0), allow_change=False)
    assert not g.holding()
    # nor 1 m beyond the standstill gap behind a standing one
    h = following()
    h.update(sv, scene(sv, 4.32 + s0 + 1.0, 0.0), allow_change=False)
    assert not h.holding()


def test_near_the_standstill_gap_it_brakes_to_rest_there_without_a_jump() -> None:
    # 0.41 m/s, 5.6 cm short of s0 behind a standing leader (scenarios/traffic_jam.toml):
    # the reference brakes to rest at s0 within HOLD_DECEL instead of dropping to 0 at
    # once (a 2.9 m/s^2 jump in ax)
    from cosim.driving.following import HOLD_DECEL

    f = following()
    s0 = f.cfg.idm_min_gap
    sv = SVState(0.0, ROAD.lane_center(0), 0.0, 0.41, 0.0, 0.0)
    f.v_ref = 0.41
    f.update(sv, scene(sv, 4.32 + s0 + 0.056, 0.0), allow_change=False)
    assert not f.holding()  # not yet within s0 ...
    ref = f.reference(0.0, sv)
    assert ref.vx0 == pytest.approx(0.41)  # ... so no step to 0
    # braking to stop at s0: v^2 / (2 room), about HOLD_DECEL where the hold begins
    assert f.accel == pytest.approx(-0.41 ** 2 / (2.0 * 0.056))
    assert -1.01 * HOLD_DECEL <= f.accel < -1.0
    assert 0.0 < f.v_ref < 0.41
    # farther back it is the IDM's business alone
    g = following()
    g.v_ref = 0.41
    g.update(sv, scene(sv, 4.32 + s0 + 1.0, 0.0), allow_change=False)
    before = g.accel
    g.reference(0.0, sv)
    assert g.accel == before
