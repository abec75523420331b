"""The SV on a lane that ends (issue 24): the mandatory lane change and the stop
before the end, as every policy that flies planned manoeuvres uses them.

- `sv_lane_end`: the end of the SV's lane ahead, the lane to change into and the
  LC2013 look-ahead within which the change is due (cosim.planning.deadline). Once
  due, the policy asks for that change with trigger "mandatory" (plans.csv), before
  any scripted request or lane the speed-band rule wants; it may ask from a standstill
  (`MERGE_MIN_SPEED`: the plan starts at CREEP_SPEED at least, the planner needs a
  positive speed).
- The deadline: the manoeuvre (cosim.driving.manoeuvre) plans only changes that end
  with the SV's front `deadline.END_MARGIN` before the end (`LaneEnd.x_limit`), and
  caps the end speed so that a change of MERGE_TAU fits in the room left
  (`deadline.fit_speed`): from a standstill at the stop line it merges at the speed
  that room allows.
- The stop before the end: while the SV keeps an ending lane it follows a virtual
  standing leader whose rear is WAIT_ROOM before the end (`stop_gap`, `stop_accel`:
  Krauss's safe speed towards it with STOP_DECEL, a comfortable braking, so that it
  brakes only once it must), stops there behind it at its standstill gap (the car
  following's hold) and waits for a gap: the change is planned again every
  `retry_interval` and from a standstill.
"""

from __future__ import annotations

import math

from cosim.driving.lanes import LaneLayout
from cosim.planning.deadline import LaneEnd, lane_end
from cosim.planning.interaction import FollowerModel, krauss_safe_speed

WAIT_ROOM = 20.0  # m, the virtual standing leader's rear this far before the lane's end:
# the room a merge from a standstill starts with (a change of MERGE_TAU ends at up to
# ~9 m/s in it)
STOP_DECEL = 2.0  # m/s^2, the braking the stop law plans with (the IDM's comfortable b)
STOP_TAU = 1.0  # s, its reaction time (SUMO's tau)
STOP_TIME = 0.5  # s, time constant of the speed towards the stop law's safe speed
MERGE_TAU = 4.0  # s, the manoeuvre's duration the end-speed cap assumes (`fit_speed`)
MERGE_MIN_SPEED = 0.0  # m/s, a mandatory change is asked for from this speed up
CREEP_SPEED = 1.0  # m/s, a mandatory change starts at least at this speed


def sv_lane_end(lanes: LaneLayout, lane: int, x: float, speed: float,
                length: float) -> LaneEnd | None:
    """The end of the SV's `lane` ahead (centre x, m; speed, m/s), None when it runs on."""
    ends = [lanes.end(k) for k in range(lanes.n_lanes)]
    if not any(math.isfinite(e) for e in ends):
        return None
    return lane_end(ends, lane, x, speed, length)


def stop_gap(end: LaneEnd | None) -> float:
    """m, bumper gap from the SV's front to the virtual standing leader WAIT_ROOM before
    the lane's end (inf: no end)."""
    return math.inf if end is None else end.remaining - WAIT_ROOM


def stop_accel(speed: float, gap: float, min_gap: float) -> float:
    """m/s^2, the stop law: towards Krauss's safe speed behind a standing leader at
    bumper gap `gap` (m), stopping `min_gap` (m) behind it (inf gap: no limit)."""
    if not math.isfinite(gap):
        return math.inf
    model = FollowerModel(decel=STOP_DECEL, tau=STOP_TAU, min_gap=min_gap)
    v_safe = float(krauss_safe_speed(gap, 0.0, model))
    return (v_safe - max(speed, 0.0)) / STOP_TIME
