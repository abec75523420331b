"""The gap-seeking lane-change policy ("gap", `[planner] policy = "gap"`; beyond the
paper): the manoeuvre of the paper's SV (cosim.driving.manoeuvre: keeping / changing /
braking / waiting, re-check, replan / abort / brake) with another way of keeping
its lane and of deciding when to plan.

While keeping its lane the SV follows cosim.driving.gap.decision each step: it wants a lane
(a due scripted request, or the decision rule's faster lane, held for WANT_HOLD
while it is still in the lane it wanted to leave), picks a gap there and drives the
speed that takes it into it (never faster than its own leader allows). It calls the
planner only once a change started now enters a usable gap (the decision's entry test;
and at >= cosim.driving.manoeuvre.PLANNER_MIN_SPEED), with the new leader's speed as
vxf; a plan is flown only if its new follower, predicted as SUMO's Krauss follows
(cosim.planning.interaction.check_follower), brakes no harder than
`GapConfig.plan_decel` (`insist_decel` once it has sought a gap for
`GapConfig.patience`), else it counts as a failed plan (a scripted change may count
on the TVs that yield to it braking on until it is in their lane: their courtesy held,
`GapConfig.hold_after`, cosim.driving.gap.yielding)
and its follower is asked to make room (retried after
`retry_interval`, the approach going on). It stops behind a standing leader at
STOP_GAP (IDM standstill gap). It signals while it seeks a gap, and asks the chosen
gap's follower to open the gap (the context's `ask_gap` port: the traffic's courtesy
and cooperative V2V, cosim.traffic.cooperation). Its planner predicts a C2 TV to end
its change no faster than its new leader, as this SV does (`prediction`).

On a lane that ends (cosim.driving.lane_end) it stops before the end (a virtual
standing leader) and, once the end is within its look-ahead, seeks a gap in the
continuing lane before anything else ("mandatory"), with the urgency law of
cosim.driving.gap.decision (what it may ask of its new follower grows as the end
nears, and only so: it does not insist after its patience) and from any speed
(`mandatory_config`); every plan ends before the end. It
signals and asks the blocking follower to make room as for any change. On the
mainline it lets a TV that must merge ahead of it in (`lane_end.yield_accel`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from cosim.driving.base import DrivingContext, Manoeuvres, Messages, PolicyStatus
from cosim.driving.following import CarFollowing
from cosim.driving.gap.decision import GapDecision, gap_decision, in_lane, mandatory_config
from cosim.driving.gap.geometry import GapConfig
from cosim.driving.gap.yielding import YieldWatch
from cosim.driving.lane_end import stop_gap, yield_accel
from cosim.driving.manoeuvre import MANDATORY, LaneChangeTimer, Manoeuvre
from cosim.driving.registry import register
from cosim.driving.view import TrafficView
from cosim.planning.interaction import FollowerModel, check_follower
from cosim.planning.planner import PredictionOptions

if TYPE_CHECKING:
    from cosim.driving.manoeuvre import LaneChange
    from cosim.planning.planner import Plan
    from cosim.planning.trajectory import LaneChangeTrajectory
    from cosim.traffic.world import Scene, SVState

WANT_HOLD = 20.0  # s, a lane the decision rule wanted is sought this long at most
STOP_GAP = 2.5  # m, IDM standstill gap s0 of this policy (SUMO's minGap; >= 2 m in a queue)
COOLNESS = 0.99  # -, its car following is the ACC model (IDM + CAH, rule.acc_blend): after
# a merge into a slot of GapConfig.headway it reopens its 1.5 s gap braking about the
# IDM's b = 2 m/s^2 at most while the new leader keeps its speed (plain IDM: up to 8)
TIME_GAP = 1.0  # s, its IDM time gap T: SUMO's drivers' tau (the paper's rule: 1.5 s), so
# that after a merge into a slot of GapConfig.headway it reopens less and makes its new
# follower brake less (issue 22)
RETRY = 0.1  # s, a plan refused although the entry test passed is asked for again this soon
# (DecisionConfig.retry_interval, 1 s, cost 1 s from request to lane each time: the entry
# test's nominal manoeuvre and the planned one differ a little, e.g. 1.47 against 1.0
# m/s^2 for the same follower at 10 veh/km/lane; issue 22)


@register("gap")
class GapPolicy:
    """The module docstring's policy; `gap` and `follower` are its gap choice's settings
    and the model of the TVs that follow (SUMO's Krauss by default)."""

    listens = True
    needs_planner = True
    asks_for_gaps = True
    prediction = PredictionOptions(gap_end_speed=True)

    def __init__(self, ctx: DrivingContext, gap: GapConfig | None = None,
                 follower: FollowerModel | None = None) -> None:
        cfg = replace(ctx.decision, idm_min_gap=max(ctx.decision.idm_min_gap, STOP_GAP),
                      idm_coolness=COOLNESS, idm_time_gap=TIME_GAP,
                      retry_interval=min(ctx.decision.retry_interval, RETRY))
        self.lanes = ctx.lanes
        self._ask_gap = ctx.ports.ask_gap
        self.yielding = YieldWatch()  # the braking of the TVs asked to make room
        self.held: LaneChange | None = None  # the change flown on the courtesy held
        self._blinker = ctx.ports.blinker
        self.signal = 0  # the SV's blinker now: -1 right, 0 off, +1 left
        self.following = CarFollowing(ctx, cfg)
        self.manoeuvre = Manoeuvre(ctx, LaneChangeTimer(cfg), self._signal)
        self.gap_cfg = gap or GapConfig()
        self.follower = follower or FollowerModel()
        # what a flown plan may ask of its new follower: the policy's own limit within b_safe
        self.plan_follower = self.follower.limited(self.gap_cfg.plan_decel)
        self.sv_length = ctx.sv_length
        self.lanes_end = any(math.isfinite(self.lanes.end(k))
                             for k in range(self.lanes.n_lanes))  # a lane ends on this road
        self.decision = ctx.sv.decision
        self.wanted: tuple[int, int, float] | None = None  # (origin, target, until t)
        self.last: GapDecision | None = None  # this step's decision (for inspection)
        self.seeking_since: float | None = None  # s, since when it seeks a gap (None: not)

    @property
    def wall(self) -> float:
        return self.manoeuvre.wall

    def _signal(self, direction: int) -> None:
        """The blinker, set in SUMO only when it changes."""
        if direction != self.signal:
            self.signal = direction
            self._blinker(direction)

    def ask_gap(self, t: float, tv_id: str) -> None:
        """Ask `tv_id` to make room (the context's port) and, if a channel carries the
        request, watch how it brakes."""
        if self._ask_gap(t, tv_id):
            self.yielding.asked(tv_id)

    def status(self, sv: SVState) -> PolicyStatus:
        status = self.manoeuvre.status(self.following.leader_gap, self.following.accel)
        lc = self.manoeuvre.active
        if lc is None or lc is not self.held or self.lanes.lane_of(sv.y) == lc.target_lane:
            return status
        return replace(status, courtesy_held=True)

    def update(self, t: float, scene: Scene, messages: Messages) -> LaneChangeTrajectory:
        """Finish a manoeuvre that is over; car-following toward the chosen gap; plan the
        change once the gap is reached, or re-check the one under way."""
        sv, m = scene.sv, self.manoeuvre
        ended = m.begin(t)
        if ended is not None:
            self.following.resume(float(ended.trajectory.vxf))
        allow_scripted, allow_decision = m.may_request(t, sv)
        if m.active is not None:  # changing: car-following values for the trace only
            self.following.update(sv, scene, False)
            trajectory = m.advance(t, sv, None, "", messages)
        else:
            traffic = TrafficView.of(scene)
            d, trigger = self.seek(t, sv, traffic, allow_scripted, allow_decision)
            target = d.target_lane if trigger else None
            trajectory = m.advance(
                t, sv, target, trigger, messages,
                vxf=d.vxf if math.isfinite(d.vxf) else None,
                accept=lambda plan: self.accept(t, plan, target, traffic))
            self.held = m.active if d.held is not None else None
        return trajectory if trajectory is not None else self.following.reference(t, sv)

    def seek(self, t: float, sv: SVState, traffic: TrafficView, allow_scripted: bool,
             allow_decision: bool) -> tuple[GapDecision, str]:
        """Car-following toward the chosen gap this step; the decision, and the trigger
        once the gap is reached ("scripted" | "decision"; "": do not plan now)."""
        following, m = self.following, self.manoeuvre
        lane = self.lanes.lane_of(sv.y)
        end = m.lane_end(lane, sv)  # its lane ends ahead: stop before it, change lanes
        due = None if end is None else m.mandatory(lane, sv)
        mandatory = due is not None
        scripted = m.due_scripted(t, sv)
        if self.wanted is not None and (self.wanted[0] != lane or t > self.wanted[2]):
            self.wanted = None
        wanted = scripted if scripted is not None else (
            self.wanted[1] if self.wanted is not None else None)
        if due is not None:
            wanted = due.target
        since = self.seeking_since
        braking = self.yielding.braking(t, traffic.ids, traffic.speed)
        # a mandatory change's settings (`mandatory_config`: it never insists after a
        # patience, what it asks grows with its urgency alone)
        gap_cfg = mandatory_config(self.gap_cfg) if mandatory else self.gap_cfg
        insist = since is not None and t - since >= gap_cfg.patience - 1e-9
        # only a requested change counts on the courtesy held: a change by choice waits
        # for a gap that asks nothing more (in the stop-and-go run one taken at 6 m/s on
        # it left the queue it had to stop in), a mandatory one has its urgency law
        held = (scripted is not None and not mandatory and since is not None
                and t - since >= gap_cfg.hold_after - 1e-9)
        # a lane by choice is sought only once the last change has settled (its
        # cooldown): seeking at once asked the next lane's follower for courtesy and
        # braked toward its gaps within 3 s of a merge, and the TV behind the SV, which
        # SUMO keeps from passing a slower car on its left, braked with it (2.4-2.6
        # m/s^2 in 5 of 20 merges at 10 veh/km/lane, issue 24)
        by_choice = self.decision and not m.timer.cooling(t)
        d = gap_decision(following.view(sv), traffic, self.lanes, following.cfg, gap_cfg,
                         self.follower, wanted_lane=wanted,
                         allow_change=mandatory or scripted is not None or by_choice,
                         insist=insist, urgency=0.0 if due is None else due.urgency,
                         yielding=braking if held else None)
        if (wanted is None and d.target_lane is not None
                and m.ends_soon(d.target_lane, sv)):
            # the rule's faster lane ends within the look-ahead: not a lane to change into
            d = gap_decision(following.view(sv), traffic, self.lanes, following.cfg,
                             self.gap_cfg, self.follower, allow_change=False)
        self.seeking_since = (None if d.target_lane is None
                              else (t if since is None else since))
        accel = d.accel
        if self.lanes_end and due is None:
            # courtesy: a TV that must merge into its lane ahead of it is let in
            accel = min(accel, yield_accel(following.v_ref, following.desired_speed(lane),
                                           self.lanes, lane, sv.x, self.sv_length, traffic,
                                           following.cfg))
        following.limit(*following.with_stop(accel, d.leader_gap, d.leader_speed,
                                             stop_gap(end)))
        self.last = d
        if (not mandatory and scripted is None and self.wanted is None
                and d.target_lane is not None):
            self.wanted = (lane, d.target_lane, t + WANT_HOLD)
        # it signals while it seeks a gap, as SUMO's drivers do while they wait for one:
        # what the traffic's courtesy answers (cosim.traffic.cooperation)
        self._signal(0 if d.target_lane is None else (1 if d.target_lane > lane else -1))
        if d.cooperate_with >= 0:
            self.ask_gap(t, str(traffic.ids[d.cooperate_with]))
        if not d.plan_now or d.target_lane is None:
            return d, ""
        if mandatory:
            return d, MANDATORY if m.may_merge(t) else ""
        if scripted is not None:
            return d, "scripted" if allow_scripted else ""
        return d, "decision" if allow_decision else ""

    def accept(self, t: float, plan: Plan, target: int | None, traffic: TrafficView) -> str:
        """Why the plan is not flown although it has a trajectory ("": fly it): its new
        follower would brake harder than the policy's limit within b_safe (MOBIL)."""
        assert target is not None and plan.trajectory is not None
        in_target = in_lane(target, traffic, self.lanes)
        limit = self.last.follower_decel if self.last is not None else math.nan
        follower = (self.follower.limited(limit) if math.isfinite(limit)
                    else self.plan_follower)
        check = check_follower(plan.trajectory, self.sv_length, traffic.x, traffic.speed,
                               traffic.length, in_target, follower,
                               tv_braking=None if self.last is None else self.last.held)
        if check.safe:
            return ""
        # the follower that would brake too hard blocks: ask it to make room
        self.ask_gap(t, str(traffic.ids[check.follower]))
        return (f"follower {traffic.ids[check.follower]} would brake "
                f"{check.max_decel:.2f} m/s^2 > {follower.b_safe:g}")

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        return self.manoeuvre.summary(t)
