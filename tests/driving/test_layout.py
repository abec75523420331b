"""The lanes as the driving layer asks for them (cosim.driving.layout.LaneLayout): lane
membership, centres, which lanes a body touches, the nearest TVs along a lane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.driving.layout import LaneLayout
from cosim.driving.view import TrafficView
from cosim.params import RoadParams

ROAD = RoadParams()
LANES = LaneLayout(ROAD)
L, W = 4.32, 1.8


def lane_y(k: int) -> float:
    return LANES.centre(k)


def test_lane_of_and_centre_agree_and_clip_to_the_road() -> None:
    assert LANES.n_lanes == 3
    for k in range(LANES.n_lanes):
        assert LANES.lane_of(LANES.centre(k)) == k
        assert LANES.lane_of(LANES.centre(k) + 0.49 * ROAD.lane_width) == k
    assert LANES.lane_of(-5.0) == 0 and LANES.lane_of(100.0) == 2
    assert LANES.centre(1) - LANES.centre(0) == pytest.approx(ROAD.lane_width)


def test_a_body_on_a_lane_line_touches_both_lanes() -> None:
    line = ROAD.y_right + ROAD.lane_width
    lo, hi = LANES.lanes_touched([line, lane_y(0)], [W / 2, W / 2])
    assert (lo[0], hi[0]) == (0, 1) and (lo[1], hi[1]) == (0, 0)


def test_speed_limit_and_end_speed_come_from_the_bands() -> None:
    assert LANES.speed_limit(2) == ROAD.speed_bands[2][1]
    assert LANES.end_speed(0, 1) == ROAD.speed_bands[1][0]  # to a faster lane: its minimum
    assert LANES.end_speed(1, 0) == ROAD.speed_bands[0][1]  # to a slower one: its maximum


def test_neighbours_finds_nearest_leader_and_follower() -> None:
    x = np.array([50.0, 20.0, -10.0, -40.0, 5.0])
    y = np.array([lane_y(0), lane_y(0), lane_y(0), lane_y(0), lane_y(1)])
    v = np.array([10.0, 11.0, 12.0, 13.0, 14.0])
    n = LANES.neighbours(0, 0.0, L, TrafficView.arrays(x, y, v, np.full(5, L), np.full(5, W)))
    assert (n.leader, n.follower) == (1, 2)
    assert n.gap_ahead == pytest.approx(20.0 - L)
    assert n.follower_speed == 12.0
    empty = LANES.neighbours(2, 0.0, L, TrafficView.arrays(x, y, v, np.full(5, L), np.full(5, W)))
    assert empty.leader == -1 and math.isinf(empty.gap_ahead)


def test_a_tv_leaving_the_lane_is_no_longer_the_leader() -> None:
    """Half across the line into lane 1 and moving left: not lane 0's leader any more;
    moving right (coming in), or still centred in lane 0, it is."""
    y = np.array([ROAD.y_right + ROAD.lane_width + 0.3])  # centre just inside lane 1
    def tv(vy: float | None) -> TrafficView:
        return TrafficView.arrays([12.0], y, [20.0], [L], [W],
                                  None if vy is None else [vy])

    # without lateral speeds it touches lane 0
    assert LANES.neighbours(0, 0.0, L, tv(None), leaving=True).leader == 0
    assert LANES.neighbours(0, 0.0, L, tv(1.0), leaving=True).leader == -1  # leaving
    assert LANES.neighbours(0, 0.0, L, tv(-1.0), leaving=True).leader == 0  # cutting in
    assert LANES.neighbours(1, 0.0, L, tv(1.0), leaving=True).leader == 0  # its new lane
    assert LANES.neighbours(0, 0.0, L, tv(1.0)).leader == 0  # lateral speed not asked
