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

On a lane that ends it does what cosim.driving.lane_end says: it stops before the end
(a virtual standing leader) and, once the end is within its look-ahead, seeks a gap in
the continuing lane before anything else ("mandatory"), with the urgency law of
cosim.driving.gap.decision (what it may ask of its new follower grows as the end
nears, and only so: it does not insist after its patience) and from any speed
(`mandatory_config`); every plan ends before the end. It signals and asks the blocking
follower to make room as for any change. On the mainline it lets a TV that must merge
ahead of it in (`SVLaneEnds.yield_accel`).

Each step's seeking is `seek`'s named steps: what it wants (`_wants`), the decision
(`_decide`), the speed it drives (`_drive`), its blinker and gap request (`_signal_gap`)
and whether to plan now (`_trigger`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from cosim.driving.base import DrivingContext, Manoeuvres, Messages, PolicyStatus
from cosim.driving.blinker import Blinker
from cosim.driving.cadence import Cadence
from cosim.driving.following import HOLD_SPEED, CarFollowing
from cosim.driving.gap.decision import (
    GapDecision,
    GapRules,
    Seeking,
    gap_decision,
    in_lane,
    mandatory_config,
)
from cosim.driving.gap.geometry import GapConfig
from cosim.driving.gap.retarget import RETARGET_MIN_TIME, end_speed
from cosim.driving.gap.yielding import MakingRoom, YieldWatch
from cosim.driving.lane_end import stop_gap
from cosim.driving.manoeuvre import LaneChangeTimer, Manoeuvre, Mode
from cosim.driving.plans import Trigger
from cosim.driving.recheck import GapRecheck, reference_state
from cosim.driving.registry import register
from cosim.driving.view import TrafficView
from cosim.planning.deadline import LaneEnd
from cosim.planning.interaction import FollowerModel, LaneTraffic, check_follower
from cosim.planning.planner import PredictionOptions
from cosim.planning.trajectory import LaneChangeTrajectory

if TYPE_CHECKING:
    from cosim.driving.layout import Neighbours
    from cosim.driving.manoeuvre import LaneChange
    from cosim.planning.planner import Plan
    from cosim.traffic.world import Scene, SVState

WANT_HOLD = 20.0  # s, a lane the decision rule wanted is sought this long at most
STOP_GAP = 2.5  # m, IDM standstill gap s0 of this policy (SUMO's minGap; >= 2 m in a queue)
COOLNESS = 0.99  # -, its car following is the ACC model (IDM + CAH, rule.acc_blend): after
# a merge into a slot of GapConfig.headway it reopens its gap braking about the IDM's
# b = 2 m/s^2 at most while the new leader keeps its speed (the plain IDM brakes far harder)
TIME_GAP = 1.0  # s, its IDM time gap T: SUMO's drivers' tau (the paper's rule: 1.5 s), so
# that after a merge into a slot of GapConfig.headway it reopens less and makes its new
# follower brake less
# tuned: docs/tuned_constants.md
RETRY = 0.1  # s, a plan refused although the entry test passed is asked for again this soon
# (the entry test's nominal manoeuvre and the planned one differ a little; the decision
# rule's retry_interval would cost that much from request to lane each time)
# tuned: docs/tuned_constants.md
CHOICE_MAX_TAU = 6.0  # s, a change by choice planned longer than this is not flown: the
# planner's check looks a fixed time ahead, and a long plan behind a TV that signals
# for the target lane is free only because its collision with it falls past the
# check's end (merge study at 30 veh/km/lane: the shorter plans met that TV 5-12 s
# ahead, 8.3 s was free; the TV then changed, and the re-check aborted or replanned)
# tuned: docs/tuned_constants.md

REACTION = 0.1  # s, SUMO's follower brakes for the SV this long after the SV's body
# entered its lane (it sees the SV's shadow at its next step and acts the step after;
# measured: the new follower's braking begins 0.1 s after the SV's side crossed the line)
# tuned: docs/tuned_constants.md


@dataclass(frozen=True)
class _Wants:
    """What the SV wants this step (`GapPolicy._wants`)."""

    lane: int  # the lane it is in
    end: LaneEnd | None  # the end of that lane ahead (None: it runs on)
    due: LaneEnd | None  # the same, once its mandatory change is due
    scripted: int | None  # the lane of a due scripted request
    wanted: int | None  # the lane it seeks (None: the decision rule's, if any)

    @property
    def mandatory(self) -> bool:
        return self.due is not None


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
        self.room = MakingRoom()  # room it makes for an automated vehicle that asked
        self.held: LaneChange | None = None  # the change flown on the courtesy held
        self.retargeted: LaneChange | None = None  # the last change whose end speed was
        # re-targeted to its new leader (`_retarget`)
        # the SV's blinker: it signals for the context's notice before it starts a change
        self.blinker = Blinker(ctx.ports.blinker, ctx.notice)
        self.following = CarFollowing(ctx, cfg)
        self.gap_cfg = gap or GapConfig()
        self.manoeuvre = Manoeuvre(ctx, LaneChangeTimer(cfg), self._signal,
                                   max_tau=self.gap_cfg.max_tau,
                                   gap_rules=GapRecheck(sv_width=ctx.sv_width),
                                   merge_max_tau=self.gap_cfg.merge_max_tau)
        self.ends = self.manoeuvre.ends  # the SV's lane-end reasoning
        self.follower = follower or FollowerModel(reaction=REACTION)
        # what a flown plan may ask of its new follower: the policy's own limit within b_safe
        self.plan_follower = self.follower.limited(self.gap_cfg.plan_decel)
        self.sv_length = ctx.sv_length
        self.sv_width = ctx.sv_width
        self.decision = ctx.sv.decision
        self.wanted: tuple[int, int, float] | None = None  # (origin, target, until t)
        self.last: GapDecision | None = None  # this step's decision (for inspection)
        self.seeking_since: float | None = None  # s, since when it seeks a gap (None: not)
        self.refused: dict[str, float] = {}  # TV id -> s, when it was last refused as the
        # new follower (by the entry test or a plan's check): taken with a margin a while
        # its decisions while keeping its lane held between steps (None: it decides every
        # step, as the SV)
        self.cadence = None if ctx.cadence is None else Cadence(ctx.cadence)

    @property
    def wall(self) -> float:
        return self.manoeuvre.wall

    def _signal(self, direction: int) -> None:
        """The blinker, set in SUMO only when it changes."""
        self.blinker.set(direction)

    def make_room(self, t: float, vehicle_id: str) -> None:
        """An automated vehicle asked it (V2V) to open a gap for it (`MakingRoom`)."""
        self.room.asked(t, vehicle_id)

    def ask_gap(self, t: float, tv_id: str) -> None:
        """Ask `tv_id` to make room (the context's port) and, if a channel carries the
        request, watch how it brakes."""
        if self._ask_gap(t, tv_id):
            self.yielding.asked(tv_id)

    def status(self, sv: SVState) -> PolicyStatus:
        return self.manoeuvre.status(self.following.leader_gap, self.following.accel)

    def gaps_held(self, sv: SVState) -> bool:
        """True while the SV seeks a gap, and while the change under way was planned on
        the courtesy held until the SV is in the target lane."""
        lc = self.manoeuvre.active
        if lc is None:
            return True
        return lc is self.held and self.lanes.lane_of(sv.y) != lc.target_lane

    def update(self, t: float, scene: Scene, messages: Messages) -> LaneChangeTrajectory:
        """Finish a manoeuvre that is over; car-following toward the chosen gap; plan the
        change once the gap is reached, or re-check the one under way."""
        sv, m = scene.sv, self.manoeuvre
        ended = m.begin(t)
        if ended is not None:
            # after a change re-targeted to a slower new leader, braking begins at the
            # manoeuvre's end acceleration (0), its jerk limited: the car following's
            # braking for that leader would be a step at once (0 -> 2.7 m/s^2, the car
            # 3.6 behind a leader that cut in 47 m ahead 6 m/s slower)
            self.following.resume(float(ended.trajectory.vxf),
                                  brake_from=0.0 if ended is self.retargeted else None)
        allow_scripted, allow_decision = m.may_request(t, sv)
        if m.active is not None:  # changing: car-following values for the trace only
            self.following.update(sv, scene, False)
            self._retarget(t, sv, scene, messages)
            trajectory = m.advance(t, sv, None, None, messages)
        else:
            traffic = TrafficView.of(scene)
            joining = getattr(messages, "joining", None)  # the fleet's announced changes
            if joining is not None:
                traffic = traffic.announced(joining())
            d, trigger = self.seek(t, sv, traffic, allow_scripted, allow_decision)
            target = d.target_lane if trigger is not None else None
            trajectory = m.advance(
                t, sv, target, trigger, messages,
                vxf=d.vxf if math.isfinite(d.vxf) else None,
                accept=lambda plan: self.accept(t, plan, target, traffic, trigger),
                ax0=self.following.accel)
            self.held = m.active if d.held is not None else None
            if self.cadence is not None and m.active is None:
                self.cadence.decided(t, sv.vx, self._own(sv, traffic), traffic.ids)
        return trajectory if trajectory is not None else self.following.reference(t, sv)

    def _retarget(self, t: float, sv: SVState, scene: Scene, messages: Messages) -> None:
        """The change under way ends at its new leader's speed now where that leader has
        slowed since the plan (cosim.driving.gap.retarget), if the rest of the change at
        that speed is still collision-free and its new follower keeps the plan's limit."""
        m = self.manoeuvre
        lc = m.active
        if lc is None or m.mode != Mode.CHANGING or lc.aborted:
            return
        tr = lc.trajectory
        left = tr.t_end - t
        if left < RETARGET_MIN_TIME:
            return
        traffic = TrafficView.of(scene)
        ahead = self.lanes.neighbours(lc.target_lane, sv.x, self.sv_length, traffic)
        if ahead.leader < 0:
            return
        vxf = end_speed(float(tr.vxf), float(tr.derivative(t, 1)[0]),
                        float(tr.derivative(t, 2)[0]), left, ahead.gap_ahead,
                        float(ahead.leader_speed), self.following.cfg.idm_time_gap,
                        self.following.cfg.idm_min_gap)
        if vxf is None:
            return
        st = reference_state(tr, t, lc.origin_lane)
        tried = LaneChangeTrajectory(t0=t, tau=left, x0=st.x, y0=st.y, vx0=st.vx, vxf=vxf,
                                     width=lc.y_target - st.y, ax0=st.ax, vy0=st.vy,
                                     ay0=st.ay)
        tvs = LaneTraffic.of(traffic.x, traffic.speed, traffic.length,
                             in_lane(lc.target_lane, traffic, self.lanes))
        if not check_follower(tried, self.sv_length, tvs, self.plan_follower,
                              sv_width=self.sv_width).safe:
            return  # slower now, its new follower would brake too hard: car following
        if m.calls.check(tried, t, messages.read()) is None:
            lc.trajectory = tried
            self.retargeted = lc

    def _own(self, sv: SVState, traffic: TrafficView) -> Neighbours:
        """Its leader and follower in its own lane."""
        return self.lanes.neighbours(self.lanes.lane_of(sv.y), sv.x, self.sv_length, traffic,
                                     leaving=True)

    def hold(self, t: float, scene: Scene) -> LaneChangeTrajectory | None:
        """The lane-keeping reference from t with the last decision's acceleration held,
        or None: decide now (`update`). Only with a cadence (cosim.driving.cadence), while
        it keeps its lane with no entry open (one its notice or timer holds back), no lane
        end ahead, no acceleration still ramping to the one decided (`Following.ramping`)
        and no leader (nor itself) near standstill
        (the standstill hold needs the gap of every step), until the cadence is due or the
        held acceleration takes the reference across the speed it wants."""
        c, m, f = self.cadence, self.manoeuvre, self.following
        if c is None or m.active is not None or m.mode != Mode.KEEPING or (
                self.room.requester is not None) or (
                self.last is not None and self.last.plan_now):  # an entry open: plan soon
            return None
        sv = scene.sv
        lane = self.lanes.lane_of(sv.y)
        if f.v_ref < HOLD_SPEED or f.leader_speed < HOLD_SPEED or f.ramping or (
                self.ends.any and self.ends.ahead(lane, sv.x, sv.vx) is not None):
            return None
        traffic = TrafficView.of(scene)
        own = self._own(sv, traffic)
        desired = f.desired_speed(lane)
        if (c.due(t, own, traffic.ids) or (own.leader >= 0 and own.leader_speed < HOLD_SPEED)
                or (f.v_ref - desired) * (f.v_ref + f.accel * f.dt - desired) < 0.0):
            return None
        if abs(f.leader_gap - c.gap) <= 1e-6:  # the decision followed its own leader
            f.leader_gap = own.gap_ahead
            f.leader_speed = own.leader_speed if own.leader >= 0 else math.inf
        return f.reference(t, sv)

    def seek(self, t: float, sv: SVState, traffic: TrafficView, allow_scripted: bool,
             allow_decision: bool) -> tuple[GapDecision, Trigger | None]:
        """Car-following toward the chosen gap this step; the decision, and the trigger
        once the gap is reached (None: do not plan now)."""
        wants = self._wants(t, sv)
        d = self._decide(t, sv, traffic, wants)
        self.seeking_since = (None if d.target_lane is None
                              else (t if self.seeking_since is None else self.seeking_since))
        self._drive(t, sv, traffic, wants, d)
        self.last = d
        if (not wants.mandatory and wants.scripted is None and self.wanted is None
                and d.target_lane is not None):
            self.wanted = (wants.lane, d.target_lane, t + WANT_HOLD)
        self._signal_gap(t, traffic, wants.lane, d)
        return d, self._trigger(t, d, wants, allow_scripted, allow_decision)

    def _wants(self, t: float, sv: SVState) -> _Wants:
        """The lane the SV seeks: the continuing lane once its own lane's mandatory change
        is due, else a due scripted request's, else the one its decision rule wanted
        (while it is still in the lane it wanted to leave, for WANT_HOLD at most)."""
        lane = self.lanes.lane_of(sv.y)
        end = self.ends.ahead(lane, sv.x, sv.vx)  # its lane ends: stop before it, change
        due = None if end is None else self.ends.due(lane, sv)
        scripted = self.manoeuvre.due_scripted(t, sv)
        if scripted is not None and not self.ends.begun(scripted, sv.x):
            scripted = None  # a lane that begins ahead: sought once it runs beside the SV
        if self.wanted is not None and (self.wanted[0] != lane or t > self.wanted[2]):
            self.wanted = None
        wanted = scripted if scripted is not None else (
            self.wanted[1] if self.wanted is not None else None)
        if due is not None:
            wanted = due.target
        return _Wants(lane, end, due, scripted, wanted)

    def _decide(self, t: float, sv: SVState, traffic: TrafficView, wants: _Wants
                ) -> GapDecision:
        """This step's gap decision (cosim.driving.gap.decision) for what the SV wants."""
        following, since = self.following, self.seeking_since
        braking = self.yielding.braking(t, traffic.ids, traffic.speed)
        # a mandatory change's settings (`mandatory_config`: it never insists after a
        # patience, what it asks grows with its urgency alone)
        gap_cfg = mandatory_config(self.gap_cfg) if wants.mandatory else self.gap_cfg
        insist = since is not None and t - since >= gap_cfg.patience - 1e-9
        # only a requested change counts on the courtesy held: a change by choice waits
        # for a gap that asks nothing more, a mandatory one has its urgency law
        held = (wants.scripted is not None and not wants.mandatory and since is not None
                and t - since >= gap_cfg.hold_after - 1e-9)
        # a lane by choice is sought only once the last change has settled (its
        # cooldown): seeking at once asks the next lane's follower for courtesy and
        # brakes toward its gaps just after a merge, and the TV behind the SV, which
        # SUMO keeps from passing a slower car on its left, brakes with it
        by_choice = self.decision and not self.manoeuvre.timer.cooling(t)
        seeking = Seeking(
            wanted_lane=wants.wanted,
            allow_change=wants.mandatory or wants.scripted is not None or by_choice,
            insist=insist, urgency=0.0 if wants.due is None else wants.due.urgency,
            yielding=braking if held else None,
            slowing=None if wants.mandatory or not np.any(braking > 0.0) else braking,
            wary=self._wary(t, traffic.ids))
        view = following.view(sv)
        if wants.mandatory:  # its plan starts from 0 (Manoeuvre.start): its entry test too
            view = replace(view, accel=0.0)
        d = gap_decision(view, traffic, self.lanes,
                         GapRules(following.cfg, gap_cfg, self.follower), seeking)
        if d.refused >= 0:
            self.refused[str(traffic.ids[d.refused])] = t
        if (wants.wanted is None and d.target_lane is not None
                and self.ends.closed(d.target_lane, sv)):
            # the rule's faster lane ends within the look-ahead: not a lane to change into
            d = gap_decision(following.view(sv), traffic, self.lanes,
                             GapRules(following.cfg, self.gap_cfg, self.follower),
                             Seeking(allow_change=False))
        return d

    def _wary(self, t: float, ids: tuple[str, ...]) -> np.ndarray | None:
        """Per TV of `ids`: refused as the new follower within the last
        `GapConfig.wary_memory` (None: nobody)."""
        memory = self.gap_cfg.wary_memory
        self.refused = {k: v for k, v in self.refused.items() if t - v <= memory + 1e-9}
        if not self.refused or not ids:
            return None
        return np.fromiter((k in self.refused for k in ids), dtype=bool, count=len(ids))

    def _drive(self, t: float, sv: SVState, traffic: TrafficView, wants: _Wants,
               d: GapDecision) -> None:
        """The speed it drives this step: the decision's, letting a TV that must merge
        into its lane ahead of it in (on the mainline beside a lane that ends) and an
        automated vehicle that asked for room, and stopping before the end of its own
        lane."""
        following = self.following
        accel = d.accel
        if self.room.requester is not None and d.target_lane is None:
            # (one seeking a gap itself does not also make room: two drivers slowing for
            # each other's changes ended in a re-check cascade)
            accel = min(accel, self.room.accel(t, sv.x, self.sv_length, following.v_ref,
                                               wants.lane, traffic, self.lanes, following.cfg))
        if self.ends.any and wants.due is None:
            accel = min(accel, self.ends.yield_accel(
                following.v_ref, following.desired_speed(wants.lane), wants.lane, sv.x,
                traffic, following.cfg))
        following.limit(*following.with_stop(accel, d.leader_gap, d.leader_speed,
                                             stop_gap(wants.end)))

    def _signal_gap(self, t: float, traffic: TrafficView, lane: int, d: GapDecision) -> None:
        """It signals while it seeks a gap, as SUMO's drivers do while they wait for one
        (what the traffic's courtesy answers, cosim.traffic.cooperation), and asks the
        TV the decision names to open the gap."""
        direction = 0 if d.target_lane is None else (1 if d.target_lane > lane else -1)
        self.blinker.set(direction, t)
        if d.cooperate_with >= 0:
            self.ask_gap(t, str(traffic.ids[d.cooperate_with]))

    def _trigger(self, t: float, d: GapDecision, wants: _Wants, allow_scripted: bool,
                 allow_decision: bool) -> Trigger | None:
        """The trigger to plan with now (None: not now)."""
        if not d.plan_now or d.target_lane is None:
            return None
        if not self.blinker.noticed(t):
            return None  # its V2V partners have not all heard its intention yet
        if wants.mandatory:
            return Trigger.MANDATORY if self.manoeuvre.may_merge(t) else None
        if wants.scripted is not None:
            return Trigger.SCRIPTED if allow_scripted else None
        return Trigger.DECISION if allow_decision else None

    def accept(self, t: float, plan: Plan, target: int | None, traffic: TrafficView,
               trigger: Trigger | None = None) -> str:
        """Why the plan is not flown although it has a trajectory ("": fly it): a change
        by choice longer than CHOICE_MAX_TAU, or its new follower would brake harder than
        the policy's limit within b_safe (MOBIL)."""
        assert target is not None and plan.trajectory is not None
        if trigger == Trigger.DECISION and plan.tau is not None and plan.tau > CHOICE_MAX_TAU:
            return f"a change by choice of {plan.tau:.2f} s > {CHOICE_MAX_TAU:g}"
        limit = self.last.follower_decel if self.last is not None else math.nan
        follower = (self.follower.limited(limit) if math.isfinite(limit)
                    else self.plan_follower)
        tvs = LaneTraffic.of(traffic.x, traffic.speed, traffic.length,
                             in_lane(target, traffic, self.lanes),
                             None if self.last is None else self.last.held)
        check = check_follower(plan.trajectory, self.sv_length, tvs, follower,
                               sv_width=self.sv_width)
        insisted = check.max_decel > self.gap_cfg.plan_decel  # its margin: the entry test's
        if (check.safe and not insisted and check.follower >= 0
                and str(traffic.ids[check.follower]) in self.refused):
            # refused moments ago: taken only with the entry rule's margin
            wary = follower.wary(self.gap_cfg.wary_share, self.gap_cfg.wary_gap)
            check = replace(check, safe=check_follower(
                plan.trajectory, self.sv_length, tvs, wary, sv_width=self.sv_width).safe)
        if check.safe:
            return ""
        # the follower that would brake too hard blocks: ask it to make room
        self.refused[str(traffic.ids[check.follower])] = t
        self.ask_gap(t, str(traffic.ids[check.follower]))
        return (f"follower {traffic.ids[check.follower]} would brake "
                f"{check.max_decel:.2f} m/s^2 > {follower.b_safe:g}")

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        return self.manoeuvre.summary(t)
