"""The paper's trigger and IDM car-following (cosim.driving.rule) on hand-made scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, decide, idm_acceleration
from cosim.driving.view import SVView, TrafficView
from cosim.params import RoadParams

ROAD = RoadParams()
LANES = LaneLayout(ROAD)
CFG = DecisionConfig()
L, W = 4.32, 1.8


def lane_y(k: int) -> float:
    return ROAD.lane_center(k)


def run_decide(tvs: list[tuple[float, int | float, float]], *, sv_lane: int = 0,
               sv_speed: float = 22.0, desired: float = 25.0, allow: bool = True):
    x = np.array([tv[0] for tv in tvs], dtype=float)
    y = np.array([lane_y(tv[1]) if isinstance(tv[1], int) else tv[1] for tv in tvs])
    v = np.array([tv[2] for tv in tvs], dtype=float)
    n = len(tvs)
    return decide(SVView(0.0, lane_y(sv_lane), sv_speed, L, desired),
                  TrafficView.arrays(x, y, v, np.full(n, L), np.full(n, W)), LANES, CFG,
                  allow_change=allow)


def test_slow_leader_and_empty_left_lane_requests_the_left_lane() -> None:
    d = run_decide([(25.0, 0, 70 / 3.6)])
    assert d.target_lane == 1
    assert d.leader_gap == pytest.approx(25.0 - L)


def test_leader_at_the_desired_speed_keeps_the_lane() -> None:
    d = run_decide([(25.0, 0, 25.0)])
    assert d.target_lane is None and d.reason == "keep lane"


def test_far_leader_does_not_trigger_a_change() -> None:
    d = run_decide([(CFG.look_ahead + 20.0, 0, 15.0)])
    assert d.target_lane is None


def test_occupied_left_lane_blocks_the_change_and_the_sv_follows() -> None:
    # a car in lane 1 right beside the SV
    d = run_decide([(25.0, 0, 70 / 3.6), (2.0, 1, 27.0)])
    assert d.target_lane is None
    assert d.reason == "slow leader, no free faster lane"
    # following: slower leader close ahead -> brake
    assert d.accel < 0.0


def test_fast_follower_close_behind_in_the_target_lane_blocks_the_change() -> None:
    d = run_decide([(25.0, 0, 70 / 3.6), (-20.0, 1, 33.0)])
    assert d.target_lane is None
    d = run_decide([(25.0, 0, 70 / 3.6), (-80.0, 1, 27.0)])
    assert d.target_lane == 1


def test_target_lane_must_be_faster_than_the_current_leader() -> None:
    # lane 1 has a leader just as slow as ours: no gain, no change (lane -1 does not exist)
    d = run_decide([(25.0, 0, 70 / 3.6), (40.0, 1, 70 / 3.6)])
    assert d.target_lane is None


def test_right_lane_is_used_when_the_left_is_blocked() -> None:
    d = run_decide([(25.0, 1, 15.0), (0.0, 2, 30.0)], sv_lane=1, sv_speed=25.0, desired=28.0)
    assert d.target_lane == 0


def test_a_tv_between_lanes_blocks_both() -> None:
    between = ROAD.y_right + ROAD.lane_width  # on the line between lanes 0 and 1
    lo, hi = LANES.lanes_touched([between], [W / 2])
    assert (lo[0], hi[0]) == (0, 1)
    d = run_decide([(25.0, 0, 70 / 3.6), (3.0, between, 25.0)])
    assert d.target_lane is None


def test_no_change_while_not_allowed() -> None:
    d = run_decide([(25.0, 0, 70 / 3.6)], allow=False)
    assert d.target_lane is None and d.reason == "slow leader, waiting"


def test_idm_free_road_accelerates_below_and_stops_at_desired_speed() -> None:
    assert idm_acceleration(20.0, 25.0, math.inf, math.nan, CFG) > 0.5
    assert idm_acceleration(25.0, 25.0, math.inf, math.nan, CFG) == pytest.approx(0.0)
    assert idm_acceleration(30.0, 25.0, math.inf, math.nan, CFG) < 0.0


def test_idm_brakes_hard_but_bounded_for_a_close_stopped_leader() -> None:
    a = idm_acceleration(25.0, 25.0, 5.0, 0.0, CFG)
    assert a == pytest.approx(-CFG.max_brake)


def test_idm_following_converges_to_a_safe_gap() -> None:
    """Integrate IDM behind a leader at 20 m/s: the follower settles at its speed
    with at least s0 + v T of gap and never touches it."""
    dt, x_l, v_l, x, v = 0.05, 30.0, 20.0, 0.0, 28.0
    gaps = []
    for _ in range(int(120 / dt)):
        gap = x_l - x - L
        a = idm_acceleration(v, 30.0, gap, v_l, CFG)
        v = max(v + a * dt, 0.0)
        x += v * dt
        x_l += v_l * dt
        gaps.append(gap)
    assert min(gaps) > 0.0
    assert v == pytest.approx(v_l, abs=0.05)
    assert gaps[-1] >= CFG.idm_min_gap + v_l * CFG.idm_time_gap
