"""The manoeuvre: plan a lane change, fly it, re-check it, replan / abort / brake: one
component every policy that flies planned manoeuvres uses (not a base class it
overrides). The policy decides *when* (a target lane and a trigger each step); the
manoeuvre does the rest and is in one of four states:

- keeping: no manoeuvre under way; the policy's car-following reference is flown.
- changing: the planner (eq. 13 over the stable, collision-free tau set) gave a
  plan; the SV tracks it until t0 + tau, then keeps its lane again. With
  `[planner] replanning` the rest of the plan is re-checked every
  `recheck_interval` against fresh predictions; on a collision it replans to the
  target lane from the reference's state, else aborts to the origin lane (an
  aborted scripted request is asked again once back), else brakes.
- braking: the last resort (neither a replan nor an abort is collision-free):
  brake while steering to the nearest lane centre, at the gentlest of BRAKE_DECELS
  the re-check passes, else within BRAKE_GRIP mu g; a gentle brake is re-checked (and
  replaced by the gentlest brake that passes then), the grip's is not re-checked.
- waiting: the planner found no collision-free tau (or the policy's own check
  refused the plan); the SV keeps its lane and asks again `retry_interval` later
  (the row says "retry"; a mandatory change's row keeps saying "mandatory").

On a lane that ends (issue 24, cosim.driving.lane_end) every plan out of it must end
before the end (`LaneEnd.x_limit`, the planner's `x_limit`), a replan of the change
under way too; a mandatory change ("mandatory") may start from a standstill at
CREEP_SPEED with its end speed capped to what the room allows. A re-check that finds
no replan while the lane it would return to ends within its look-ahead does not abort
into it with the planner's plan (whose end speed would carry it on): it brakes
(`brake_trajectory`) to a stop before that lane's stop line when it can.

It also keeps the scripted requests not yet served (`due_scripted`), the plans.csv
rows, the counts of the metrics row, and when the SV may ask again (`LaneChangeTimer`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.driving.base import DrivingContext, Manoeuvres, PolicyStatus
from cosim.driving.lane_end import (
    CREEP_SPEED,
    MERGE_CURVATURE,
    MERGE_TAUS,
    STOP_DECEL,
    WAIT_ROOM,
    sv_lane_end,
)
from cosim.driving.plans import plan_row, request_row
from cosim.driving.rule import DecisionConfig
from cosim.params import G
from cosim.planning.deadline import END_MARGIN, LaneEnd, fit_speed
from cosim.planning.trajectory import LaneChangeTrajectory

if TYPE_CHECKING:
    from cosim.planning.planner import Plan, SVPlanState
    from cosim.traffic.world import SVState

PLANNER_MIN_SPEED = 5.0  # m/s (18 km/h): below it no lane change is planned (stop-and-go:
# the SV keeps its lane in a queue); the gap policy's GapConfig.min_speed defaults to it
BRAKE_GRIP = 0.7  # -, share of mu g an emergency brake (no replan, no abort) may use
BRAKE_DECELS = (1.0, 2.0, 3.0)  # m/s^2, mean decelerations of a brake tried before the
# grip's, the gentlest the re-check passes first (the merge study braked at the grip,
# 4.1-4.8 m/s^2, for collisions predicted 3.4-6.9 s ahead in 26 of 100 runs)
BRAKE_TAU = 3.0  # s, emergency brake's duration when the planner gave no tau_min
BRAKE_TAU_MIN = 1.5  # s, shortest emergency brake (lateral move to the nearest centre)

KEEPING, CHANGING, BRAKING, WAITING = "keeping", "changing", "braking", "waiting"
MANDATORY = "mandatory"  # the trigger of a change off a lane that ends (plans.csv)

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
    t_next: float = math.inf  # s, when the next manoeuvre started (window end)
    trigger: str = ""  # what asked for it (scripted | decision | retry)
    aborted: bool = False  # given up for a return to the origin lane (not a lane change)
    start_lane: int = -1  # lane it started in
    wanted_lane: int = -1  # lane first asked for


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


def reference_state(trajectory: LaneChangeTrajectory, t: float, lane: int) -> SVPlanState:
    """The reference's state at t as a planning start (position, velocity and
    acceleration of the reference, not of the plant: a new plan from it continues the
    reference without a jump, and the controller's errors carry over unchanged)."""
    from cosim.planning.planner import SVPlanState

    x, y = trajectory.position(t)
    xd, yd = trajectory.derivative(t, 1)
    xdd, ydd = trajectory.derivative(t, 2)
    return SVPlanState(x=float(x), y=float(y), heading=math.atan2(float(yd), float(xd)),
                       vx=float(xd), ax=float(xdd), vy=float(yd), ay=float(ydd), lane=lane)


