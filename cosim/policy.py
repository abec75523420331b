"""When and how the SV changes lanes: the lane-change policy, one state machine.

`PaperPolicy` ("paper", the paper's SV with our additions) is in one of four modes:

- keeping: lane keeping; the reference is a straight line on the lane centre whose
  speed follows the IDM law (cosim.decision), rate-limited and kept near the car's
  speed. A lane change is asked for when a scripted request is due (in time order;
  one already satisfied is dropped, one to a lane not adjacent is logged and
  dropped) or, with `[sv] decision`, when the decision rule wants one (not within
  `cooldown` after a manoeuvre).
- changing: the planner (eq. 13 over the stable, collision-free tau set) gave a
  plan; the SV tracks it until t0 + tau, then keeps its lane again. With
  `[planner] replanning` the rest of the plan is re-checked every
  `recheck_interval` against fresh predictions; on a collision it replans to the
  target lane from the reference's state, else aborts to the origin lane (an
  aborted scripted request is asked again once back), else brakes.
- braking: the last resort (neither a replan nor an abort is collision-free):
  brake within BRAKE_GRIP mu g while steering to the nearest lane centre; not
  re-checked.
- waiting: the planner found no collision-free tau; the SV keeps its lane and asks
  again `retry_interval` later (the row says "retry").

`SumoDriverPolicy` serves the SUMO-driven baseline SV: scripted requests become
SUMO `changeLane` calls and SUMO's own model decides the rest.

A policy has `status` (what the recorder reads at the top of a step), `update`
(the step's decisions; returns the reference the ego tracks) and `summary` (what
it did, for the metrics row). Another lane-change policy plugs in beside the
paper's in POLICIES (chosen by name); nothing here needs SUMO, so a policy can be
tested on hand-made scenes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from cosim.decision import Decision, DecisionConfig, LaneChangeTimer, decide
from cosim.gap import PLANNER_MIN_SPEED
from cosim.params import G, RoadParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.recorder import (
    PLAN_COLUMNS,
    LaneChange,
    Manoeuvres,
    PolicyStatus,
    excursions,
    plan_row,
)
from cosim.scenario import LaneChangeCommand, Scenario
from cosim.traffic.world import Scene, SVState

FOLLOW_HORIZON = 1.0  # s, horizon of the straight lane-keeping reference
FOLLOW_GRIP = 0.7  # -, share of mu g the car-following reference may brake with
MAX_FOLLOW_JERK = 15.0  # m/s^3, rate limit of the car-following acceleration
REF_SPEED_BAND = 0.5  # m/s, the lane-keeping reference speed stays this close to Vx
BRAKE_GRIP = 0.7  # -, share of mu g an emergency brake (no replan, no abort) may use
BRAKE_TAU = 3.0  # s, emergency brake's duration when the planner gave no tau_min
BRAKE_TAU_MIN = 1.5  # s, shortest emergency brake (lateral move to the nearest centre)
SIDEWAYS_SPEED = 0.05  # m/s, the SUMO-driven SV moving sideways faster is changing lanes

KEEPING, CHANGING, BRAKING, WAITING = "keeping", "changing", "braking", "waiting"


class Messages(Protocol):
    """What the SV knows of the TVs this step (cosim.observer.Inbox)."""

    def read(self) -> list[Any]: ...


class LaneChangePolicy(Protocol):
    """A lane-change policy (see the module docstring)."""

    listens: bool  # it reads V2V messages (the channel must run)
    wall: float  # s, wall time in the planner

    def status(self, sv: SVState) -> PolicyStatus: ...
    def update(self, t: float, scene: Scene, messages: Messages
               ) -> LaneChangeTrajectory | None: ...
    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres: ...


def lane_keeping_reference(
    t: float, x: float, y_centre: float, speed: float, accel: float
) -> LaneChangeTrajectory:
    """A straight reference along a lane centre whose speed starts at `speed` and
    changes at `accel` (m/s^2) over the next FOLLOW_HORIZON (a 'lane change' of width 0)."""
    return LaneChangeTrajectory(
        t0=t, tau=FOLLOW_HORIZON, x0=x, y0=y_centre, vx0=speed,
        vxf=max(speed + accel * FOLLOW_HORIZON, 0.0), width=0.0, ax0=accel,
    )


def reference_state(trajectory: LaneChangeTrajectory, t: float, lane: int) -> Any:
    """The reference's state at t as a planning start (position, velocity and
    acceleration of the reference, not of the plant: a new plan from it continues the
    reference without a jump, and the controller's errors carry over unchanged)."""
    from cosim.planning.planner import SVPlanState

    x, y = trajectory.position(t)
    xd, yd = trajectory.derivative(t, 1)
    xdd, ydd = trajectory.derivative(t, 2)
    return SVPlanState(x=float(x), y=float(y), heading=math.atan2(float(yd), float(xd)),
                       vx=float(xd), ax=float(xdd), vy=float(yd), ay=float(ydd), lane=lane)


