"""The re-check of the plan under way and what follows when it fails (beyond the paper,
S2; `[planner] replanning`): every `recheck_interval` the rest of the plan is checked
against fresh predictions; when it now collides, the SV

1. replans to the target lane from the reference's state (continuing keeps its intent,
   so it is tried first; out of a lane that ends, the replan ends before the end too),
2. else aborts to the origin lane (not back into a lane whose change has been due:
   cosim.driving.lane_end `SVLaneEnds.was_due`),
3. else brakes, the last resort: while steering to the nearest lane centre, at the
   gentlest of BRAKE_DECELS the re-check passes, else within BRAKE_GRIP mu g; in a lane
   that ends, to a stop before its stop line when it can (`brake_to_stop`). A gentle
   brake is re-checked in turn (and replaced by the gentlest that passes then); the
   grip's is not.

Each new plan starts from the reference's state, not the plant's (`reference_state`): it
continues the reference without a jump, and the controller's errors carry over.

A collision far ahead with a TV the SV closes on slowly does not replace the plan
(`clear_ahead`); under the gap policy (`GapRecheck`) neither does one with such a TV
that brakes while the SV can still stop behind it (`stops_behind`) nor one with a TV
that only signals toward the lane SUMO's driver already sees the SV in
(`unseen_signal`), and a replan keeps the change's end speed, else ends behind a slower
TV cutting in ahead at its speed (`behind_speed`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from cosim.driving.lane_end import (
    MERGE_PEAK_ACCEL,
    STOP_DECEL,
    SVLaneEnds,
    comfortable_speed,
    stop_gap,
)
from cosim.driving.layout import LaneLayout
from cosim.driving.plans import RESCUES, PlannerCalls, Trigger, plan_row
from cosim.params import G
from cosim.planning.deadline import END_MARGIN, LaneEnd
from cosim.planning.trajectory import LaneChangeTrajectory

if TYPE_CHECKING:
    from cosim.planning.planner import SVPlanState

BRAKE_GRIP = 0.7  # -, share of mu g an emergency brake (no replan, no abort) may use
BRAKE_DECELS = (1.0, 2.0, 3.0)  # m/s^2, mean decelerations of a brake tried before the
# grip's, the gentlest the re-check passes first: a collision predicted seconds ahead
# rarely needs the grip's braking
# tuned: docs/tuned_constants.md
CLEAR_AHEAD = 2.0  # s, a collision the re-check predicts at least this far ahead with a
# TV ahead of the SV that the SV closes on slowly enough (CLEAR_DECEL) and that is not
# braking leaves the plan under way alone: the plan's check extrapolates the SV at its
# end speed, but its car following keeps it behind that TV once the change ends, and
# the next re-check sees the TV if it starts braking (a merge braked at 3.4 m/s^2 over a
# TV 24-31 m ahead that nobody was closing on; re-checks replanned, aborted and braked
# over collisions predicted 6-11 s ahead)
# tuned: docs/tuned_constants.md
CLEAR_DECEL = 1.0  # m/s^2, the constant braking that matches the TV's speed within the
# gap left when the plan ends, at most this (0 for a TV not slower than the SV)
CLEAR_MIN_GAP = 2.5  # m, bumper gap kept to that TV (SUMO's minGap)
CLEAR_BRAKING = 0.5  # m/s^2, that TV braking harder than this closes the gap, unless ...
CLEAR_STOP_DECEL = 3.0  # m/s^2, ... (the gap policy's re-check) the SV, braking at this
# from the next re-check on, still stops CLEAR_MIN_GAP behind it braking on as measured
# (`stops_behind`): SUMO's drivers' measured acceleration swings by +-2 m/s^2 from step
# to step in dense traffic, and kept for seconds it made a leader 12 m ahead at the
# SV's speed a collision 3.4 s away (merge study, 40 veh/km/lane: 10 replans and 3
# emergency brakes over such leaders); one braking on is seen at the next re-check
# tuned: docs/tuned_constants.md
SEEN_AHEAD = 1.0  # s, a collision with a TV that only signals, predicted this long after
# SUMO's driver sees the SV in the lane it signals for, does not replace the plan
# (`unseen_signal`; SUMO's driver acts the step after it sees the SV, and a change it
# began unseen shows as lateral motion at the next re-check, 0.1 s later)
# tuned: docs/tuned_constants.md
STOP_SAMPLES = 64  # samples of `stops_behind`'s comparison
SEEN_STEP = 0.05  # s, the sampling of the plan for when its body enters the lane
BRAKE_TAU = 3.0  # s, emergency brake's duration when the planner gave no tau_min
BRAKE_TAU_MIN = 1.5  # s, shortest emergency brake (lateral move to the nearest centre)


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


class UnderWay(Protocol):
    """The manoeuvre under way as the re-check reads it (cosim.driving.manoeuvre.LaneChange)."""

    origin_lane: int
    target_lane: int
    trajectory: LaneChangeTrajectory
    plan: Any


@dataclass(frozen=True)
class Rescue:
    """What replaces a plan under way that the re-check found colliding."""

    kind: Trigger  # REPLAN | ABORT | BRAKE
    plan: Any  # the planner's Plan it came from
    trajectory: LaneChangeTrajectory
    row: dict[str, Any]  # its plans.csv row
    gentle: bool = False  # a brake gentler than the grip's (re-checked in turn)


class Recheck:
    """When the plan under way is re-checked (`due`, `schedule`), what a failed re-check
    gives (`run`: the module docstring's steps), and how often each outcome came."""

    def __init__(self, calls: PlannerCalls, ends: SVLaneEnds, lanes: LaneLayout, mu: float,
                 interval: float, enabled: bool, sv_length: float = 0.0,
                 gap_rules: GapRecheck | None = None, merge_time: float | None = None
                 ) -> None:
        self.calls, self.ends, self.lanes, self.mu = calls, ends, lanes, mu
        self.merge_time = merge_time  # s, a merge's comfortable end speed assumes this
        # duration (None: no comfort bound; cosim.driving.lane_end.SVLaneEnds.limits)
        self.sv_length = sv_length  # m
        self.gap_rules = gap_rules  # the gap policy's (None: the paper's re-check)
        self.interval = interval  # s, between re-checks
        self.enabled = enabled  # [planner] replanning
        self.next_check = math.inf  # s, the next re-check of the plan under way
        self.outcomes = dict.fromkeys(RESCUES, 0)  # re-check outcomes

    def due(self, t: float) -> bool:
        return self.enabled and t >= self.next_check - 1e-9

    def schedule(self, t: float) -> None:
        """A plan was adopted at t: its first re-check is one interval later."""
        self.next_check = t + self.interval

    def run(self, t: float, lc: UnderWay, messages: list[Any], braking: bool
            ) -> Rescue | None:
        """Re-check the rest of `lc` at t; None while it is collision-free, else what
        replaces it (`braking`: `lc` is a gentle brake already, braked anew)."""
        self.next_check = t + self.interval
        rejection = self.calls.check(lc.trajectory, t, messages)
        g = self.gap_rules
        stop_decel = None if g is None else g.stop_decel
        if rejection is None or clear_ahead(t, lc.trajectory, rejection, messages,
                                            self.sv_length, stop_decel, self.interval):
            return None
        if g is not None and unseen_signal(t, lc.trajectory, rejection, messages, self.lanes,
                                           lc.target_lane, g.sv_width):
            return None
        when = math.nan if rejection.time is None else rejection.time
        reason = f"re-check: collision with {rejection.vehicle_id} at {when:.2f} s"
        if braking:
            rescue = self.brake(t, lc, lc.plan, messages, reason)
        else:
            rescue = self.replan_or_abort(t, lc, messages, reason, rejection)
        self.outcomes[rescue.kind] += 1
        if rescue.kind == Trigger.BRAKE:
            self.next_check = t + self.interval if rescue.gentle else math.inf
        return rescue

    def replan_or_abort(self, t: float, lc: UnderWay, messages: list[Any], reason: str,
                        rejection: Any = None) -> Rescue:
        """A replan to the target lane, else an abort to the origin lane, else a brake.
        Under the gap policy a replan that keeps the end speed and collides is tried
        again behind the TV of `rejection` (the re-check's collision) at that TV's speed
        when it is ahead of the SV and slower (`behind_speed`): SUMO's driver that cuts
        in ahead of a change under way is followed, as a leader is."""
        frm, to = lc.origin_lane, lc.target_lane
        state = reference_state(lc.trajectory, t, frm)
        frm_end = self.ends.ahead(frm, state.x, state.vx)
        # the gap policy's replan keeps the change's end speed (its new leader's; the
        # band rule's instead made a new follower, let in at the gap's speed, brake 4.5
        # m/s^2 behind an SV that then drove 5 m/s slower)
        vxf = (float(lc.trajectory.vxf) if self.gap_rules is not None
               and self.gap_rules.keep_end_speed else None)
        x_limit = self.ends.x_limit(frm_end)
        accel = math.inf
        merge_time = self.merge_time
        if merge_time is not None and self.ends.was_due(frm, frm_end):
            # a merge: its end speed within comfortable reach, as planned (lane_end)
            wanted = self.lanes.end_speed(frm, to) if vxf is None else vxf
            vxf = min(wanted, comfortable_speed(state.vx, merge_time))
            accel = MERGE_PEAK_ACCEL
        again = self.calls.plan(t, state, to, messages, vxf=vxf, x_limit=x_limit, accel=accel)
        if again.trajectory is None and vxf is not None and rejection is not None:
            slower = behind_speed(state.x, vxf, rejection, messages, self.sv_length)
            if slower is not None:
                behind = self.calls.plan(t, state, to, messages, vxf=slower, x_limit=x_limit,
                                         accel=accel)
                if behind.trajectory is not None:
                    again = behind
        back = None
        if again.trajectory is None and not self.ends.was_due(frm, frm_end):
            # the gap policy's abort returns to the lane the SV was just in, whose traffic
            # it is in step with: no faster than it drives now (the band rule's speed, the
            # lane's limit, had a fleet's AV aborting in a queue at 6 m/s plan to end at
            # 25, speed up at 6 m/s^2 and run into the queue)
            back_vxf = (min(self.lanes.end_speed(to, frm), state.vx)
                        if self.gap_rules is not None and self.gap_rules.abort_no_faster
                        else None)
            back = self.calls.plan(t, replace(state, lane=to), frm, messages, vxf=back_vxf)
        if again.trajectory is not None:
            kind, plan = Trigger.REPLAN, again
        elif back is not None and back.trajectory is not None:
            kind, plan = Trigger.ABORT, back
        else:
            return self.brake(t, lc, back if back is not None else again, messages, reason)
        row = plan_row(plan, kind, state.vx)
        row.update(reason=reason)
        return Rescue(kind, plan, plan.trajectory, row)

    def brake(self, t: float, lc: UnderWay, plan: Any, messages: list[Any], reason: str
              ) -> Rescue:
        """The last resort: brake while steering to the nearest lane centre, from the
        reference's state at t (eq. 2 / eq. 4 with general start values): the gentlest of
        BRAKE_DECELS (mean decelerations) that the re-check passes, else within
        BRAKE_GRIP mu g at the quartic's peak."""
        st = reference_state(lc.trajectory, t, lc.origin_lane)  # lane unused here
        lane = self.lanes.lane_of(st.y)
        base_tau = max(plan.tau_min if math.isfinite(plan.tau_min) else BRAKE_TAU,
                       BRAKE_TAU_MIN)
        # the quartic from a = ax0 to a(tau) = 0 peaks at about 1.5x its mean deceleration
        grip = BRAKE_GRIP * self.mu * G / 1.5
        end = self.ends.ahead(lane, st.x, st.vx)
        centre = self.lanes.centre(lane)
        trajectory, gentle = None, False
        for decel in (d for d in BRAKE_DECELS if d < grip):
            tried, stops = brake_reference(t, st, centre, base_tau, decel, end)
            if not stops:
                continue  # a lane that ends: only a brake that still stops before its end
            if self.calls.check(tried, t, messages) is None:
                trajectory, gentle = tried, True
                break
        if trajectory is None:
            trajectory = brake_reference(t, st, centre, base_tau, grip, end)[0]
        row = plan_row(plan, Trigger.BRAKE, trajectory.vx0)
        row.update(reason=reason, tau_s=trajectory.tau, ok=1,
                   target_lane=self.lanes.lane_of(trajectory.y_final))
        return Rescue(Trigger.BRAKE, plan, trajectory, row, gentle)


@dataclass(frozen=True)
class GapRecheck:
    """The gap policy's re-check rules (`Recheck`'s gap_rules)."""

    sv_width: float  # m, the SV's body width (when SUMO's drivers see it in a lane)
    keep_end_speed: bool = True  # a replan ends at the plan's end speed (the new
    # leader's), not the band rule's
    abort_no_faster: bool = True  # an abort ends at most at the SV's speed at the abort
    stop_decel: float | None = CLEAR_STOP_DECEL  # m/s^2, a braking TV ahead is clear
    # while the SV can stop behind it at this (`clear_ahead`; None: never)


def unseen_signal(t: float, trajectory: LaneChangeTrajectory, rejection: Any,
                  messages: list[Any], lanes: LaneLayout, target_lane: int,
                  sv_width: float) -> bool:
    """Whether the collision a re-check at t found is with a TV that only signals a
    change into `target_lane` (its blinker, no lateral motion yet) and is predicted
    SEEN_AHEAD or more after SUMO's driver sees the SV's body in that lane: SUMO's
    driver changes only into a gap secure behind and ahead of it, so it does not cut
    into the SV it sees there (the prediction starts its change now, whatever the SV
    does); the next re-check sees its lateral motion if it starts before. Such a
    collision does not replace the plan (two TVs signalling from the lane the SV was
    leaving, passed at 6 m/s, turned a merge's later change into a replan and an
    emergency brake of 3.9 m/s^2)."""
    when, tv_id = rejection.time, rejection.vehicle_id
    if when is None or tv_id is None:
        return False
    tv = next((m for m in messages if m.vehicle_id == tv_id), None)
    if tv is None or tv.intention == 0 or tv.motion is not None:
        return False
    if lanes.lane_of(tv.y) + int(tv.intention) != target_lane:
        return False
    # when the SV's body first touches the target lane (SUMO's drivers see it there)
    times = np.arange(t, max(trajectory.t_end, t) + 1e-9, SEEN_STEP)
    _, y = trajectory.position(times)
    lo, hi = lanes.lanes_touched(np.asarray(y, dtype=float), 0.5 * sv_width)
    inside = np.flatnonzero((lo <= target_lane) & (hi >= target_lane))
    return inside.size > 0 and when - float(times[inside[0]]) >= SEEN_AHEAD


def clear_ahead(t: float, trajectory: LaneChangeTrajectory, rejection: Any,
                messages: list[Any], sv_length: float, stop_decel: float | None = None,
                interval: float = 0.0) -> bool:
    """Whether the collision a re-check at t found for the plan under way (`rejection`:
    the TV and the time) is with a TV ahead of the SV, CLEAR_AHEAD or more away, that
    the SV closes on slowly enough to match its speed at CLEAR_DECEL once the plan ends
    (CLEAR_AHEAD's comment; the TV as its message has it, kept at its speed, the SV as
    the plan's reference), and that is not braking harder than CLEAR_BRAKING, or (with
    `stop_decel`, m/s^2) brakes so that the SV, braking at `stop_decel` from the next
    re-check on (`interval`, s), still stops behind it (`stops_behind`): then it does
    not replace the plan."""
    when, tv_id = rejection.time, rejection.vehicle_id
    if when is None or when - t < CLEAR_AHEAD or tv_id is None:
        return False
    tv = next((m for m in messages if m.vehicle_id == tv_id), None)
    if tv is None:
        return False
    t_end = max(trajectory.t_end, t)
    x_now, _ = trajectory.position(t)
    x_end, _ = trajectory.position(t_end)
    half = 0.5 * (tv.length + sv_length)
    gap_now = tv.x - float(x_now) - half
    if gap_now < CLEAR_MIN_GAP:
        return False
    if tv.accel < -CLEAR_BRAKING and (stop_decel is None or not stops_behind(
            gap_now, max(float(trajectory.derivative(t, 1)[0]), float(trajectory.vxf)),
            tv.speed, -tv.accel, stop_decel, interval)):
        return False
    room = tv.x + tv.speed * (t_end - t) - float(x_end) - half - CLEAR_MIN_GAP
    closing = float(trajectory.vxf) - tv.speed
    if room <= 0.0:
        return False
    return closing <= 0.0 or closing * closing / (2.0 * room) <= CLEAR_DECEL


def behind_speed(sv_x: float, vxf: float, rejection: Any, messages: list[Any],
                 sv_length: float) -> float | None:
    """m/s, the speed of the TV a re-check found a collision with when it is ahead of
    the SV's centre `sv_x` (m) by CLEAR_MIN_GAP or more (bumper) and slower than the
    plan's end speed `vxf` (m/s); else None."""
    tv = next((m for m in messages if m.vehicle_id == rejection.vehicle_id), None)
    if tv is None or tv.speed >= vxf - 1e-6 or tv.speed <= 0.0:
        return None
    if tv.x - sv_x - 0.5 * (tv.length + sv_length) < CLEAR_MIN_GAP:
        return None
    return float(tv.speed)


def stops_behind(gap: float, sv_speed: float, tv_speed: float, tv_decel: float,
                 sv_decel: float, reaction: float) -> bool:
    """Whether an SV at `sv_speed` (m/s) `gap` (m, bumper) behind a TV at `tv_speed`
    braking at `tv_decel` (m/s^2) to a standstill stays CLEAR_MIN_GAP or more behind it
    when it keeps its speed for `reaction` (s) and then brakes at `sv_decel` to a
    standstill (both sampled STOP_SAMPLES times until both stand)."""
    s = np.linspace(0.0, max(reaction + sv_speed / sv_decel, tv_speed / tv_decel),
                    STOP_SAMPLES)
    t_tv = np.minimum(s, tv_speed / tv_decel)
    tv_x = tv_speed * t_tv - 0.5 * tv_decel * t_tv * t_tv
    braking = np.clip(s - reaction, 0.0, sv_speed / sv_decel)
    sv_x = sv_speed * (np.minimum(s, reaction) + braking) - 0.5 * sv_decel * braking * braking
    return bool((gap + tv_x - sv_x >= CLEAR_MIN_GAP).all())


def brake_to_stop(vx: float, ax: float, tau: float, vxf: float, decel: float,
                  end: LaneEnd) -> tuple[float, float, bool]:
    """(tau, vxf) of a brake in a lane that ends, and whether the SV then stops with its
    front at the stop line before the end (`lane_end.stop_gap`; braking on at STOP_DECEL
    after it): the brake's own (tau, vxf) when it does, else a brake to a standstill
    that ends at the stop line if `decel` allows, at most at `decel` (then as far as it
    must, and past the line). A quartic from ax0 with a(tau) = 0 travels
    (vx0 + vxf) tau / 2 + ax0 tau^2 / 12."""
    room = stop_gap(end)  # m, front to the stop line

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