class Manoeuvre:
    """The module docstring's component. `blinker(direction)` sets the SV's blinker
    (-1 right, 0 off, +1 left); the context's planner has `plan(t, state, target,
    messages, occupant, vxf=None)` and `check(trajectory, t, messages)`
    (cosim.planning.planner.LaneChangePlanner)."""

    def __init__(self, ctx: DrivingContext, timer: LaneChangeTimer,
                 blinker: Callable[[int], None]) -> None:
        self.lanes = ctx.lanes
        self.sv_length = ctx.sv_length
        self.mu = ctx.mu
        self.planner = ctx.planner
        self.blinker = blinker
        self.timer = timer
        self.occupant = ctx.sv.occupant
        self.recheck_interval = ctx.recheck_interval
        self.replanning = ctx.replanning
        self.mode = KEEPING
        self.pending = list(ctx.sv.lane_changes)  # scripted requests not yet served
        self.active: LaneChange | None = None  # the manoeuvre under way
        self.lane_changes: list[LaneChange] = []
        self.plans: list[dict[str, Any]] = []  # plans.csv rows
        self.first_plan: Any = None
        self.requests = 0
        self.last_failed: tuple[int, int] | None = None  # (origin, target) of a failed plan
        self.next_check = math.inf  # s, next re-check of the plan under way
        self.outcomes = {"replan": 0, "abort": 0, "brake": 0}  # re-check outcomes
        self.wall = 0.0  # s, wall time in the planner
        self.due_lane = -1  # the lane whose mandatory change became due (-1: none)
        self.due_horizon = 0.0  # m, the longest look-ahead since

    # ------------------------------------------------------------------ the step
    def begin(self, t: float) -> LaneChange | None:
        """Top of a step: end a manoeuvre whose time is up (returned: the policy resumes
        its car-following from its end speed) and leave `waiting` once the retry is due."""
        lc = self.active
        ended = None
        if lc is not None and t >= lc.t0 + lc.tau - 1e-9:
            self.active = None
            self.mode = KEEPING
            self.timer.manoeuvre_done(t)
            self.blinker(0)
            ended = lc
        if self.mode == WAITING and self.timer.may_request(t, decision=False):
            self.mode = KEEPING
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
        starts at CREEP_SPEED). No speed test: one asking vx >= 0 read the plant standing
        still at -1e-12 m/s as moving backwards and kept a stopped SV from ever merging
        while the queue it had asked to make room stood beside it (3 of 20 runs at 40
        veh/km/lane, issue 24)."""
        return self.active is None and self.timer.may_request(t, decision=False)

    def mandatory(self, lane: int, sv: SVState) -> LaneEnd | None:
        """The end of the SV's `lane` once the mandatory change is due, else None. Once
        due it stays due while the SV is on that lane, its look-ahead the longest it had
        (LC2013's look-ahead speed decays slowly for the same reason: slowing down, or
        standing at the stop line, must not call the change off nor make it less urgent)."""
        end = self.lane_end(lane, sv)
        if end is None:
            return None
        if self.due_lane != lane:
            self.due_horizon = 0.0
        if end.due:
            self.due_lane = lane
        if self.due_lane != lane:
            return None
        self.due_horizon = max(self.due_horizon, end.horizon)
        return replace(end, horizon=self.due_horizon)

    def lane_end(self, lane: int, sv: SVState | None = None, *, x: float = math.nan,
                 speed: float = math.nan) -> LaneEnd | None:
        """The end of `lane` ahead of the SV (at sv, or at centre x, speed), or None."""
        if sv is not None:
            x, speed = sv.x, sv.vx
        return sv_lane_end(self.lanes, lane, x, speed, self.sv_length)

    def ends_soon(self, lane: int, sv: SVState) -> bool:
        """`lane` ends within the SV's look-ahead (or has ended): no lane to change into
        for a change the SV wants (a mandatory change would have to leave it again)."""
        end = self.lane_end(lane, sv)
        return end is not None and end.due

    def advance(self, t: float, sv: SVState, target: int | None, trigger: str,
                messages: Any, *, vxf: float | None = None,
                accept: Acceptance | None = None) -> LaneChangeTrajectory | None:
        """Plan the change the policy asks for (`target`, `trigger`; None: none), or
        re-check the one under way when due; the trajectory to fly (None: keeping)."""
        if target is not None:
            self.start(t, sv, target, trigger, messages.read(), vxf=vxf, accept=accept)
        elif (self.mode in (CHANGING, BRAKING) and self.replanning
              and t >= self.next_check - 1e-9):
            self.recheck(t, messages.read())
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
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending[0].target_lane
            if target == lane:
                self.pending.pop(0)
                continue
            if abs(target - lane) != 1:  # an earlier change never happened: drop it
                self.pending.pop(0)
                self.plans.append(request_row(t, lane, target, sv.vx, 0,
                                              "not an adjacent lane"))
                self.requests += 1
                continue
            return target
        return None

    def start(self, t: float, sv: SVState, target: int, trigger: str, messages: list[Any],
              *, vxf: float | None = None, accept: Acceptance | None = None) -> None:
        """Ask the planner for a lane change to `target` (ending at `vxf`, m/s; None: the
        band rule's speed); adopt the plan (changing) unless `accept` refuses it, or keep
        the lane and ask again after `retry_interval` (waiting)."""
        from cosim.planning.planner import SVPlanState

        lane = self.lanes.lane_of(sv.y)
        vx0 = sv.vx
        end = self.lane_end(lane, sv)
        x_limit = math.inf if end is None else end.x_limit(self.sv_length)
        slower: list[float] = []  # m/s, the end speeds of further tries (mandatory)
        curvature = math.inf
        if trigger == MANDATORY:
            # from a standstill at the stop line: the reference pulls away at CREEP_SPEED
            # (the planner needs a positive speed); if no plan at the wanted end speed
            # ends in time, one at the speed a change of each MERGE_TAUS fits in the room,
            # if that is no slower than the SV (a change that brakes hard into the target
            # lane surprises its new follower: the paper's SV, 17.7 -> 3.8 m/s into a
            # braking queue, was hit from behind; the stop law slows it and it asks again)
            vx0 = max(vx0, CREEP_SPEED)
            vxf = self.lanes.end_speed(lane, target) if vxf is None else vxf
            curvature = MERGE_CURVATURE
            for tau in MERGE_TAUS:
                fit = max(fit_speed(x_limit - sv.x, vx0, tau), CREEP_SPEED)
                if vx0 - 1e-6 <= fit < (slower[-1] if slower else vxf) - 1e-6:
                    slower.append(fit)
        # the paper's boundary conditions (x'' = y' = y'' = 0 at the start): the SV plans
        # only while keeping its lane, where these are ~0; the measured values carry
        # the plant's transients (at t = 0: drag with no force yet) into the plan
        state = SVPlanState(x=sv.x, y=sv.y, heading=sv.heading, vx=vx0, ax=0.0, vy=0.0,
                            ay=0.0, lane=lane)
        repeat = self.last_failed == (lane, target)
        if trigger not in ("decision", MANDATORY) and repeat:
            trigger = "retry"
        if trigger != "retry" and not (trigger == MANDATORY and repeat):
            self.requests += 1
        plan, why = self._plan(t, state, target, trigger, messages, vxf, x_limit,
                               curvature, accept)
        for speed in slower:
            if plan.trajectory is not None and not why:
                break
            plan, why = self._plan(t, state, target, trigger, messages, speed, x_limit,
                                   curvature, accept)
        if plan.trajectory is None or why:
            self.timer.planning_failed(t)
            self.last_failed = (lane, target)
            self.mode = WAITING
            return
        self.last_failed = None
        if trigger not in ("decision", MANDATORY) and self.pending:
            self.pending.pop(0)
        self.active = LaneChange(
            t0=t, tau=float(plan.tau), origin_lane=lane, target_lane=target,
            y_target=self.lanes.centre(target), trajectory=plan.trajectory, plan=plan,
            trigger=trigger, start_lane=lane, wanted_lane=target,
        )
        self.lane_changes.append(self.active)
        self.mode = CHANGING
        self.blinker(1 if target > lane else -1)
        self.next_check = t + self.recheck_interval

    def _plan(self, t: float, state: SVPlanState, target: int, trigger: str,
              messages: list[Any], vxf: float | None, x_limit: float, curvature: float,
              accept: Acceptance | None) -> tuple[Plan, str]:
        """One planner call and its plans.csv row: (the plan, why `accept` refused it)."""
        w0 = time.perf_counter()
        if math.isfinite(x_limit):
            plan = self.planner.plan(t, state, target, messages, self.occupant, vxf=vxf,
                                     x_limit=x_limit, max_curvature=curvature)
        else:
            plan = self.planner.plan(t, state, target, messages, self.occupant, vxf=vxf)
        why = accept(plan) if accept is not None and plan.trajectory is not None else ""
        self.wall += time.perf_counter() - w0
        row = plan_row(plan, trigger, state.vx)
        if why:
            row.update(ok=0, rejections=why)
        self.plans.append(row)
        if self.first_plan is None:
            self.first_plan = plan
        return plan, why

    # ------------------------------------------------------------------ replanning
    def _check(self, trajectory: LaneChangeTrajectory, t: float, messages: list[Any]) -> Any:
        """The planner's collision check of `trajectory` against fresh predictions (its
        rejection, None: collision-free), timed into `wall`."""
        w0 = time.perf_counter()
        try:
            return self.planner.check(trajectory, t, messages)
        finally:
            self.wall += time.perf_counter() - w0

    def recheck(self, t: float, messages: list[Any]) -> None:
        """Beyond the paper (S2): re-check the rest of the plan under way against fresh
        predictions; if it now collides, replan to the target lane from the reference's
        state at t, else abort to the origin lane, else brake in the nearest lane (a
        gentle brake is re-checked too and, failing, braked anew)."""
        lc = self.active
        assert lc is not None
        self.next_check = t + self.recheck_interval
        rejection = self._check(lc.trajectory, t, messages)
        if rejection is None:
            return
        when = math.nan if rejection.time is None else rejection.time
        reason = f"re-check: collision with {rejection.vehicle_id} at {when:.2f} s"
        if self.mode == BRAKING:  # a gentle brake no longer passes: brake anew
            self._brake(t, lc, lc.plan, messages, reason, lc.target_lane)
            return
        frm, to = lc.origin_lane, lc.target_lane
        state = reference_state(lc.trajectory, t, frm)
        # a lane that ends: the replan leaves it before its end too; no abort back into
        # it once its change has been due (the brake below stops before its end
        # instead): an abort plans to the band's speed with no end in sight (issue 24: a
        # merge from the stop line at 1 m/s, within 47 m of the end but outside that
        # speed's look-ahead, aborted to 25 m/s and drove to the lane's end)
        frm_end = self.lane_end(frm, x=state.x, speed=state.vx)
        was_due = frm_end is not None and (frm_end.due or self.due_lane == frm)
        w0 = time.perf_counter()
        # continuing keeps the SV's intent, so it is tried first; the abort only when
        # no collision-free tau to the target lane is left
        if frm_end is not None:
            again = self.planner.plan(t, state, to, messages, self.occupant,
                                      x_limit=frm_end.x_limit(self.sv_length))
        else:
            again = self.planner.plan(t, state, to, messages, self.occupant)
        back = None
        if again.trajectory is None and not was_due:
            back = self.planner.plan(t, replace(state, lane=to), frm, messages, self.occupant)
        self.wall += time.perf_counter() - w0
        if again.trajectory is not None:
            kind, plan, trajectory = "replan", again, again.trajectory
        elif back is not None and back.trajectory is not None:
            kind, plan, trajectory = "abort", back, back.trajectory
        else:
            self._brake(t, lc, back if back is not None else again, messages, reason, to)
            return
        self.outcomes[kind] += 1
        row = plan_row(plan, kind, state.vx)
        row.update(reason=reason)
        self.plans.append(row)
        self._fly(t, lc, plan, trajectory, to)

    def _brake(self, t: float, lc: LaneChange, plan: Any, messages: list[Any], reason: str,
               to: int) -> None:
        """The last resort: the gentlest brake the re-check passes (`brake_trajectory`);
        re-checked while it is gentler than the grip's, which is not re-checked again."""
        trajectory, gentle = self.brake_trajectory(t, lc, plan, messages)
        self.outcomes["brake"] += 1
        self.mode = BRAKING
        self.next_check = t + self.recheck_interval if gentle else math.inf
        row = plan_row(plan, "brake", trajectory.vx0)
        row.update(reason=reason, tau_s=trajectory.tau, ok=1,
                   target_lane=self.lanes.lane_of(trajectory.y_final))
        self.plans.append(row)
        self._fly(t, lc, plan, trajectory, to)

    def _fly(self, t: float, lc: LaneChange, plan: Any, trajectory: LaneChangeTrajectory,
             to: int) -> None:
        """Adopt `trajectory` (from a re-check at t) for the manoeuvre that headed for `to`."""
        from cosim.scenario.model import LaneChangeCommand

        lanes = self.lanes
        lc.trajectory = trajectory
        lc.plan = plan
        lc.tau = trajectory.t_end - lc.t0
        end_lane = lanes.lane_of(trajectory.y_final)
        if end_lane != to:  # heading back: the manoeuvre now leaves `to` for `end_lane`
            lc.origin_lane, lc.target_lane = to, end_lane
            lc.y_target = lanes.centre(end_lane)
            self.blinker(1 if end_lane > to else -1)
        was_aborted = lc.aborted
        lc.aborted = lc.target_lane == lc.start_lane  # back where it started: no lane change
        if lc.aborted and not was_aborted and lc.trigger in ("scripted", "retry"):
            # (a mandatory change is asked again by its trigger once due)
            # ask again once back in the lane
            self.pending.insert(0, LaneChangeCommand(at=t, target_lane=lc.wanted_lane))

    def brake_trajectory(self, t: float, lc: LaneChange, plan: Any, messages: list[Any]
                         ) -> tuple[LaneChangeTrajectory, bool]:
        """Neither replan nor abort is collision-free: brake while steering to the nearest
        lane centre, from the reference's state at t (eq. 2 / eq. 4 with general start
        values): the gentlest of BRAKE_DECELS (mean decelerations) that the re-check
        passes, else within BRAKE_GRIP mu g at the quartic's peak. Returns the trajectory
        and whether it is gentler than the grip's."""
        st = reference_state(lc.trajectory, t, lc.origin_lane)  # lane unused here
        lane = self.lanes.lane_of(st.y)
        base_tau = max(plan.tau_min if math.isfinite(plan.tau_min) else BRAKE_TAU,
                       BRAKE_TAU_MIN)
        # the quartic from a = ax0 to a(tau) = 0 peaks at about 1.5x its mean deceleration
        grip = BRAKE_GRIP * self.mu * G / 1.5
        end = self.lane_end(lane, x=st.x, speed=st.vx)
        centre = self.lanes.centre(lane)
        for decel in (d for d in BRAKE_DECELS if d < grip):
            trajectory, stops = brake_reference(t, st, centre, base_tau, decel, end)
            if not stops:
                continue  # a lane that ends: only a brake that still stops before its end
            if self._check(trajectory, t, messages) is None:
                return trajectory, True
        return brake_reference(t, st, centre, base_tau, grip, end)[0], False

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
            planner_calls=len(self.plans), outcomes=dict(self.outcomes),
            first_start=changes[0].t0 if changes else None, plans=self.plans,
            first_plan=self.first_plan)