def request_row(t: float, origin: int, target: int, vx0: float, ok: int,
                    why: str = "") -> dict[str, Any]:
    """A plans.csv row of a scripted request that did not go through the planner (one
    dropped, or one handed to SUMO's lane-change model)."""
    row = dict.fromkeys(PLAN_COLUMNS, math.nan)
    row.update(t_s=t, trigger="scripted", origin_lane=origin, target_lane=target, vx0_mps=vx0,
               ok=ok, stable_set_s="", collision_free_set_s="", rejections=why)
    return row


class CarFollowing:
    """Car-following in the SV's lane (IDM through the decision rule), rate-limited to
    what the car can follow, and the lane-keeping reference built from it."""

    def __init__(self, scenario: Scenario, road: RoadParams, cfg: DecisionConfig) -> None:
        self.sv = scenario.sv
        self.sv_length = scenario.vehicle.length
        self.road, self.cfg, self.dt = road, cfg, scenario.step
        self.v_cruise = scenario.sv.speed  # m/s, speed kept without a leader (no decision rule)
        self.v_ref = scenario.sv.speed  # m/s, lane-keeping reference speed (integrated IDM)
        self.accel = 0.0  # m/s^2, car-following acceleration
        self.leader_gap = math.inf  # m

    def desired_speed(self, lane: int) -> float:
        if self.sv.desired_speed is not None:
            return self.sv.desired_speed
        if self.sv.decision:
            return self.road.speed_bands[lane][1]
        return self.v_cruise

    def update(self, sv: SVState, scene: Scene, allow_change: bool) -> Decision:
        """This step's car-following acceleration; the decision rule's lane change
        (only with `allow_change` and `[sv] decision`)."""
        road = self.road
        tvs = scene.tvs
        d = decide(sv.x, sv.y, self.v_ref, self.sv_length, self.desired_speed(road.lane_of(sv.y)),
                   tvs.x, tvs.y, scene.tv_vx, tvs.length, tvs.width,
                   road, self.cfg, allow_change=allow_change and self.sv.decision,
                   tv_lateral_speed=tvs.lateral_speed)
        self.limit(d.accel, d.leader_gap)
        return d

    def limit(self, accel: float, leader_gap: float) -> None:
        """Take `accel` (m/s^2) as this step's car-following acceleration, as a reference
        the car can follow: braking within the road's grip, and the acceleration
        changing at most MAX_FOLLOW_JERK (a new leader cutting in)."""
        lo = -min(self.cfg.max_brake, FOLLOW_GRIP * self.road.mu * G)
        step = MAX_FOLLOW_JERK * self.dt
        self.accel = min(max(accel, lo, self.accel - step), self.accel + step)
        self.leader_gap = leader_gap

    def reference(self, t: float, sv: SVState) -> LaneChangeTrajectory:
        """The straight lane-keeping reference from t; advances the reference speed."""
        lane = self.road.lane_of(sv.y)
        # anti-windup of the reference: never far from the speed the car has
        self.v_ref = min(max(self.v_ref, sv.vx - REF_SPEED_BAND), sv.vx + REF_SPEED_BAND)
        reference = lane_keeping_reference(t, sv.x, self.road.lane_center(lane), self.v_ref,
                                           self.accel)
        self.v_ref = max(self.v_ref + self.accel * self.dt, 0.0)
        return reference


