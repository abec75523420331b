"""The stop rules (cosim.run.stop) on hand-made SV states, without SUMO: the first
collision onset, and our SV at the end of a lane that ends."""

from __future__ import annotations

import math

from cosim.params import RoadParams
from cosim.run.stop import StopRules
from cosim.traffic.world import SVState

ROAD = RoadParams()
L = 4.32  # m, the SV's length
Y0 = ROAD.lane_center(0)


def test_our_sv_at_the_end_of_a_lane_that_ends_stops_the_run() -> None:
    """Lane 0 ends at s = 194.5 m (y_right -3.75: an acceleration lane); the row whose
    next step would take the SV's front past it is the run's last (lane_end_reached);
    in a lane that runs on, or short of the end, nothing happens."""
    road = RoadParams(speed_bands=((15.0, 25.0),) * 4, y_right=-3.75,
                      lane_ends=(194.5, math.inf, math.inf, math.inf))
    stop = StopRules(road, 4.32, 0.05, 100, on_collision=True, at_lane_ends=True)
    assert not stop.stops(10, SVState(190.0, -1.875, 0.0, 20.0, 0.0, 0), None)
    assert not stop.stops(11, SVState(400.0, 1.875, 0.0, 20.0, 0.0, 1), None)
    assert stop.stops(12, SVState(191.5, -1.875, 0.0, 20.0, 0.0, 0), None)
    assert stop.at_lane_end and stop.last_row == 12
    assert not stop.stops(13, SVState(192.0, -1.875, 0.0, 20.0, 0.0, 0), None)
    # the SUMO-driven SV stops there by itself: no rule for it
    sumo_driven = StopRules(road, 4.32, 0.05, 100, on_collision=True, at_lane_ends=False)
    assert not sumo_driven.stops(12, SVState(191.5, -1.875, 0.0, 20.0, 0.0, 0), None)


def test_the_first_collision_onset_stops_the_run_only_when_asked() -> None:
    """on_collision "stop": the row holding the first collision onset is the run's last
    (stopped_by_collision); otherwise the run drives on."""
    sv = SVState(100.0, Y0, 0.0, 20.0, 0.0, 0)
    onset = (1.5, "a")
    going_on = StopRules(ROAD, L, 0.05, 100, on_collision=False, at_lane_ends=True)
    assert not going_on.stops(30, sv, onset) and going_on.last_row == 100
    stop = StopRules(ROAD, L, 0.05, 100, on_collision=True, at_lane_ends=True)
    assert not stop.stops(29, sv, None)
    assert stop.stops(30, sv, onset)
    assert stop.by_collision and stop.last_row == 30