def brake_to_stop(vx: float, ax: float, tau: float, vxf: float, decel: float,
                  end: LaneEnd) -> tuple[float, float, bool]:
    """(tau, vxf) of a brake in a lane that ends, and whether the SV then stops with its
    front WAIT_ROOM before the end (braking on at STOP_DECEL after it): the brake's own
    (tau, vxf) when it does, else a brake to a standstill that ends at the stop line if
    `decel` allows, at most at `decel` (then as far as it must, and past the line). A
    quartic from ax0 with a(tau) = 0 travels (vx0 + vxf) tau / 2 + ax0 tau^2 / 12."""
    room = end.remaining - WAIT_ROOM  # m, front to the stop line

    def stops(tau: float, vxf: float) -> bool:
        travel = 0.5 * (vx + vxf) * tau + ax * tau * tau / 12.0
        return travel + vxf * vxf / (2.0 * STOP_DECEL) <= room + 1e-6

    if stops(tau, vxf):
        return tau, vxf, True
    tau_grip = max(vx / decel, BRAKE_TAU_MIN)  # shortest brake to rest within `decel`
    # (the quartic's ax0 term is small next to vx0: the stop is found from vx0 alone)
    # the gentlest stop at the stop line, within 2 BRAKE_TAU (an earlier stop leaves
    # the car following to close up to it)
    tau_stop = 2.0 * max(room, END_MARGIN) / vx
    tau = max(tau_grip, min(tau_stop, 2.0 * BRAKE_TAU))
    return tau, 0.0, stops(tau, 0.0)


def brake_reference(t: float, st: SVPlanState, centre: float, tau: float, decel: float,
                    end: LaneEnd | None) -> tuple[LaneChangeTrajectory, bool]:
    """A brake from the reference state `st` at t to the lane centre `centre` (m) over
    tau at mean deceleration `decel` (m/s^2), and whether it stops before the end of a
    lane that ends (`end`; as `brake_to_stop` has it; True without one)."""
    vxf, stops = max(st.vx - decel * tau, 0.0), True
    if end is not None and st.vx > 0.0:
        tau, vxf, stops = brake_to_stop(st.vx, st.ax, tau, vxf, decel, end)
    return LaneChangeTrajectory(t0=t, tau=tau, x0=st.x, y0=st.y, vx0=st.vx, vxf=vxf,
                                width=centre - st.y, ax0=st.ax, vy0=st.vy,
                                ay0=st.ay), stops
