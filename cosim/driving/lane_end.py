"""The SV on a lane that ends: the one place its policies and its manoeuvre ask about
the end of a lane (`SVLaneEnds`, one per SV), and the laws they follow there. The
geometry of lanes that end (which lane continues, the LC2013 look-ahead, the deadline
of a manoeuvre) is cosim.planning.deadline's.

- Where and when (`SVLaneEnds.ahead`, `SVLaneEnds.due`): the end of the SV's lane
  ahead (a `LaneEnd`), the lane to change into and the look-ahead within which the
  change is due. Once due it stays due while the SV is on that lane, its look-ahead the
  longest it had: slowing down, or standing at the stop line, must not call the change
  off nor make it less urgent (LC2013's look-ahead speed decays slowly for the same
  reason). The policy then asks for that change with trigger "mandatory" (plans.csv)
  before any scripted request or lane its decision rule wants, from any speed; the
  decision rule never changes into a lane that ends within the look-ahead
  (`SVLaneEnds.ends_soon`).
- The plan out of it (`SVLaneEnds.limits`): every plan out of an ending lane ends with
  the SV's front `deadline.END_MARGIN` before the end (`LaneEnd.x_limit`, the
  planner's `x_limit`), a replan of the change under way too. A mandatory change
  starts at CREEP_SPEED at least (the planner needs a positive speed), its path bends
  at most MERGE_CURVATURE (the planner's `max_curvature`), and when no plan at the
  wanted end speed ends in time it tries the end speeds at which a change of each of
  MERGE_TAUS fits in the room left (`deadline.fit_speed`), none slower than the SV: a
  change that brakes hard into the target lane surprises its new follower; the stop
  law slows the SV instead and it asks again. Its end speed is also no more than the
  SV reaches with a comfortable acceleration (`comfortable_speed`: MERGE_ACCEL at the
  plan's peak over the policy's merge duration) and its plan accelerates no harder
  (the planner's `max_accel`): from a slow start (a ramp's corners, the stop line) a
  driver merges at the speed it has reached and speeds up in the lane after (the car
  following), it does not floor it to the lane's speed within the change.
- The stop before the end: while the SV keeps an ending lane it follows a virtual
  standing leader whose rear is WAIT_ROOM before the end (`stop_gap`, `stop_accel`:
  Krauss's safe speed towards it with STOP_DECEL and STOP_TAU, so that it brakes only
  once it must), stops there behind it at its standstill gap (the car following's
  hold) and waits for a gap: the change is planned again every `retry_interval` and
  from a standstill. A re-check that finds no replan out of a lane whose change has
  been due does not abort back into it (`SVLaneEnds.was_due`; the abort's plan would
  carry the SV on at the band's speed): it brakes to a stop before the stop line
  (cosim.driving.brake).
- Letting merging traffic in (the gap policy, `SVLaneEnds.yield_accel`): a TV ahead of
  the SV that must merge into its lane from a lane that ends is followed as if it were
  already its leader while that asks no more than YIELD_DECEL of the SV, as SUMO's
  cooperative followers make room for a strategic changer (LC2013's `informFollower`,
  within their decel); one too close to let in comfortably merges behind it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, idm_acceleration
from cosim.driving.view import TrafficView
from cosim.planning.deadline import (
    EndPhases,
    LaneEnd,
    end_ahead,
    ends_ahead,
    fit_speed,
    look_ahead,
)
from cosim.planning.interaction import FollowerModel, krauss_safe_speed

if TYPE_CHECKING:
    from cosim.traffic.world import SVState

WAIT_ROOM = 45.0  # m, the virtual standing leader's rear this far before the lane's end:
# the room a merge from a standstill starts with; within MERGE_CURVATURE a change from
# 1 m/s ends at up to 13 m/s in it (7 s), fast enough to be let into the mainline
# tuned: docs/tuned_constants.md
STOP_DECEL = 3.5  # m/s^2, the braking the stop law plans with, and ...
STOP_TAU = 0.5  # s, ... its reaction time: it brakes only once it must, so that the SV
# keeps the mainline's speed along the acceleration lane while it seeks a gap
# tuned: docs/tuned_constants.md
STOP_TIME = 0.5  # s, time constant of the speed towards the stop law's safe speed
MERGE_TAUS = (4.0, 7.0, 10.0)  # s, the durations the end-speed caps assume (`fit_speed`):
# from the stop line (47 m of room) a 4 s change ends at ~23 m/s, a 7 s one at ~13 m/s
# (the first a car can steer from a standstill: MERGE_CURVATURE), a 10 s one at ~8 m/s
MERGE_CURVATURE = 0.2  # 1/m, the sharpest path a mandatory plan may take (R 5 m; the
# plant's 0.6 rad road-wheel limit on its 2.51 m wheelbase allows 0.27): from 1 m/s a
# 4 s change to 9 m/s bends at 0.56 1/m, the envelope's yaw-rate bound allows it
CREEP_SPEED = 1.0  # m/s, a mandatory change starts at least at this speed
MERGE_ACCEL = 2.6  # m/s^2, the mean acceleration of a mandatory change's plan at most
# (its peak 1.5 times that, eq. 2): SUMO's passenger car's accel, what the ramp's own
# drivers merge with (Krauss speeds up at its accel): the SV keeps up with the TVs
# behind it on the ramp, which merge too; from 23 km/h a 4 s merge ends at 60 km/h
MERGE_PEAK_ACCEL = 1.5 * MERGE_ACCEL  # m/s^2, that plan's peak (eq. 2)
MERGE_INSIST_DECEL = 4.5  # m/s^2, the most a mandatory change may ask of its new follower
# (the urgency law's top, cosim.driving.gap.decision.mandatory_config): the Krauss
# follower's decel, what LC2013 asks of a blocking follower. A Krauss follower either
# keeps its speed or drops what it must in one step at its decel (its predicted braking
# is ~0 or 4.5), so a limit below its decel lets no blocked merge go
# tuned: docs/tuned_constants.md
MERGE_APPROACH_DECEL = 2.0  # m/s^2, the hardest a mandatory change brakes toward a gap
# (GapConfig.approach_decel, 3 for a change by choice): on an acceleration lane braking
# for a slower gap loses the speed the merge needs, and the stop law brakes for the end
# tuned: docs/tuned_constants.md
YIELD_DECEL = 2.0  # m/s^2, the most the gap policy's SV brakes to let a merging TV in
# (the IDM's comfortable b)


@dataclass(frozen=True)
class PlanLimits:
    """What the end of the SV's lane asks of a plan out of it (`SVLaneEnds.limits`)."""

    vx0: float  # m/s, the plan's start speed
    vxf: float | None  # m/s, its end speed (None: the band rule's)
    x_limit: float = math.inf  # m, the latest centre x at its end (inf: no end ahead)
    curvature: float = math.inf  # 1/m, the sharpest path it may take
    slower: tuple[float, ...] = ()  # m/s, the end speeds tried next, in order, when no
    # plan at vxf ends in time
    accel: float = math.inf  # m/s^2, the plan's peak acceleration at most


