"""The re-check's rules for a collision far ahead with a TV the SV closes on slowly or not
at all (cosim.driving.recheck.clear_ahead), braking or not, for one with a TV that only
signals a change into the lane SUMO's driver sees the SV in (`unseen_signal`), and the
replan's end speed behind a TV that cuts in ahead (`behind_speed`), on hand-made plans
and messages."""

from __future__ import annotations

from dataclasses import replace

from cosim.driving.layout import LaneLayout
from cosim.driving.recheck import (
    CLEAR_AHEAD,
    CLEAR_STOP_DECEL,
    SEEN_AHEAD,
    behind_speed,
    clear_ahead,
    stops_behind,
    unseen_signal,
)
from cosim.params import RoadParams
from cosim.planning.planner import Rejection
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.traffic.v2v import V2VMessage

L = 4.5
# a merge under way at 20 m/s, from t = 10 s over 4 s into y = 3.75 at the same speed
PLAN = LaneChangeTrajectory(t0=10.0, tau=4.0, x0=0.0, y0=0.0, vx0=20.0, vxf=20.0,
                            width=3.75)
# the SV's centre at t = 11 s is at x = 20; a TV 27 m ahead of it at 21 m/s, cruising
TV = V2VMessage(vehicle_id="tv1", t=11.0, x=47.0 + 0.5 * L, y=3.75, heading=0.0, speed=21.0,
                accel=0.0, lane=1, lateral_speed=0.0, length=L, width=1.8, intention=0)


def test_a_collision_far_ahead_with_a_tv_nobody_closes_on_keeps_the_plan() -> None:
    far = Rejection(4.0, "collision", "tv1", 11.0 + CLEAR_AHEAD + 0.5)
    assert clear_ahead(11.0, PLAN, far, [TV], L)
    # closing at 1 m/s on it: matched within the 21 m left at the plan's end at 0.02 m/s^2
    assert clear_ahead(11.0, PLAN, far, [replace(TV, speed=19.0)], L)


def test_a_near_closing_braking_or_unknown_tv_replaces_it() -> None:
    far = Rejection(4.0, "collision", "tv1", 11.0 + CLEAR_AHEAD + 0.5)
    soon = Rejection(4.0, "collision", "tv1", 11.0 + CLEAR_AHEAD - 0.5)
    assert not clear_ahead(11.0, PLAN, soon, [TV], L)  # too soon to leave it to chance
    assert not clear_ahead(11.0, PLAN, far, [replace(TV, speed=12.0)], L)  # closing fast
    assert not clear_ahead(11.0, PLAN, far, [replace(TV, accel=-2.0)], L)  # it brakes
    assert not clear_ahead(11.0, PLAN, far, [replace(TV, x=22.0)], L)  # beside the SV
    assert not clear_ahead(11.0, PLAN, far, [replace(TV, vehicle_id="tv2")], L)  # unseen
    faster = LaneChangeTrajectory(t0=10.0, tau=4.0, x0=0.0, y0=0.0, vx0=20.0, vxf=30.0,
                                  width=3.75)
    assert not clear_ahead(11.0, faster, far, [TV], L)  # the plan ends 9 m/s faster


def test_a_braking_tv_ahead_the_sv_can_stop_behind_keeps_the_gap_policys_plan() -> None:
    far = Rejection(4.0, "collision", "tv1", 11.0 + CLEAR_AHEAD + 0.5)
    soon = Rejection(4.0, "collision", "tv1", 11.0 + CLEAR_AHEAD - 0.5)
    braking = replace(TV, accel=-2.0)  # 22.5 m ahead (bumper), as fast as the SV
    assert clear_ahead(11.0, PLAN, far, [braking], L, CLEAR_STOP_DECEL, 0.1)
    assert not clear_ahead(11.0, PLAN, soon, [braking], L, CLEAR_STOP_DECEL, 0.1)
    # an emergency stop ahead (6 m/s^2): 33 m to a standstill against the SV's 69
    assert not clear_ahead(11.0, PLAN, far, [replace(TV, accel=-6.0)], L, CLEAR_STOP_DECEL,
                           0.1)
    # braking 2 m/s^2 only 4 m ahead, 5 m/s slower: the SV would close in on it
    assert not clear_ahead(11.0, PLAN, far, [replace(braking, x=28.5, speed=15.0)], L,
                           CLEAR_STOP_DECEL, 0.1)


def test_stopping_behind_a_braking_tv() -> None:
    assert stops_behind(12.0, 17.5, 17.4, 2.2, 3.0, 0.1)  # a leader's swing of -2.2 m/s^2
    assert not stops_behind(12.0, 17.5, 17.4, 5.0, 3.0, 0.1)  # one braking hard
    # the SV much faster: the gap closes before the TV's braking counts
    assert not stops_behind(20.0, 25.0, 15.0, 0.6, 3.0, 0.1)
    assert stops_behind(20.0, 15.0, 25.0, 0.6, 3.0, 0.1)


def test_a_replan_ends_behind_a_slower_tv_cutting_in_ahead() -> None:
    # a TV 22.5 m ahead (bumper) at 19 m/s, moving into the target lane
    cut_in = replace(TV, speed=19.0, y=1.875, lane=0, lateral_speed=1.25, intention=1)
    rejection = Rejection(3.0, "collision", "tv1", 14.0)
    assert behind_speed(20.0, 25.0, rejection, [cut_in], L) == 19.0
    assert behind_speed(20.0, 18.0, rejection, [cut_in], L) is None  # not slower
    assert behind_speed(45.0, 25.0, rejection, [cut_in], L) is None  # beside the SV
    assert behind_speed(20.0, 25.0, Rejection(3.0, "collision", "tv2", 14.0), [cut_in],
                        L) is None  # unseen


def test_a_tv_that_only_signals_into_the_lane_the_sv_is_seen_in_keeps_the_plan() -> None:
    lanes = LaneLayout(RoadParams())
    # a change from lane 0 (y 1.875) to lane 1 at 20 m/s from t = 10 s over 4 s; its
    # body (1.8 m wide) touches lane 1 at about 11.4 s
    plan = LaneChangeTrajectory(t0=10.0, tau=4.0, x0=0.0, y0=1.875, vx0=20.0, vxf=20.0,
                                width=3.75)
    # a slower TV ahead in lane 0 signalling left, not moving sideways yet
    tv = V2VMessage(vehicle_id="tv1", t=10.5, x=40.0, y=1.875, heading=0.0, speed=15.0,
                    accel=0.0, lane=0, lateral_speed=0.0, length=L, width=1.8, intention=1)
    late = Rejection(4.0, "collision", "tv1", 11.4 + SEEN_AHEAD + 0.2)
    early = Rejection(4.0, "collision", "tv1", 11.4 + SEEN_AHEAD - 0.3)
    assert unseen_signal(10.5, plan, late, [tv], lanes, 1, 1.8)
    assert not unseen_signal(10.5, plan, early, [tv], lanes, 1, 1.8)  # before it sees it
    assert not unseen_signal(10.5, plan, late, [replace(tv, intention=0)], lanes, 1, 1.8)
    assert not unseen_signal(10.5, plan, late, [replace(tv, intention=-1)], lanes, 1, 1.8)
    assert not unseen_signal(10.5, plan, late, [replace(tv, y=5.625)], lanes, 1, 1.8)
    assert not unseen_signal(10.5, plan, late, [tv], lanes, 2, 1.8)
