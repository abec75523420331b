"""The paper's SV ("paper", the paper's method with our additions): plan where the
SV is once the target lane is free, track, re-check.

Each step while it keeps its lane the SV follows its leader (cosim.driving.following)
and asks for a lane change when a scripted request is due (in time order; one
already satisfied is dropped, one to a lane not adjacent is logged and dropped) or,
with `[sv] decision`, when the paper's trigger (cosim.driving.rule) wants one (not
within `cooldown` after a manoeuvre). The manoeuvre (cosim.driving.manoeuvre) plans
it at the band rule's end speed and flies, re-checks, replans, aborts or brakes.

On a lane that ends it does what cosim.driving.lane_end says: it stops before the end
(a virtual standing leader), and once the end is within its look-ahead it asks for the
change into the continuing lane ("mandatory") instead of any other, every
`retry_interval` until a plan that ends before the end is found, from a standstill
too; its decision rule never changes into a lane that ends within the look-ahead.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from cosim.driving.base import DrivingContext, Manoeuvres, Messages, PolicyStatus
from cosim.driving.following import CarFollowing
from cosim.driving.lane_end import stop_gap
from cosim.driving.manoeuvre import LaneChangeTimer, Manoeuvre
from cosim.driving.plans import Trigger
from cosim.driving.registry import register

if TYPE_CHECKING:
    from cosim.planning.trajectory import LaneChangeTrajectory
    from cosim.traffic.world import Scene, SVState


@register("paper")
class PaperPolicy:
    """The module docstring's policy."""

    listens = True
    needs_planner = True
    asks_for_gaps = False
    prediction = None  # the planner's default prediction

    def __init__(self, ctx: DrivingContext) -> None:
        self.following = CarFollowing(ctx, ctx.decision)
        self.manoeuvre = Manoeuvre(ctx, LaneChangeTimer(ctx.decision), ctx.ports.blinker)
        self.ends = self.manoeuvre.ends  # the SV's lane-end reasoning

    @property
    def wall(self) -> float:
        return self.manoeuvre.wall

    def status(self, sv: SVState) -> PolicyStatus:
        return self.manoeuvre.status(self.following.leader_gap, self.following.accel)

    def gaps_held(self, sv: SVState) -> bool:
        """No gap requests (`asks_for_gaps` false): true while no change is under way."""
        return self.manoeuvre.active is None

    def update(self, t: float, scene: Scene, messages: Messages) -> LaneChangeTrajectory:
        """Finish a manoeuvre that is over, ask for a lane change or re-check the one
        under way; returns the reference to track from t."""
        sv, m = scene.sv, self.manoeuvre
        ended = m.begin(t)
        if ended is not None:
            self.following.resume(float(ended.trajectory.vxf))
        allow_scripted, allow_decision = m.may_request(t, sv)
        lane = self.following.lanes.lane_of(sv.y)
        end = self.ends.ahead(lane, sv.x, sv.vx)  # its lane ends: stop before it, change
        d = self.following.update(sv, scene, allow_decision, stop_gap(end))
        target, trigger = None, None
        if end is not None and self.ends.due(lane, sv) is not None:
            if m.may_merge(t):
                target, trigger = end.target, Trigger.MANDATORY
        elif allow_scripted:
            target = m.due_scripted(t, sv)
            if target is not None:
                trigger = Trigger.SCRIPTED
            elif (allow_decision and d.target_lane is not None
                  and not self.ends.closed(d.target_lane, sv)):
                target, trigger = d.target_lane, Trigger.DECISION
        trajectory = m.advance(t, sv, target, trigger, messages)
        return trajectory if trajectory is not None else self.following.reference(t, sv)

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        """Lane changes from each adopted plan's start; an aborted one is none."""
        return self.manoeuvre.summary(t)