class PaperPolicy:
    """The paper's SV: plan with the planner, track, re-check (module docstring).

    `planner` has `plan(t, state, target, messages, occupant)` and `check(trajectory,
    t, messages)` (cosim.planning.planner.LaneChangePlanner); `blinker(direction)`
    sets the SV's blinker (-1 right, 0 off, +1 left)."""

    name = "paper"
    listens = True

    def __init__(self, scenario: Scenario, road: RoadParams, cfg: DecisionConfig,
                 planner: Any, blinker: Callable[[int], None]) -> None:
        self.road = road
        self.planner = planner
        self.blinker = blinker
        self.occupant = scenario.sv.occupant
        self.recheck_interval = scenario.planner.recheck_interval
        self.replanning = scenario.planner.replanning
        self.following = CarFollowing(scenario, road, cfg)
        self.timer = LaneChangeTimer(cfg)
        self.mode = KEEPING
        self.pending = list(scenario.sv.lane_changes)  # scripted requests not yet served
        self.active: LaneChange | None = None  # the manoeuvre under way
        self.lane_changes: list[LaneChange] = []
        self.plans: list[dict[str, Any]] = []  # plans.csv rows
        self.first_plan: Any = None
        self.requests = 0
        self.last_failed: tuple[int, int] | None = None  # (origin, target) of a failed plan
        self.next_check = math.inf  # s, next re-check of the plan under way
        self.outcomes = {"replan": 0, "abort": 0, "brake": 0}  # re-check outcomes
        self.wall = 0.0

    # ------------------------------------------------------------------ the step
    def status(self, sv: SVState) -> PolicyStatus:
        lc = self.active
        return PolicyStatus(
            target_lane=None if lc is None else lc.target_lane, changing=lc is not None,
            manoeuvring=lc is not None, leader_gap=self.following.leader_gap,
            idm_accel=self.following.accel if lc is None else math.nan)

    def update(self, t: float, scene: Scene, messages: Messages) -> LaneChangeTrajectory:
        """Finish a manoeuvre that is over, ask for a lane change or re-check the one
        under way; returns the reference to track from t."""
        sv = scene.sv
        lc = self.active
        if lc is not None and t >= lc.t0 + lc.tau - 1e-9:
            self.active = None
            self.mode = KEEPING
            self.following.v_ref = float(lc.trajectory.vxf)
            self.following.v_cruise = self.following.v_ref
            self.timer.manoeuvre_done(t)
            self.blinker(0)
        if self.mode == WAITING and self.timer.may_request(t, decision=False):
            self.mode = KEEPING
        # no lane change is planned below PLANNER_MIN_SPEED (stop-and-go: the SV keeps
        # its lane in a queue)
        free = self.active is None and sv.vx >= PLANNER_MIN_SPEED
        target, trigger = self.request(t, sv, scene,
                                       free and self.timer.may_request(t, decision=False),
                                       free and self.timer.may_request(t))
        if target is not None:
            self.plan(t, sv, target, trigger, messages.read())
        elif self.mode == CHANGING and self.replanning and t >= self.next_check - 1e-9:
            self.recheck(t, messages.read())
        if self.active is not None:
            return self.active.trajectory
        return self.following.reference(t, sv)

    def request(self, t: float, sv: SVState, scene: Scene, allow_scripted: bool,
                allow_decision: bool) -> tuple[int | None, str]:
        """Car-following for this step, and a lane change wanted now (a due scripted
        request first, else the decision rule): (target lane, trigger) or (None, "")."""
        d = self.following.update(sv, scene, allow_decision)
        if not allow_scripted:
            return None, ""
        target = self.due_scripted(t, sv)
        if target is not None:
            return target, "scripted"
        if allow_decision and d.target_lane is not None:
            return d.target_lane, "decision"
        return None, ""

    def due_scripted(self, t: float, sv: SVState) -> int | None:
        """The lane of the first due scripted request (in time order; one already
        satisfied is dropped, one to a lane not adjacent is logged and dropped)."""
        lane = self.road.lane_of(sv.y)
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

    def plan(self, t: float, sv: SVState, target: int, trigger: str,
             messages: list[Any]) -> None:
        """Ask the planner for a lane change to `target`; adopt the plan (changing), or
        keep the lane and ask again after `retry_interval` (waiting)."""
        from cosim.planning.planner import SVPlanState

        lane = self.road.lane_of(sv.y)
        # the paper's boundary conditions (x'' = y' = y'' = 0 at the start): the SV plans
        # only while keeping its lane, where these are ~0; the measured values carry
        # the plant's transients (at t = 0: drag with no force yet) into the plan
        state = SVPlanState(x=sv.x, y=sv.y, heading=sv.heading, vx=sv.vx, ax=0.0, vy=0.0,
                            ay=0.0, lane=lane)
        if trigger != "decision" and self.last_failed == (lane, target):
            trigger = "retry"
        if trigger != "retry":
            self.requests += 1
        w0 = time.perf_counter()
        plan, why = self.call_planner(t, state, target, messages)
        self.wall += time.perf_counter() - w0
        row = plan_row(plan, trigger, state.vx)
        if why:
            row.update(ok=0, rejections=why)
        self.plans.append(row)
        if self.first_plan is None:
            self.first_plan = plan
        if plan.trajectory is None or why:
            self.timer.planning_failed(t)
            self.last_failed = (lane, target)
            self.mode = WAITING
            return
        self.last_failed = None
        if trigger != "decision" and self.pending:
            self.pending.pop(0)
        self.active = LaneChange(
            t0=t, tau=float(plan.tau), origin_lane=lane, target_lane=target,
            y_target=self.road.lane_center(target), trajectory=plan.trajectory, plan=plan,
            trigger=trigger, start_lane=lane, wanted_lane=target,
        )
        self.lane_changes.append(self.active)
        self.mode = CHANGING
        self.blinker(1 if target > lane else -1)
        self.next_check = t + self.recheck_interval

    def call_planner(self, t: float, state: Any, target: int, messages: list[Any]
                     ) -> tuple[Any, str]:
        """The planner's plan for a change to `target` from `state`, and why it is not
        to be flown although it has a trajectory ("": fly it if it has one)."""
        return self.planner.plan(t, state, target, messages, self.occupant), ""

    # ------------------------------------------------------------------ replanning
    def recheck(self, t: float, messages: list[Any]) -> None:
        """Beyond the paper (S2): re-check the rest of the plan under way against fresh
        predictions; if it now collides, replan to the target lane from the reference's
        state at t, else abort to the origin lane, else brake in the nearest lane."""
        lc = self.active
        assert lc is not None
        self.next_check = t + self.recheck_interval
        w0 = time.perf_counter()
        rejection = self.planner.check(lc.trajectory, t, messages)
        self.wall += time.perf_counter() - w0
        if rejection is None:
            return
        when = math.nan if rejection.time is None else rejection.time
        reason = f"re-check: collision with {rejection.vehicle_id} at {when:.2f} s"
        frm, to = lc.origin_lane, lc.target_lane
        state = reference_state(lc.trajectory, t, frm)
        w0 = time.perf_counter()
        # continuing keeps the driver's intent, so it is tried first; the abort only
        # when no collision-free tau to the target lane is left
        again = self.planner.plan(t, state, to, messages, self.occupant)
        back = None
        if again.trajectory is None:
            back = self.planner.plan(t, replace(state, lane=to), frm, messages, self.occupant)
        self.wall += time.perf_counter() - w0
        if again.trajectory is not None:
            kind, plan, trajectory = "replan", again, again.trajectory
        elif back is not None and back.trajectory is not None:
            kind, plan, trajectory = "abort", back, back.trajectory
        else:
            kind, plan = "brake", back if back is not None else again
            trajectory = self.brake_trajectory(t, lc, plan)
        self.outcomes[kind] += 1
        row = plan_row(plan, kind, state.vx)
        row.update(reason=reason)
        if kind == "brake":
            self.mode = BRAKING
            self.next_check = math.inf  # the last resort: not re-checked into another one
            row.update(tau_s=trajectory.tau, ok=1,
                       target_lane=self.road.lane_of(trajectory.y_final))
        self.plans.append(row)
        lc.trajectory = trajectory
        lc.plan = plan
        lc.tau = trajectory.t_end - lc.t0
        end_lane = self.road.lane_of(trajectory.y_final)
        if end_lane != to:  # heading back: the manoeuvre now leaves `to` for `end_lane`
            lc.origin_lane, lc.target_lane = to, end_lane
            lc.y_target = self.road.lane_center(end_lane)
            self.blinker(1 if end_lane > to else -1)
        was_aborted = lc.aborted
        lc.aborted = lc.target_lane == lc.start_lane  # back where it started: no lane change
        if lc.aborted and not was_aborted and lc.trigger in ("scripted", "retry"):
            # ask again once back in the lane
            self.pending.insert(0, LaneChangeCommand(at=t, target_lane=lc.wanted_lane))

    def brake_trajectory(self, t: float, lc: LaneChange, plan: Any) -> LaneChangeTrajectory:
        """Neither replan nor abort is collision-free: brake (within BRAKE_GRIP mu g at the
        quartic's peak) while steering to the nearest lane centre, from the reference's
        state at t (eq. 2 / eq. 4 with general start values)."""
        st = reference_state(lc.trajectory, t, lc.origin_lane)  # lane unused here
        lane = self.road.lane_of(st.y)
        tau = plan.tau_min if math.isfinite(plan.tau_min) else BRAKE_TAU
        tau = max(tau, BRAKE_TAU_MIN)
        # the quartic from a = ax0 to a(tau) = 0 peaks at about 1.5x its mean deceleration
        decel = BRAKE_GRIP * self.road.mu * G / 1.5
        vxf = max(st.vx - decel * tau, 0.0)
        return LaneChangeTrajectory(
            t0=t, tau=tau, x0=st.x, y0=st.y, vx0=st.vx, vxf=vxf,
            width=self.road.lane_center(lane) - st.y, ax0=st.ax, vy0=st.vy, ay0=st.ay,
        )

    # ------------------------------------------------------------------ the run
    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
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