class SVLaneEnds:
    """The SV's lane-end reasoning (module docstring) on the lanes `lanes`, for an SV of
    `sv_length` (m). It remembers the lane whose mandatory change became due."""

    def __init__(self, lanes: LaneLayout, sv_length: float) -> None:
        self.lanes = lanes
        self.sv_length = sv_length
        self.end_s = tuple(lanes.end_s(k) for k in range(lanes.n_lanes))  # m, per lane
        self.any = any(math.isfinite(e) for e in self.end_s)  # a lane ends on this road
        self.begin_s = tuple(lanes.begin_s(k) for k in range(lanes.n_lanes))  # m, per lane
        # a lane in two (begins after its end: RoadParams.lane_begins) ends nowhere past
        # its first part's end
        self.split = any(b > e for b, e in zip(self.begin_s, self.end_s, strict=True))
        self.due_lane = -1  # the lane whose mandatory change became due (-1: none)
        self.due_horizon = 0.0  # m, the longest look-ahead since

    def ahead(self, lane: int, x: float, speed: float) -> LaneEnd | None:
        """The end of `lane` ahead of the SV at centre x (m) and speed (m/s), or None
        when the lane runs on."""
        if not self.any:
            return None
        ends = ends_ahead(self.end_s, self.begin_s, x) if self.split else self.end_s
        return end_ahead(ends, lane, x, speed, self.sv_length)

    def due(self, lane: int, sv: SVState) -> LaneEnd | None:
        """The end of the SV's `lane` once the mandatory change is due, else None; once
        due it stays due on that lane, its look-ahead the longest it had."""
        end = self.ahead(lane, sv.x, sv.vx)
        if end is None or not self.begun(end.target, sv.x):
            return None
        if self.due_lane != lane:
            self.due_horizon = 0.0
        if end.due:
            self.due_lane = lane
        if self.due_lane != lane:
            return None
        self.due_horizon = max(self.due_horizon, end.horizon)
        return replace(end, horizon=self.due_horizon)

    def was_due(self, lane: int, end: LaneEnd | None) -> bool:
        """`lane`, ending at `end`, is one the SV must leave: its change is due, or has
        been (no abort back into it)."""
        return end is not None and (end.due or self.due_lane == lane)

    def ends_soon(self, lane: int, sv: SVState) -> bool:
        """`lane` ends within the SV's look-ahead (or has ended): no lane to change into
        for a change the SV wants (a mandatory change would have to leave it again)."""
        end = self.ahead(lane, sv.x, sv.vx)
        return end is not None and end.due

    def begun(self, lane: int, x: float) -> bool:
        """`lane` runs beside the whole SV at centre x (m): a lane that begins along the
        route (the mainline beside an on-ramp's lane, a deceleration lane) is no lane to
        change into before its start (a lane in two: but for its first part)."""
        begin, end = self.begin_s[lane], self.end_s[lane]
        return (x - 0.5 * self.sv_length >= begin
                or (begin > end and x + 0.5 * self.sv_length <= end))

    def closed(self, lane: int, sv: SVState) -> bool:
        """No lane to change into by choice: `lane` ends soon (`ends_soon`) or has not
        begun beside the SV (`begun`)."""
        return self.ends_soon(lane, sv) or not self.begun(lane, sv.x)

    def x_limit(self, end: LaneEnd | None) -> float:
        """m, the latest centre x of the SV at the end of a manoeuvre out of a lane
        ending at `end` (inf: none)."""
        return math.inf if end is None else end.x_limit(self.sv_length)

    def limits(self, lane: int, sv: SVState, target: int, vxf: float | None,
               mandatory: bool, merge_time: float | None = None) -> PlanLimits:
        """What the end of the SV's `lane` asks of a plan from `sv` to `target` ending at
        `vxf` (m/s; None: the band rule's speed); `mandatory`: the change off an ending
        lane, `merge_time` (s; None: no comfort bound) the duration its comfortable end
        speed assumes (module docstring)."""
        x_limit = self.x_limit(self.ahead(lane, sv.x, sv.vx))
        if not mandatory:
            return PlanLimits(vx0=sv.vx, vxf=vxf, x_limit=x_limit)
        vx0 = max(sv.vx, CREEP_SPEED)
        vxf = self.lanes.end_speed(lane, target) if vxf is None else vxf
        accel = math.inf
        if merge_time is not None:
            vxf, accel = min(vxf, comfortable_speed(vx0, merge_time)), MERGE_PEAK_ACCEL
        slower: list[float] = []
        for tau in MERGE_TAUS:
            fit = max(fit_speed(x_limit - sv.x, vx0, tau), CREEP_SPEED)
            if vx0 - 1e-6 <= fit < (slower[-1] if slower else vxf) - 1e-6:
                slower.append(fit)
        return PlanLimits(vx0=vx0, vxf=vxf, x_limit=x_limit, curvature=MERGE_CURVATURE,
                          slower=tuple(slower), accel=accel)

    def merging_ahead(self, lane: int, sv_x: float, traffic: TrafficView
                      ) -> tuple[int, float]:
        """(index, bumper gap m) of the nearest TV ahead of the SV's front (centre sv_x,
        m) that must merge into the SV's `lane` from a neighbouring lane that ends (its
        change due: within its LC2013 look-ahead, cosim.planning.deadline), or (-1,
        inf). Arrays over TVs."""
        n = self.lanes.n_lanes
        x = np.asarray(traffic.x, dtype=float)
        if not self.any or x.size == 0:
            return -1, math.inf
        phases = self._phases
        p = phases.phase(x)
        length = np.asarray(traffic.length, dtype=float)
        lo, _ = self.lanes.lanes_touched(traffic.y, np.zeros(x.size))
        tv_lane = np.clip(lo, 0, n - 1).astype(int)
        remaining = phases.ends[p, tv_lane] - (x + 0.5 * length)
        # a lane with no continuing lane counts one crossing (it is no merging lane)
        crossings = np.maximum(phases.crossings[p, tv_lane], 1.0)
        horizon = look_ahead(traffic.speed, length, lane > tv_lane, crossings)
        gap = x - 0.5 * length - (sv_x + 0.5 * self.sv_length)
        merging = ((phases.target[p, tv_lane] == lane) & (tv_lane != lane) & (remaining > 0.0)
                   & (remaining <= horizon) & (gap > 0.0))
        if not merging.any():
            return -1, math.inf
        k = int(np.argmin(np.where(merging, gap, np.inf)))
        return k, float(gap[k])

    @functools.cached_property
    def _phases(self) -> EndPhases:
        return EndPhases.of(self.lanes.road)

    def yield_accel(self, speed: float, desired_speed: float, lane: int, sv_x: float,
                    traffic: TrafficView, cfg: DecisionConfig) -> float:
        """m/s^2, the courtesy of the SV (at `speed`, m/s, wanting `desired_speed`) to a
        TV that must merge into its lane ahead of it (`merging_ahead`): its car
        following's acceleration behind that TV as if it were already its leader, when
        that asks no more braking than YIELD_DECEL (LC2013's cooperative follower helps
        only within its decel); inf: nobody to let in, or too late to let it in
        comfortably (it merges behind the SV)."""
        k, gap = self.merging_ahead(lane, sv_x, traffic)
        if k < 0:
            return math.inf
        a = idm_acceleration(speed, desired_speed, gap, float(traffic.speed[k]), cfg)
        return a if a >= -YIELD_DECEL else math.inf


def comfortable_speed(vx0: float, tau: float) -> float:
    """m/s, the highest end speed of a change of `tau` (s) from `vx0` (m/s, x'' = 0 at
    both ends) whose mean acceleration is MERGE_ACCEL (eq. 2's x'' = 6 (vxf - vx0)
    (s - s^2) / tau peaks at 1.5 times its mean, `MERGE_PEAK_ACCEL`)."""
    return vx0 + MERGE_ACCEL * tau


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
