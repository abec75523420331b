"""The manoeuvre: plan a lane change, fly it, re-check it: one component every policy
that flies planned manoeuvres uses (not a base class it overrides). The policy decides
*when* (a target lane and a trigger each step); the manoeuvre does the rest and is in
one of four modes (`Mode`):

- keeping: no manoeuvre under way; the policy's car-following reference is flown.
- changing: the planner (eq. 13 over the stable, collision-free tau set) gave a
  plan; the SV tracks it until t0 + tau, then keeps its lane again. With
  `[planner] replanning` the rest of the plan is re-checked every
  `recheck_interval` (cosim.driving.recheck: replan, else abort, else brake; an
  aborted scripted request is asked again once back).
- braking: the re-check's last resort, a brake in the nearest lane.
- waiting: the planner found no collision-free tau (or the policy's own check
  refused the plan); the SV keeps its lane and asks again `retry_interval` later
  (the row says "retry"; a mandatory change's row keeps saying "mandatory").

A plan out of a lane that ends takes what the lane's end asks of it
(cosim.driving.lane_end `SVLaneEnds.limits`: its deadline, and for a mandatory change a
start at walking pace and slower end speeds to try).

It also keeps the scripted requests not yet served (`ScriptedRequests`), the plans.csv
rows, the counts of the metrics row, and when the SV may ask again (`LaneChangeTimer`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.driving.base import DrivingContext, Manoeuvres, PolicyStatus
from cosim.driving.lane_end import PlanLimits, SVLaneEnds
from cosim.driving.plans import NOT_ADJACENT, PlannerCalls, Trigger, plan_row, request_row
from cosim.driving.recheck import GapRecheck, Recheck, Rescue
from cosim.driving.rule import DecisionConfig
from cosim.driving.speed_limits import SpeedLimits
from cosim.planning.trajectory import LaneChangeTrajectory

if TYPE_CHECKING:
    from cosim.planning.planner import Plan, SVPlanState
    from cosim.scenario.model import LaneChangeCommand
    from cosim.traffic.world import SVState

PLANNER_MIN_SPEED = 5.0  # m/s (18 km/h): below it no lane change is planned (stop-and-go:
# the SV keeps its lane in a queue); the gap policy's GapConfig.min_speed defaults to it


class Mode(StrEnum):
    """What the manoeuvre is doing (module docstring)."""

    KEEPING = "keeping"
    CHANGING = "changing"
    BRAKING = "braking"
    WAITING = "waiting"


# a plan the policy refuses although it has a trajectory: (plan) -> why ("": fly it)
Acceptance = Callable[["Plan"], str]


@dataclass
class LaneChange:
    """One adopted lane-change plan and how it went."""

    t0: float  # s, start
    tau: float  # s, planned duration
    origin_lane: int  # lane the manoeuvre under way leaves (after an abort: the one it aborted)
    target_lane: int  # lane it heads for (after an abort: the lane it started in)
    y_target: float  # m, target lane centre
    trajectory: LaneChangeTrajectory
    plan: Any  # the planner's Plan (for the tau-set figure)
    trigger: Trigger  # what asked for it (scripted | decision | retry | mandatory)
    start_lane: int  # lane it started in
    wanted_lane: int  # lane first asked for
    t_next: float = math.inf  # s, when the next manoeuvre started (window end)
    aborted: bool = False  # given up for a return to the origin lane (not a lane change)


class LaneChangeTimer:
    """When the SV may ask the planner again: after a failure, `retry_interval`
    later (any request); after a finished manoeuvre, `cooldown` later (requests of
    the decision rule only: a scripted request comes when the scenario says)."""

    def __init__(self, cfg: DecisionConfig) -> None:
        self.cfg = cfg
        self.next_retry = -math.inf  # s, earliest request after a failed planning call
        self.next_decision = -math.inf  # s, earliest decision-rule request after a manoeuvre

    def may_request(self, t: float, *, decision: bool = True) -> bool:
        due = t >= self.next_retry - 1e-9
        return due and (not decision or t >= self.next_decision - 1e-9)

    def cooling(self, t: float) -> bool:
        """Whether the cooldown after a finished manoeuvre still runs at t."""
        return t < self.next_decision - 1e-9

    def planning_failed(self, t: float) -> None:
        self.next_retry = t + self.cfg.retry_interval

    def manoeuvre_done(self, t: float) -> None:
        self.next_decision = t + self.cfg.cooldown


class ScriptedRequests:
    """The scenario's scripted lane changes not yet served, in time order."""

    def __init__(self, commands: Sequence[LaneChangeCommand]) -> None:
        self.pending = list(commands)

    def due(self, t: float, lane: int) -> tuple[int | None, list[int]]:
        """(the target lane of the first request due at t for an SV in `lane`, None: none;
        the target lanes of the requests dropped on the way: not adjacent to `lane`,
        an earlier change never happened). One already satisfied is dropped silently."""
        dropped = []
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending[0].target_lane
            if target == lane:
                self.pending.pop(0)
                continue
            if abs(target - lane) != 1:
                self.pending.pop(0)
                dropped.append(target)
                continue
            return target, dropped
        return None, dropped

    def served(self) -> None:
        """The first request went to a flown plan."""
        if self.pending:
            self.pending.pop(0)

    def ask_again(self, t: float, target: int) -> None:
        """A request given up (aborted) at t: ask for `target` again first."""
        from cosim.scenario.model import LaneChangeCommand

        self.pending.insert(0, LaneChangeCommand(at=t, target_lane=target))


