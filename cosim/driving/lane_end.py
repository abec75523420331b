"""The SV on a lane that ends (issue 24): the mandatory lane change and the stop
before the end, as every policy that flies planned manoeuvres uses them.

- `sv_lane_end`: the end of the SV's lane ahead, the lane to change into and the
  LC2013 look-ahead within which the change is due (cosim.planning.deadline). Once
  due, the policy asks for that change with trigger "mandatory" (plans.csv), before
  any scripted request or lane the speed-band rule wants; it may ask from any speed, a
  standstill too (the plan starts at CREEP_SPEED at least, the planner needs a positive
  speed).
- The deadline: the manoeuvre (cosim.driving.manoeuvre) plans only changes that end
  with the SV's front `deadline.END_MARGIN` before the end (`LaneEnd.x_limit`); when
  none at the wanted end speed does, it tries the end speeds at which a change of
  each of MERGE_TAUS fits in the room left (`deadline.fit_speed`): from a standstill
  at the stop line it merges at the speed that room allows. A mandatory plan's path
  bends at most MERGE_CURVATURE (the planner's `max_curvature`).
- The stop before the end: while the SV keeps an ending lane it follows a virtual
  standing leader whose rear is WAIT_ROOM before the end (`stop_gap`, `stop_accel`:
  Krauss's safe speed towards it with STOP_DECEL and STOP_TAU, so that it brakes only
  once it must), stops there behind it at its standstill gap (the car
  following's hold) and waits for a gap: the change is planned again every
  `retry_interval` and from a standstill.
- Letting merging traffic in (the gap policy): a TV ahead of the SV that must merge
  into its lane from a lane that ends is followed as if it were already its leader
  while that asks no more than YIELD_DECEL of the SV (`yield_accel`), as SUMO's
  cooperative followers make room for a strategic changer (LC2013's
  `informFollower`, within their decel); one too close to let in comfortably merges
  behind it.
"""

from __future__ import annotations

import math

import numpy as np

from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, idm_acceleration
from cosim.driving.view import TrafficView
from cosim.planning.deadline import LaneEnd, continuing_lane, lane_end, look_ahead
from cosim.planning.interaction import FollowerModel, krauss_safe_speed

WAIT_ROOM = 45.0  # m, the virtual standing leader's rear this far before the lane's end:
# the room a merge from a standstill starts with: within MERGE_CURVATURE a change from
# 1 m/s ends at up to 13 m/s in it (7 s); with 20 m, at 3 m/s (10 s), too slow to be let
# into traffic at 20 m/s (a whole-loop run at 25 veh/km/lane waited 40 s)
STOP_DECEL = 3.5  # m/s^2, the braking the stop law plans with, and ...
STOP_TAU = 0.5  # s, ... its reaction time: it brakes only once it must, so that the SV
# keeps the mainline's speed along the acceleration lane while it seeks a gap (with the
# IDM's comfortable 2 m/s^2 and SUMO's tau 1 s it braked from the lane's start, at 70 km/h
# 165 m before the end of a 194.5 m lane, fell below the mainline's speed before a gap
# came and stopped: 1 of 5 sample merges at 40 veh/km/lane)
STOP_TIME = 0.5  # s, time constant of the speed towards the stop law's safe speed
MERGE_TAUS = (4.0, 7.0, 10.0)  # s, the durations the end-speed caps assume (`fit_speed`):
# from the stop line (47 m of room) a 4 s change ends at ~23 m/s, a 7 s one at ~13 m/s
# (the first a car can steer from a standstill: MERGE_CURVATURE), a 10 s one at ~8 m/s
MERGE_CURVATURE = 0.2  # 1/m, the sharpest path a mandatory plan may take (R 5 m; the
# plant's 0.6 rad road-wheel limit on its 2.51 m wheelbase allows 0.27): from 1 m/s a
# 4 s change to 9 m/s bends at 0.56 1/m, the envelope's yaw-rate bound allows it
CREEP_SPEED = 1.0  # m/s, a mandatory change starts at least at this speed
MERGE_INSIST_DECEL = 4.5  # m/s^2, the most a mandatory change may ask of its new follower
# (the urgency law's top, cosim.driving.gap.decision.mandatory_config): the Krauss
# follower's decel, what LC2013 asks of a blocking follower; a Krauss follower either
# keeps its speed or drops what it must in one step, at its decel (its predicted braking
# is ~0 or 4.5), so GapConfig.insist_decel's 4.0 let no blocked merge go (issue 24)
MERGE_APPROACH_DECEL = 2.0  # m/s^2, the hardest a mandatory change brakes toward a gap
# (GapConfig.approach_decel, 3 for a change by choice): on an acceleration lane braking
# for a slower gap loses the speed the merge needs, and the stop law brakes for the end
# (merge study, 20 seeds: 17 of 20 merges at 50 veh/km/lane with 3, 20 of 20 with 2)
YIELD_DECEL = 2.0  # m/s^2, the most the gap policy's SV brakes to let a merging TV in
# (the IDM's comfortable b)


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


def merging_ahead(lanes: LaneLayout, lane: int, sv_x: float, sv_length: float,
                  traffic: TrafficView) -> tuple[int, float]:
    """(index, bumper gap m) of the nearest TV ahead of the SV's front that must merge
    into the SV's `lane` from a neighbouring lane that ends (its change due: within its
    LC2013 look-ahead, cosim.planning.deadline), or (-1, inf). Arrays over TVs."""
    n = lanes.n_lanes
    ends = np.array([lanes.end(k) for k in range(n)], dtype=float)
    x = np.asarray(traffic.x, dtype=float)
    if not np.isfinite(ends).any() or x.size == 0:
        return -1, math.inf
    target = np.full(n, -1)
    crossings = np.ones(n)
    for k in range(n):  # lanes, not vehicles
        nxt = continuing_lane(ends, k)
        if nxt is not None:
            target[k], crossings[k] = nxt
    length = np.asarray(traffic.length, dtype=float)
    lo, _ = lanes.lanes_touched(traffic.y, np.zeros(x.size))
    tv_lane = np.clip(lo, 0, n - 1).astype(int)
    remaining = ends[tv_lane] - (x + 0.5 * length)
    horizon = look_ahead(traffic.speed, length, lane > tv_lane, crossings[tv_lane])
    gap = x - 0.5 * length - (sv_x + 0.5 * sv_length)
    merging = ((target[tv_lane] == lane) & (tv_lane != lane) & (remaining > 0.0)
               & (remaining <= horizon) & (gap > 0.0))
    if not merging.any():
        return -1, math.inf
    k = int(np.argmin(np.where(merging, gap, np.inf)))
    return k, float(gap[k])


def yield_accel(speed: float, desired_speed: float, lanes: LaneLayout, lane: int,
                sv_x: float, sv_length: float, traffic: TrafficView,
                cfg: DecisionConfig) -> float:
    """m/s^2, the courtesy of the SV to a TV that must merge into its lane ahead of it
    (`merging_ahead`): its car following's acceleration behind that TV as if it were
    already its leader, when that asks no more braking than YIELD_DECEL (LC2013's
    cooperative follower helps only within its decel); inf: nobody to let in, or too
    late to let it in comfortably (it merges behind the SV)."""
    k, gap = merging_ahead(lanes, lane, sv_x, sv_length, traffic)
    if k < 0:
        return math.inf
    a = idm_acceleration(speed, desired_speed, gap, float(traffic.speed[k]), cfg)
    return a if a >= -YIELD_DECEL else math.inf