class SumoDriverPolicy:
    """The SUMO-driven SV's: scripted requests become `change_lane(target)` calls (with
    SUMO's safety checks), SUMO's own lane-change model decides the rest (`[sv]
    decision`); the car-following values are computed for the trace only."""

    name = "sumo"
    listens = False

    def __init__(self, scenario: Scenario, road: RoadParams, cfg: DecisionConfig,
                 change_lane: Callable[[int], None]) -> None:
        self.road = road
        self.change_lane = change_lane
        self.decision = scenario.sv.decision
        self.following = CarFollowing(scenario, road, cfg)
        self.pending = list(scenario.sv.lane_changes)
        self.plans: list[dict[str, Any]] = []
        self.requests = 0
        self.wall = 0.0

    def status(self, sv: SVState) -> PolicyStatus:
        # no plan: moving sideways is its lane change
        return PolicyStatus(target_lane=None, changing=False,
                            manoeuvring=abs(sv.vy) > SIDEWAYS_SPEED,
                            leader_gap=self.following.leader_gap,
                            idm_accel=self.following.accel)

    def update(self, t: float, scene: Scene, messages: Messages) -> None:
        sv = scene.sv
        lane = self.road.lane_of(sv.y)
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending.pop(0).target_lane
            if target == lane:
                continue
            self.requests += 1
            self.change_lane(target)
            self.plans.append(request_row(t, lane, target, sv.vx, 1))
            break
        # the gap to the leader, for the trace (SUMO's own model follows it)
        self.following.v_ref = sv.vx
        self.following.update(sv, scene, allow_change=False)

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        """Lane changes read off the path; with `[sv] decision` SUMO's own model decided,
        and each change it made beyond the scripted ones was its request."""
        starts, targets, ends = excursions(t, y, self.road)
        requests = self.requests
        if self.decision:
            requests += max(len(starts) - self.requests, 0)
        return Manoeuvres(
            lane_changes=[], starts=starts, targets=targets, ends=ends, requests=requests,
            planner_calls=0, outcomes={"replan": 0, "abort": 0, "brake": 0},
            first_start=None, plans=self.plans)


POLICIES: dict[str, type[PaperPolicy]] = {"paper": PaperPolicy}  # name -> lane-change policy
