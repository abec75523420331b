"""The gap-seeking lane-change policy ("gap", `[planner] policy = "gap"`; beyond the
paper): the paper's state machine (cosim.policy.PaperPolicy: keeping / changing /
braking / waiting, re-check, replan / abort / brake) with another way of keeping
its lane and of deciding when to plan.

While keeping its lane the SV follows cosim.gap_driver each step: it wants a lane
(a due scripted request, or the decision rule's faster lane, held for WANT_HOLD
while it is still in the lane it wanted to leave), picks a gap there and drives the
speed that takes it into it (never faster than its own leader allows). It calls the
planner only once the gap is reached (and at >= cosim.gap.PLANNER_MIN_SPEED), with
the gap's speed as vxf; a plan is flown only if its new follower, predicted as
SUMO's Krauss follows (cosim.planning.interaction.check_follower), brakes no harder
than `GapConfig.plan_decel` (within MOBIL's b_safe), else it counts as a failed plan
and its follower is asked to make room (retried after
`retry_interval`, the approach going on). It stops behind a standing leader at
STOP_GAP (IDM standstill gap). It signals while it seeks a gap, and asks the chosen
gap's follower to open the gap (`cooperate(t, tv_id)`: the traffic's courtesy and
cooperative V2V, cosim.traffic.cooperation; None: never).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from cosim.decision import DecisionConfig, lanes_touched
from cosim.gap import GapConfig
from cosim.gap_driver import GapDecision, gap_decision
from cosim.params import RoadParams
from cosim.planning.interaction import FollowerModel, check_follower
from cosim.policy import PaperPolicy
from cosim.scenario import Scenario
from cosim.traffic.world import Scene, SVState

WANT_HOLD = 20.0  # s, a lane the decision rule wanted is sought this long at most
STOP_GAP = 2.5  # m, IDM standstill gap s0 of this driver (SUMO's minGap; >= 2 m in a queue)


class GapPolicy(PaperPolicy):
    """The module docstring's policy; `cooperate(t, tv_id)` asks a TV to open a gap."""

    name = "gap"

    def __init__(self, scenario: Scenario, road: RoadParams, cfg: DecisionConfig,
                 planner: Any, blinker: Callable[[int], None],
                 cooperate: Callable[[float, str], object] | None = None,
                 gap_cfg: GapConfig | None = None,
                 follower: FollowerModel | None = None) -> None:
        super().__init__(scenario, road, replace(cfg, idm_min_gap=max(cfg.idm_min_gap,
                                                                      STOP_GAP)),
                         planner, self._signal)
        self._blinker = blinker
        self.signal = 0  # the SV's blinker now: -1 right, 0 off, +1 left
        self.gap_cfg = gap_cfg or GapConfig()
        self.follower = follower or FollowerModel()
        # what a flown plan may ask of its new follower: the driver's own limit within b_safe
        self.plan_follower = self.follower.limited(self.gap_cfg.plan_decel)
        self.cooperate = cooperate
        self.sv_length = scenario.vehicle.length
        self.decision = scenario.sv.decision
        self.wanted: tuple[int, int, float] | None = None  # (origin, target, until t)
        self.last: GapDecision | None = None  # this step's decision
        self.scene: Scene | None = None

    def _signal(self, direction: int) -> None:
        """The blinker, set in SUMO only when it changes."""
        if direction != self.signal:
            self.signal = direction
            self._blinker(direction)

    def update(self, t: float, scene: Scene, messages: Any) -> Any:
        self.scene = scene
        return super().update(t, scene, messages)

    def request(self, t: float, sv: SVState, scene: Scene, allow_scripted: bool,
                allow_decision: bool) -> tuple[int | None, str]:
        """Car-following toward the chosen gap; (target, trigger) once it is reached."""
        following = self.following
        if self.active is not None:  # changing: car-following values for the trace only
            following.update(sv, scene, False)
            return None, ""
        lane = self.road.lane_of(sv.y)
        scripted = self.due_scripted(t, sv)
        if self.wanted is not None and (self.wanted[0] != lane or t > self.wanted[2]):
            self.wanted = None
        wanted = scripted if scripted is not None else (
            self.wanted[1] if self.wanted is not None else None)
        tvs = scene.tvs
        d = gap_decision(
            sv.x, sv.y, following.v_ref, self.sv_length, following.desired_speed(lane),
            tvs.x, tvs.y, scene.tv_vx, tvs.length, tvs.width, self.road, following.cfg,
            self.gap_cfg, self.follower, wanted_lane=wanted,
            allow_change=scripted is not None or self.decision,
            tv_lateral_speed=tvs.lateral_speed)
        following.limit(d.accel, d.leader_gap)
        self.last = d
        if scripted is None and self.wanted is None and d.target_lane is not None:
            self.wanted = (lane, d.target_lane, t + WANT_HOLD)
        # it signals while it seeks a gap, as SUMO's drivers do while they wait for one:
        # what the traffic's courtesy answers (cosim.traffic.cooperation)
        self._signal(0 if d.target_lane is None else (1 if d.target_lane > lane else -1))
        if d.cooperate_with >= 0 and self.cooperate is not None:
            self.cooperate(t, str(tvs.ids[d.cooperate_with]))
        if not d.plan_now or d.target_lane is None:
            return None, ""
        if scripted is not None:
            return (d.target_lane, "scripted") if allow_scripted else (None, "")
        return (d.target_lane, "decision") if allow_decision else (None, "")

    def call_planner(self, t: float, state: Any, target: int, messages: list[Any]
                     ) -> tuple[Any, str]:
        """The plan at the gap's speed; not flown if its new follower would brake harder
        than b_safe (MOBIL)."""
        vxf = self.last.vxf if self.last is not None else math.nan
        plan = self.planner.plan(t, state, target, messages, self.occupant,
                                 vxf=vxf if math.isfinite(vxf) else None)
        if plan.trajectory is None or self.scene is None:
            return plan, ""
        tvs = self.scene.tvs
        lo, hi = lanes_touched(tvs.y, 0.5 * np.asarray(tvs.width, dtype=float), self.road)
        in_target = (lo <= target) & (hi >= target)
        check = check_follower(plan.trajectory, self.sv_length, tvs.x, self.scene.tv_vx,
                               tvs.length, in_target, self.plan_follower)
        if check.safe:
            return plan, ""
        if self.cooperate is not None:  # the follower that would brake too hard blocks
            self.cooperate(t, str(tvs.ids[check.follower]))
        return plan, (f"follower {tvs.ids[check.follower]} would brake "
                      f"{check.max_decel:.2f} m/s^2 > {self.plan_follower.b_safe:g}")