class Manoeuvre:
    """The module docstring's component. `blinker(direction)` sets the SV's blinker
    (-1 right, 0 off, +1 left); the context's planner has `plan(t, state, target,
    messages, occupant, vxf=None, x_limit=inf, max_curvature=inf, max_tau=inf,
    max_accel=inf)` and
    `check(trajectory, t, messages)` (cosim.planning.planner.LaneChangePlanner);
    `max_tau` (s) bounds the manoeuvres it plans (inf: eq. 13 alone); `gap_rules`: the
    gap policy's re-check rules (cosim.driving.recheck.GapRecheck; None: the paper's)."""

    def __init__(self, ctx: DrivingContext, timer: LaneChangeTimer,
                 blinker: Callable[[int], None], max_tau: float = math.inf,
                 gap_rules: GapRecheck | None = None, merge_max_tau: float | None = None
                 ) -> None:
        self.lanes = ctx.lanes
        self.blinker = blinker
        self.timer = timer
        self.calls = PlannerCalls(ctx.planner, ctx.sv.occupant, max_tau)
        self.merge_max_tau = merge_max_tau  # s, a mandatory change's longest (None: max_tau)
        self.ends = SVLaneEnds(ctx.lanes, ctx.sv_length)  # the SV's lane-end reasoning
        self.sv_length = ctx.sv_length
        # the route's limits below the lanes' bands (none: every route without one)
        road = ctx.lanes.road
        self.limits = SpeedLimits(road.speed_limits) if road.speed_limits else None
        self.recheck = Recheck(self.calls, self.ends, ctx.lanes, ctx.mu,
                               ctx.recheck_interval, ctx.replanning, ctx.sv_length,
                               gap_rules, merge_max_tau)
        self.scripted = ScriptedRequests(ctx.sv.lane_changes)
        self.mode = Mode.KEEPING
        self.active: LaneChange | None = None  # the manoeuvre under way
        self.lane_changes: list[LaneChange] = []
        self.plans: list[dict[str, Any]] = []  # plans.csv rows
        self.first_plan: Any = None
        self.requests = 0
        self.last_failed: tuple[int, int] | None = None  # (origin, target) of a failed plan

    @property
    def wall(self) -> float:
        """s, wall time in the planner."""
        return self.calls.wall

    # ------------------------------------------------------------------ the step
    def begin(self, t: float) -> LaneChange | None:
        """Top of a step: end a manoeuvre whose time is up (returned: the policy resumes
        its car-following from its end speed) and leave `waiting` once the retry is due."""
        lc = self.active
        ended = None
        if lc is not None and t >= lc.t0 + lc.tau - 1e-9:
            self.active = None
            self.mode = Mode.KEEPING
            self.timer.manoeuvre_done(t)
            self.blinker(0)
            ended = lc
        if self.mode == Mode.WAITING and self.timer.may_request(t, decision=False):
            self.mode = Mode.KEEPING
        return ended

    def may_request(self, t: float, sv: SVState) -> tuple[bool, bool]:
        """Whether a scripted request, and whether a request of a decision rule, may go
        to the planner now: no manoeuvre under way, at least PLANNER_MIN_SPEED, and the
        timer's retry / cooldown passed."""
        free = self.active is None and sv.vx >= PLANNER_MIN_SPEED
        return (free and self.timer.may_request(t, decision=False),
                free and self.timer.may_request(t))

    def may_merge(self, t: float) -> bool:
        """Whether a mandatory change may go to the planner now: no manoeuvre under way
        and the retry passed, at any speed (a standstill at the stop line: the plan
        starts at walking pace). No speed test: the plant standing still reads a speed
        of about -1e-12 m/s, and a stopped SV must still merge."""
        return self.active is None and self.timer.may_request(t, decision=False)

    def advance(self, t: float, sv: SVState, target: int | None, trigger: Trigger | None,
                messages: Any, *, vxf: float | None = None,
                accept: Acceptance | None = None, ax0: float = 0.0
                ) -> LaneChangeTrajectory | None:
        """Plan the change the policy asks for (`target`, `trigger`; None: none), or
        re-check the one under way when due; the trajectory to fly (None: keeping)."""
        if target is not None and trigger is not None:
            self.start(t, sv, target, trigger, messages.read(), vxf=vxf, accept=accept,
                       ax0=ax0)
        elif self.mode in (Mode.CHANGING, Mode.BRAKING) and self.recheck.due(t):
            self._recheck(t, messages.read())
        return None if self.active is None else self.active.trajectory

    def status(self, leader_gap: float, follow_accel: float) -> PolicyStatus:
        lc = self.active
        return PolicyStatus(
            target_lane=None if lc is None else lc.target_lane, changing=lc is not None,
            manoeuvring=lc is not None, leader_gap=leader_gap,
            idm_accel=follow_accel if lc is None else math.nan)

    def due_scripted(self, t: float, sv: SVState) -> int | None:
        """The lane of the first due scripted request (in time order; one already
        satisfied is dropped, one to a lane not adjacent is logged and dropped)."""
        lane = self.lanes.lane_of(sv.y)
        target, dropped = self.scripted.due(t, lane)
        for k in dropped:
            self.plans.append(request_row(t, lane, k, sv.vx, 0, NOT_ADJACENT))
            self.requests += 1
        return target

    # ------------------------------------------------------------------ planning
    def start(self, t: float, sv: SVState, target: int, trigger: Trigger, messages: list[Any],
              *, vxf: float | None = None, accept: Acceptance | None = None,
              ax0: float = 0.0) -> None:
        """Ask the planner for a lane change to `target` (ending at `vxf`, m/s; None: the
        band rule's speed; starting with the reference's acceleration `ax0`, m/s^2, but for
        a mandatory change); adopt the plan (changing) unless `accept` refuses it, or keep
        the lane and ask again after `retry_interval` (waiting)."""
        from cosim.planning.planner import SVPlanState

        if not self.ends.begun(target, sv.x):
            return  # a lane that begins ahead: asked again once it runs beside the SV
        lane = self.lanes.lane_of(sv.y)
        if self.limits is not None:
            vxf = self.limits.change_end_speed(
                target, sv.x + 0.5 * self.sv_length, sv.vx,
                self.lanes.end_speed(lane, target) if vxf is None else vxf)
        limits = self.ends.limits(lane, sv, target, vxf, trigger == Trigger.MANDATORY,
                                  self.merge_max_tau)
        # the paper's boundary conditions (x'' = y' = y'' = 0 at the start): the SV plans
        # only while keeping its lane, where these are ~0; the measured values would
        # carry the plant's transients (at t = 0: drag with no force yet) into the plan.
        # A policy may start it with its reference's acceleration instead (`ax0`: the
        # gap policy speeding up toward a faster lane goes on doing so, not a jerk to 0)
        ax = 0.0 if trigger == Trigger.MANDATORY else ax0
        state = SVPlanState(x=sv.x, y=sv.y, heading=sv.heading, vx=limits.vx0, ax=ax,
                            vy=0.0, ay=0.0, lane=lane)
        trigger = self._count_request(lane, target, trigger)
        plan, why = self._plan(t, state, target, trigger, messages, limits.vxf, limits, accept)
        for speed in limits.slower:  # a mandatory change: slower end speeds, in order
            if plan.trajectory is not None and not why:
                break
            plan, why = self._plan(t, state, target, trigger, messages, speed, limits, accept)
        if plan.trajectory is None or why:
            self.timer.planning_failed(t)
            self.last_failed = (lane, target)
            self.mode = Mode.WAITING
            return
        self._adopt(t, lane, target, trigger, plan)

    def _count_request(self, lane: int, target: int, trigger: Trigger) -> Trigger:
        """The trigger of the row (a scripted request asked again after a failed plan is
        a retry) and the request counted unless it repeats one."""
        repeat = self.last_failed == (lane, target)
        if trigger not in (Trigger.DECISION, Trigger.MANDATORY) and repeat:
            trigger = Trigger.RETRY
        if trigger != Trigger.RETRY and not (trigger == Trigger.MANDATORY and repeat):
            self.requests += 1
        return trigger

    def _plan(self, t: float, state: SVPlanState, target: int, trigger: Trigger,
              messages: list[Any], vxf: float | None, limits: PlanLimits,
              accept: Acceptance | None) -> tuple[Plan, str]:
        """One planner call and its plans.csv row: (the plan, why `accept` refused it)."""
        plan = self.calls.plan(t, state, target, messages, vxf=vxf, x_limit=limits.x_limit,
                               curvature=limits.curvature, accel=limits.accel,
                               max_tau=self.merge_max_tau if trigger == Trigger.MANDATORY
                               else None)
        with self.calls.timed():
            why = accept(plan) if accept is not None and plan.trajectory is not None else ""
        row = plan_row(plan, trigger, state.vx)
        if why:
            row.update(ok=0, rejections=why)
        self.plans.append(row)
        if self.first_plan is None:
            self.first_plan = plan
        return plan, why

    def _adopt(self, t: float, lane: int, target: int, trigger: Trigger, plan: Plan) -> None:
        """Fly `plan` from t (changing)."""
        self.last_failed = None
        if trigger not in (Trigger.DECISION, Trigger.MANDATORY):
            self.scripted.served()
        self.active = LaneChange(
            t0=t, tau=float(plan.tau), origin_lane=lane, target_lane=target,
            y_target=self.lanes.centre(target), trajectory=plan.trajectory, plan=plan,
            trigger=trigger, start_lane=lane, wanted_lane=target,
        )
        self.lane_changes.append(self.active)
        self.mode = Mode.CHANGING
        self.blinker(1 if target > lane else -1)
        self.recheck.schedule(t)

    # ------------------------------------------------------------------ re-checking
    def _recheck(self, t: float, messages: list[Any]) -> None:
        """Re-check the plan under way; fly what replaces it if it now collides."""
        lc = self.active
        assert lc is not None
        rescue = self.recheck.run(t, lc, messages, braking=self.mode == Mode.BRAKING)
        if rescue is None:
            return
        if rescue.kind == Trigger.BRAKE:
            self.mode = Mode.BRAKING
        self.plans.append(rescue.row)
        self._fly(t, lc, rescue)

    def _fly(self, t: float, lc: LaneChange, rescue: Rescue) -> None:
        """Adopt the rescue's trajectory (from a re-check at t) for the manoeuvre `lc`."""
        lanes = self.lanes
        to = lc.target_lane
        trajectory = rescue.trajectory
        lc.trajectory = trajectory
        lc.plan = rescue.plan
        lc.tau = trajectory.t_end - lc.t0
        end_lane = lanes.lane_of(trajectory.y_final)
        if end_lane != to:  # heading back: the manoeuvre now leaves `to` for `end_lane`
            lc.origin_lane, lc.target_lane = to, end_lane
            lc.y_target = lanes.centre(end_lane)
            self.blinker(1 if end_lane > to else -1)
        was_aborted = lc.aborted
        lc.aborted = lc.target_lane == lc.start_lane  # back where it started: no lane change
        if lc.aborted and not was_aborted and lc.trigger in (Trigger.SCRIPTED, Trigger.RETRY):
            # asked again once back in the lane (a mandatory change is asked again by its
            # trigger once due)
            self.scripted.ask_again(t, lc.wanted_lane)

    # ------------------------------------------------------------------ the run
    def summary(self, t: np.ndarray) -> Manoeuvres:
        """Lane changes from each adopted plan's start; an aborted one is none."""
        changes = self.lane_changes
        for a, b in zip(changes, changes[1:], strict=False):
            a.t_next = b.t0
        flown = [lc for lc in changes if not lc.aborted]  # an aborted one went back
        return Manoeuvres(
            lane_changes=changes, starts=[lc.t0 for lc in flown],
            targets=[lc.y_target for lc in flown],
            ends=[min(lc.t_next, float(t[-1])) for lc in flown], requests=self.requests,
            planner_calls=len(self.plans), outcomes=dict(self.recheck.outcomes),
            first_start=changes[0].t0 if changes else None, plans=self.plans,
            first_plan=self.first_plan)
