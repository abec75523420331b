"""Car following in the SV's lane while it keeps its lane: the decision rule's IDM
acceleration (cosim.driving.rule), rate-limited to what the car can follow, and the
straight lane-keeping reference built from it (a 'lane change' of width 0 along the
lane centre whose speed follows the IDM law, kept near the car's speed)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from cosim.driving.base import DrivingContext
from cosim.driving.curve_speed import CornerSpeeds
from cosim.driving.lane_end import stop_accel
from cosim.driving.rule import Decision, DecisionConfig, decide
from cosim.driving.speed_limits import SpeedLimits
from cosim.driving.view import SVView, TrafficView
from cosim.params import STANDSTILL_SPEED, G
from cosim.planning.trajectory import LaneChangeTrajectory

if TYPE_CHECKING:
    from cosim.traffic.world import Scene, SVState

FOLLOW_HORIZON = 1.0  # s, horizon of the straight lane-keeping reference
FOLLOW_GRIP = 0.7  # -, share of mu g the car-following reference may brake with
MAX_FOLLOW_JERK = 15.0  # m/s^3, rate limit of the car-following acceleration
REF_SPEED_BAND = 0.5  # m/s, the lane-keeping reference speed stays this close to Vx
HOLD_DECEL = 1.5  # m/s^2, the standstill hold begins where braking at this stops the
# reference at the standstill gap (a hold that began only at s0 would set a still
# creeping reference's speed to 0 at once, a jump in ax) ...
# tuned: docs/tuned_constants.md
HOLD_SPEED = 1.0  # m/s, ... from this speed down only (the IDM's last creep; faster, the
# IDM and a lane end's stop law brake for the standing leader themselves)


def lane_keeping_reference(
    t: float, x: float, y_centre: float, speed: float, accel: float
) -> LaneChangeTrajectory:
    """A straight reference along a lane centre whose speed starts at `speed` and
    changes at `accel` (m/s^2) over the next FOLLOW_HORIZON (a 'lane change' of width 0)."""
    return LaneChangeTrajectory(
        t0=t, tau=FOLLOW_HORIZON, x0=x, y0=y_centre, vx0=speed,
        vxf=max(speed + accel * FOLLOW_HORIZON, 0.0), width=0.0, ax0=accel,
    )


class CarFollowing:
    """Car following in the SV's lane (IDM through the decision rule), rate-limited to
    what the car can follow, and the lane-keeping reference built from it; `cfg` is the
    decision rule's settings this policy follows with."""

    def __init__(self, ctx: DrivingContext, cfg: DecisionConfig) -> None:
        self.sv = ctx.sv
        self.sv_length = ctx.sv_length
        self.sv_width = ctx.sv_width
        self.lanes, self.mu, self.cfg, self.dt = ctx.lanes, ctx.mu, cfg, ctx.step
        self.v_cruise = ctx.sv.speed  # m/s, speed kept without a leader (no decision rule)
        self.v_ref = ctx.sv.speed  # m/s, lane-keeping reference speed (integrated IDM)
        self.accel = 0.0  # m/s^2, car-following acceleration
        self.wanted = 0.0  # m/s^2, the acceleration `limit` was asked for (within grip)
        self.leader_gap = math.inf  # m
        self.leader_speed = math.inf  # m/s (inf: no leader)
        road = ctx.lanes.road
        # its speed at the route's corners (none: every route without one)
        self.corners = (CornerSpeeds(road.corners, ctx.mu, ctx.sv.curve_lat_accel)
                        if road.corners else None)
        # the route's limits below the lanes' bands (none: every route without one)
        self.limits = SpeedLimits(road.speed_limits) if road.speed_limits else None
        self.s = math.nan  # m, the SV's s when it was last seen (`view`)
        self.lane = 0  # the SV's lane when it was last seen (`view`)

    def desired_speed(self, lane: int) -> float:
        if self.limits is None:
            return self._wanted_speed(lane)
        limit = self.limits.at(lane, self.s + 0.5 * self.sv_length)
        return min(self._wanted_speed(lane), limit)

    def _wanted_speed(self, lane: int) -> float:
        if self.sv.desired_speed is not None:
            return self.sv.desired_speed
        if self.sv.decision:
            return self.lanes.speed_limit(lane)
        return self.v_cruise

    def view(self, sv: SVState) -> SVView:
        """The SV as the decision rules see it: at the reference's speed, wanting its
        desired speed in the lane it is in."""
        self.s = sv.x
        self.lane = self.lanes.lane_of(sv.y)
        return SVView(sv.x, sv.y, self.v_ref, self.sv_length,
                      self.desired_speed(self.lane), self.sv_width, self.accel)

    def update(self, sv: SVState, scene: Scene, allow_change: bool,
               stop_gap: float = math.inf) -> Decision:
        """This step's car-following acceleration; the decision rule's lane change
        (only with `allow_change` and `[sv] decision`). `stop_gap` (m): bumper gap to a
        virtual standing leader (a lane that ends: cosim.driving.lane_end; inf: none)."""
        d = decide(self.view(sv), TrafficView.of(scene), self.lanes, self.cfg,
                   allow_change=allow_change and self.sv.decision)
        self.limit(*self.with_stop(d.accel, d.leader_gap, d.leader_speed, stop_gap))
        return d

    def with_stop(self, accel: float, leader_gap: float, leader_speed: float,
                  stop_gap: float) -> tuple[float, float, float]:
        """(accel, leader gap, leader speed) with a virtual standing leader at bumper gap
        `stop_gap` (m; inf: none) as well: the smaller acceleration of the two
        (`lane_end.stop_accel`), the nearer of the two leaders."""
        if not math.isfinite(stop_gap):
            return accel, leader_gap, leader_speed
        accel = min(accel, stop_accel(self.v_ref, stop_gap, self.cfg.idm_min_gap))
        if stop_gap < leader_gap:
            return accel, stop_gap, 0.0
        return accel, leader_gap, leader_speed

    def limit(self, accel: float, leader_gap: float, leader_speed: float = math.inf) -> None:
        """Take `accel` (m/s^2) as this step's car-following acceleration, as a reference
        the car can follow: braking within the road's grip, and the acceleration
        changing at most MAX_FOLLOW_JERK (a new leader cutting in)."""
        if self.corners is not None:
            half = 0.5 * self.sv_length
            accel = min(accel, self.corners.accel_cap(self.s + half, self.s - half, self.v_ref))
        if self.limits is not None:
            accel = min(accel, self.limits.accel_cap(self.lane, self.s + 0.5 * self.sv_length,
                                                     self.v_ref))
        lo = -min(self.cfg.max_brake, FOLLOW_GRIP * self.mu * G)
        step = MAX_FOLLOW_JERK * self.dt
        self.wanted = max(accel, lo)
        self.accel = min(max(self.wanted, self.accel - step), self.accel + step)
        self.leader_gap = leader_gap
        self.leader_speed = leader_speed

    @property
    def ramping(self) -> bool:
        """Whether the jerk limit still holds the acceleration short of the one asked
        for: a decision held now would hold the ramp (a leader cut in 2.4 m ahead,
        braking reached 3 m/s^2 in 0.65 s at one step per held decision, not 15 m/s^3)."""
        return abs(self.accel - self.wanted) > 1e-9

    def holding(self, reach: float = 0.0) -> bool:
        """Behind a standing leader within the IDM's standstill gap (plus `reach`, m):
        the reference speed is held at 0 (the IDM alone would creep on at the speed its
        integration leaves and close ~1 cm inside s0; SUMO's Krauss stops at minGap the
        same way)."""
        return (self.leader_speed < STANDSTILL_SPEED
                and self.leader_gap <= self.cfg.idm_min_gap + reach)

    def resume(self, speed: float, brake_from: float | None = None) -> None:
        """A manoeuvre ended at `speed` (m/s): follow on from it, and cruise at it; braking
        begins at `brake_from` (m/s^2, its end acceleration; None: at once), the next
        accelerations within MAX_FOLLOW_JERK."""
        self.v_ref = speed
        self.v_cruise = speed
        if brake_from is not None:
            self.accel = max(self.accel, brake_from)

    def reference(self, t: float, sv: SVState) -> LaneChangeTrajectory:
        """The straight lane-keeping reference from t; advances the reference speed."""
        lane = self.lanes.lane_of(sv.y)
        # anti-windup of the reference: never far from the speed the car has
        self.v_ref = min(max(self.v_ref, sv.vx - REF_SPEED_BAND), sv.vx + REF_SPEED_BAND)
        # the hold begins where braking at HOLD_DECEL brings the reference to rest at s0
        creep = max(self.v_ref, 0.0)
        if self.holding(creep ** 2 / (2.0 * HOLD_DECEL) if creep <= HOLD_SPEED else 0.0):
            room = self.leader_gap - self.cfg.idm_min_gap
            if room > 1e-3:  # short of s0: brake to rest there, within HOLD_DECEL
                self.accel = min(self.accel, 0.0,
                                 -min(self.v_ref / self.dt, self.v_ref ** 2 / (2.0 * room)))
            else:
                self.v_ref = 0.0
                self.accel = min(self.accel, 0.0)
        reference = lane_keeping_reference(t, sv.x, self.lanes.centre(lane), self.v_ref,
                                           self.accel)
        self.v_ref = max(self.v_ref + self.accel * self.dt, 0.0)
        return reference
