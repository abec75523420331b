"""The gap-seeking decision (policy "gap", beyond the paper): one decision per step
while the SV keeps its lane.

The paper's trigger (cosim.driving.rule) asks the planner for a change only when the
target lane is already free beside the SV, and always ends the change at the band
rule's speed; in dense traffic that moment rarely comes (docs/batch_results.md). This
policy instead:

1. wants a lane as the paper's rule does (a slow leader, a faster adjacent lane,
   left first) or as a scripted request says, but without the free-lane pre-filter:
   the gap choice replaces it;
2. picks a gap in that lane and the speed that takes the SV there (cosim.driving.gap.geometry):
   ahead, alongside or behind, never past its own leader;
3. drives that speed in its own lane (within the approach acceleration), the IDM of
   the paper's rule still keeping it behind its own leader (the smaller of the two);
4. plans the paper's manoeuvre as soon as a change started now enters a usable gap
   (`geometry.entry_test`: its new follower and leader keep their limits when it
   enters; for a change by choice or a scripted one, after `GapConfig.patience` of
   seeking the follower's limit is `insist_decel`, `Seeking.insist`; for a mandatory
   one it is the urgency law's, `urgent_decel`; for a scripted one, after
   `GapConfig.hold_after`, also an entry that counts on the TVs yielding to the SV
   braking on until it is in their lane, `Seeking.yielding`), at the new leader's speed
   (vxf) and only at or above `GapConfig.min_speed`; the planner's collision check and
   the new follower's check on the plan itself (planning.interaction.check_follower)
   then decide;
5. names the TV to ask to open the gap while it blocks it (the chosen gap's
   follower until the SV is inside the gap's slot, or without a gap in reach the TV
   nearest behind the SV in that lane that can still fall back behind it,
   `can_fall_back`), for the traffic's courtesy and cooperative
   V2V (cosim.traffic.cooperation); only a TV that does not already have room for
   the SV (`has_room`) is asked.

The steps are `gap_decision`'s: `_wanted` (the lane), `_first_entry` (step 4),
`_go` / `_pace_the_lane` / `_approach` (what it does: plan now, pace the lane with no gap
in reach, approach the chosen gap). Vehicles are arrays (one entry per TV); no Python
loop over vehicles.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cosim.driving.gap.geometry import (
    ChangeStart,
    Entry,
    GapChoice,
    GapConfig,
    OwnLane,
    TargetLane,
    approach_speed,
    choose_gap,
    entry_test,
    lane_gaps,
    seeking_accel,
    slot_rear,
)
from cosim.driving.lane_end import MERGE_APPROACH_DECEL, MERGE_INSIST_DECEL
from cosim.driving.layout import LaneLayout, Neighbours
from cosim.driving.rule import Decision, DecisionConfig, decide, neighbours
from cosim.driving.view import SVView, TrafficView
from cosim.planning.interaction import FollowerModel, LaneTraffic, secure_gap
from cosim.traffic.cooperation import COURTESY_DECEL

Array = NDArray[np.float64]


@dataclass(frozen=True)
class GapDecision:
    """What the gap-seeking SV does this step while keeping its lane."""

    target_lane: int | None  # lane it wants (None: none)
    accel: float  # m/s^2, longitudinal acceleration to drive now
    leader_gap: float  # m, bumper-to-bumper gap to its own leader (inf: none)
    plan_now: bool  # ask the planner for the change into `target_lane` now
    vxf: float  # m/s, the manoeuvre's end speed: the gap's speed (nan: no gap)
    gap: GapChoice | None  # the gap aimed at
    cooperate_with: int  # TV index to ask to open the gap (-1: nobody)
    reason: str
    leader_speed: float = math.inf  # m/s, its own leader's speed (inf: none)
    follower_decel: float = math.nan  # m/s^2, what the plan may ask of its new follower
    held: Array | None = None  # m/s^2 per TV: the braking of the TVs
    # yielding to the SV that the plan counts on them going on with until the SV is in
    # their lane (their courtesy held; `Seeking.yielding`); None: it counts on nothing
    refused: int = -1  # TV index: the new follower the entry test refused this step (-1:
    # none; the policy then takes it only with a margin, `Seeking.wary`)
    follower: int = -1  # TV index: the new follower of the entry planned now (-1: none)


@dataclass(frozen=True)
class GapRules:
    """The settings a decision follows: the decision rule's and IDM's (`cfg`), the gap
    choice's (`gap`) and the model of the TVs that follow (`follower`)."""

    cfg: DecisionConfig
    gap: GapConfig
    follower: FollowerModel


@dataclass(frozen=True)
class Seeking:
    """What the SV seeks this step."""

    wanted_lane: int | None = None  # a requested lane (scripted, mandatory; None: the
    # decision rule's)
    allow_change: bool = True  # False: car following only
    insist: bool = False  # an entry may ask its new follower for up to insist_decel
    urgency: float = 0.0  # -, 0-1, a mandatory change: the follower's limit before the SV
    # insists grows with it (`urgent_decel`)
    yielding: Array | None = None  # m/s^2 >= 0 per TV, the braking of the TVs that make
    # room for the SV: an entry that holds only if they go on with it until the SV is in
    # their lane is taken too (`GapDecision.held`), after one that asks nothing of them;
    # None: not counted on
    slowing: Array | None = None  # m/s^2 >= 0 per TV, the braking of the TVs asked to make
    # room as the SV sees it now, counted on or not (None: none seen): such a TV is held
    # by its openGap behind the SV and does not speed up toward it, so an insisted entry
    # gives it no `GapConfig.insist_margin`
    wary: NDArray[np.bool_] | None = None  # per TV: a follower refused moments ago, taken
    # only with the entry rule's margin (`GapConfig.wary_share`, `wary_gap`): a refusal
    # does not turn into an acceptance a step later while the situation is the same


@dataclass(frozen=True)
class _Situation:
    """What the steps of one decision share."""

    sv: SVView
    lane: int  # the SV's lane
    target: int  # the lane it wants
    lane_max: float  # m/s, its own lane's speed limit
    own: Neighbours  # its own leader and follower
    traffic: TrafficView
    tvs: LaneTraffic  # the TVs, those in the target lane marked
    target_lane: TargetLane


@functools.lru_cache(maxsize=8)  # one config per run, asked every step (replace is slow)
def wanting_config(cfg: DecisionConfig) -> DecisionConfig:
    """the paper's rule without its free-lane pre-filter (every gap passes it)."""
    return replace(cfg, min_gap=-math.inf, time_gap_ahead=0.0, time_gap_behind=0.0,
                   closing_time=0.0)


@functools.lru_cache(maxsize=8)
def mandatory_config(cfg: GapConfig) -> GapConfig:
    """The gap choice of a mandatory change (a lane that ends): from any speed (a
    standstill at the stop line, cosim.driving.lane_end) and into a gap at any speed
    (its end speed is capped to the room left; the new follower's check decides); its
    new follower asked for what the urgency law allows (`urgent_decel`, up to
    MERGE_INSIST_DECEL at the end), never more after a patience (the courtesy opens
    the gap instead); its approach braking no harder than MERGE_APPROACH_DECEL; with no
    gap in reach, the TV asked to make room one that can still fall back behind the SV
    at the courtesy's own braking (COURTESY_DECEL: a nearer one, asked while the SV
    stands at its stop line, cannot stop behind it and drives past)."""
    # tuned: docs/tuned_constants.md (patience, ask_decel)
    return replace(cfg, min_speed=0.0, max_speed_change=math.inf,
                   insist_decel=MERGE_INSIST_DECEL, approach_decel=MERGE_APPROACH_DECEL,
                   ask_decel=COURTESY_DECEL, patience=math.inf)


def urgent_decel(cfg: GapConfig, urgency: float) -> float:
    """m/s^2, what an entry may ask of its new follower at `urgency` (0: the change just
    became due, 1: at the lane's end; cosim.planning.deadline): plan_decel growing
    linearly to insist_decel (MOBIL's b_safe), as LC2013's urgent strategic change
    asks more of the blocking follower as the remaining distance shrinks."""
    u = min(max(urgency, 0.0), 1.0)
    return cfg.plan_decel + u * (cfg.insist_decel - cfg.plan_decel)


def gap_decision(sv: SVView, traffic: TrafficView, lanes: LaneLayout, rules: GapRules,
                 seeking: Seeking = Seeking()) -> GapDecision:
    """The module docstring's steps for `sv` among `traffic`, seeking what `seeking`
    says."""
    d, target = _wanted(sv, traffic, lanes, rules.cfg, seeking)
    keep = GapDecision(None, d.accel, d.leader_gap, False, math.nan, None, -1, d.reason,
                       d.leader_speed)
    if target is None or target == lanes.lane_of(sv.y):
        return keep
    at = _scene(sv, traffic, lanes, target)
    gap_cfg, follower = rules.gap, rules.follower
    gaps = lane_gaps(sv.length, at.target_lane, gap_cfg, follower)
    own = at.own
    # seeking: up to its lane's limit, Krauss-safe behind its own leader (gap.seeking_accel)
    limit = OwnLane(max_speed=at.lane_max)
    if own.leader >= 0:
        # the SV's centre may get as far as its own leader's rear less half the SV and a
        # standstill gap
        limit = OwnLane(sv.x + own.gap_ahead - rules.cfg.idm_min_gap, own.leader_speed,
                        at.lane_max)
    choice = choose_gap(sv, gaps, gap_cfg, follower, limit)
    # take the first acceptable gap: a change started now that enters a gap whose
    # follower and leader keep their limits is planned now, wherever the chosen gap is
    entry, asked, held = _first_entry(at, lanes, rules, seeking)
    if entry.ok:
        return _go(at, d, gap_cfg, choice, entry, asked, held)
    refused = entry.follower if not entry.follower_ok else -1
    if choice is None:
        return replace(_pace_the_lane(at, keep, rules), refused=refused)
    return replace(_approach(at, d, rules, choice), refused=refused)


def _wanted(sv: SVView, traffic: TrafficView, lanes: LaneLayout, cfg: DecisionConfig,
            seeking: Seeking) -> tuple[Decision, int | None]:
    """The paper's rule without its pre-filter (its IDM acceleration, its lane when none
    is requested) and the lane the SV wants (None: none)."""
    wanted = seeking.wanted_lane
    d = decide(sv, traffic, lanes, wanting_config(cfg),
               allow_change=seeking.allow_change and wanted is None)
    return d, wanted if seeking.allow_change and wanted is not None else d.target_lane


def _scene(sv: SVView, traffic: TrafficView, lanes: LaneLayout, target: int) -> _Situation:
    lane = lanes.lane_of(sv.y)
    x = np.asarray(traffic.x, dtype=float)
    tvs = LaneTraffic(x, np.asarray(traffic.speed, dtype=float),
                      np.asarray(traffic.length, dtype=float), in_lane(target, traffic, lanes))
    return _Situation(sv=sv, lane=lane, target=target, lane_max=lanes.speed_limit(lane),
                  own=neighbours(lane, sv, traffic, lanes, leaving=True), traffic=traffic,
                  tvs=tvs, target_lane=TargetLane(tvs, lanes.end_speed(lane, target),
                                                  lanes.speed_limit(target)))


def _first_entry(at: _Situation, lanes: LaneLayout, rules: GapRules, seeking: Seeking
                 ) -> tuple[Entry, float, Array | None]:
    """The entry test of a change started now (`entry_test`) at each limit on what it
    may ask of its new follower, in order (the urgency law's or plan_decel, then
    insist_decel when insisting), each first with the TVs keeping their speeds, then
    counting on the yielding TVs' braking: (the entry, the limit, the braking counted
    on); the last tried when none passes."""
    gap_cfg, sv = rules.gap, at.sv
    y0 = lanes.centre(at.lane)
    start = ChangeStart(sv.x, y0, sv.speed, sv.length, lanes.centre(at.target) - y0,
                        sv.width, sv.accel)

    def enters(speeds: Array, limit: float, braking: Array | None) -> Entry:
        """`entry_test` of the change, the TVs at `speeds`."""
        tvs = replace(at.tvs, speed=speeds, braking=braking)
        return entry_test(start, replace(at.target_lane, tvs=tvs), gap_cfg,
                          rules.follower.limited(limit))

    yielding = seeking.yielding
    first = (urgent_decel(gap_cfg, seeking.urgency) if seeking.urgency > 0.0
             else gap_cfg.plan_decel)
    limits = (first, gap_cfg.insist_decel) if seeking.insist else (first,)
    speeds = at.tvs.speed
    brakings = (None,) if yielding is None or not np.any(yielding > 0.0) else (None, yielding)
    for limit in limits:
        for braking in brakings:
            entry = enters(speeds, limit, braking)
            if entry.ok:
                break
        insisted = entry.ok and entry.follower_decel > gap_cfg.plan_decel
        if insisted:
            # insisting (an entry that asks its new follower for more than plan_decel;
            # one that asks less is not, whatever the limit: its follower's predicted
            # braking may flip to its decel 1 m/s faster): the entry must hold with the
            # TVs behind the SV a little faster too (`GapConfig.insist_margin`), but for
            # those seen yielding to it (`Seeking.slowing`): SUMO's gap control lets such
            # a TV go no faster than its speed or the headway behind the SV allows
            faster = np.where((at.tvs.x < sv.x) & ~_slowing(seeking, speeds.size),
                              speeds + gap_cfg.insist_margin, speeds)
            entry = replace(entry, ok=enters(faster, limit, braking).ok)
        # a follower refused moments ago is taken only with a margin: an insisted entry
        # has had its margin (it holds with the TVs behind faster; the wary test on top
        # refuses it until its follower's predicted braking falls to nothing, 0.8 s of
        # waiting at 15 veh/km/lane, seed 2)
        if entry.ok and not insisted and _is_wary(seeking, entry.follower):
            wary = rules.follower.limited(limit).wary(gap_cfg.wary_share, gap_cfg.wary_gap)
            tvs = replace(at.tvs, speed=speeds, braking=braking)
            again = entry_test(start, replace(at.target_lane, tvs=tvs), gap_cfg, wary)
            entry = replace(entry, ok=again.ok, follower_ok=again.follower_ok)
        if entry.ok:
            break
    return entry, limit, braking


def _slowing(seeking: Seeking, n: int) -> NDArray[np.bool_]:
    """Per TV (n of them): seen braking to make room for the SV (`Seeking.slowing`)."""
    if seeking.slowing is None:
        return np.zeros(n, dtype=bool)
    return np.asarray(seeking.slowing, dtype=float) > 0.0


def _is_wary(seeking: Seeking, k: int) -> bool:
    """Whether TV `k` (-1: none) is a follower refused moments ago."""
    return k >= 0 and seeking.wary is not None and bool(seeking.wary[k])


def _go(at: _Situation, d: Decision, cfg: GapConfig, choice: GapChoice | None, entry: Entry,
        asked: float, held: Array | None) -> GapDecision:
    """An entry passed: plan now, toward its end speed meanwhile."""
    accel = seeking_accel(at.sv.speed, entry.vxf, at.lane_max, at.own.gap_ahead,
                          _leader_speed(at), cfg)
    return GapDecision(
        target_lane=at.target, accel=float(accel), leader_gap=d.leader_gap, plan_now=True,
        vxf=entry.vxf, gap=choice, cooperate_with=-1,
        reason=f"lane {at.target}: gap reached", leader_speed=d.leader_speed,
        follower_decel=asked, held=held, follower=entry.follower)


def _pace_the_lane(at: _Situation, keep: GapDecision, rules: GapRules) -> GapDecision:
    """No gap in reach: the TV nearest behind the SV in the target lane (of those that
    can still fall back behind it) may be asked to yield (if it has no room yet), and
    the SV keeps pace with that lane's traffic ahead of it (the nearest TV ahead in that
    lane), so that the gap the asked TV opens behind it comes up beside it (driving
    toward the lane's band speed runs away from the gap being opened; pacing the asked
    TV itself slows both down together); none ahead: the band speed."""
    sv, traffic, cfg = at.sv, at.traffic, rules.gap
    x, in_target = at.tvs.x, at.tvs.in_target
    behind = np.where(in_target & (x < sv.x) & can_fall_back(sv, traffic, cfg), x, -np.inf)
    ask = int(np.argmax(behind)) if behind.size and np.isfinite(behind.max()) else -1
    if ask >= 0 and has_room(sv, traffic, ask, cfg, rules.follower):
        ask = -1  # it already has room: nothing to ask of it
    ahead = np.where(in_target & (x >= sv.x), x, np.inf)
    pace = int(np.argmin(ahead)) if ahead.size and np.isfinite(ahead.min()) else -1
    if pace >= 0:
        # ... with its front the SV's secure gap behind that TV's rear, where the entry
        # test wants it (pacing it level leaves the SV too close behind it to go)
        v_p = float(traffic.speed[pace])
        rear = float(x[pace] - 0.5 * traffic.length[pace])
        need = float(secure_gap(v_p, v_p, cfg.sv_model()))
        e = min(rear - need - 0.5 * sv.length - sv.x, 0.0)
        v_lane = float(approach_speed(e, v_p, cfg))
    else:
        v_lane = at.target_lane.lane_speed
    accel = seeking_accel(sv.speed, v_lane, at.lane_max, at.own.gap_ahead,
                          _leader_speed(at), cfg)
    return replace(keep, target_lane=at.target, accel=float(accel), cooperate_with=ask,
                   reason=f"lane {at.target}: no gap in reach")


def _approach(at: _Situation, d: Decision, rules: GapRules, choice: GapChoice) -> GapDecision:
    """Toward the chosen gap's approach speed, within the approach acceleration; not
    planned yet (the entry test decides). Only a follower that blocks the gap is asked
    (SUMO's LC2013 informs the blocking follower only): one behind the SV that it is not
    yet clear of (a gap's follower ahead of the SV would have to brake for a car behind
    it)."""
    sv, cfg = at.sv, rules.gap
    accel = seeking_accel(sv.speed, choice.target_speed, at.lane_max, at.own.gap_ahead,
                          _leader_speed(at), cfg)
    f = choice.follower
    coop = f if (f >= 0 and not choice.reachable and at.tvs.x[f] < sv.x
                 and not has_room(sv, at.traffic, f, cfg, rules.follower)) else -1
    return GapDecision(
        target_lane=at.target, accel=float(accel), leader_gap=d.leader_gap, plan_now=False,
        vxf=choice.speed, gap=choice, cooperate_with=coop,
        reason=f"lane {at.target}: gap {choice.index} {choice.relation}, "
               f"{choice.offset:+.1f} m",
        leader_speed=d.leader_speed,
    )


def _leader_speed(at: _Situation) -> float:
    """m/s, the SV's own leader's speed (inf: none)."""
    return at.own.leader_speed if at.own.leader >= 0 else math.inf


def has_room(sv: SVView, traffic: TrafficView, k: int, cfg: GapConfig,
             follower: FollowerModel) -> bool:
    """Whether TV `k` (behind the SV in the target lane) already has room for the SV
    entering beside it now: its bumper gap to the SV's rear is at least the slot's
    rear end (its accepted gap at `GapConfig.entry_decel` plus what it closes before
    the SV enters, `slot_rear`). Such a TV is not asked to open a gap: its openGap
    would only make it brake for nothing."""
    lo = slot_rear(float(traffic.x[k]) + 0.5 * float(traffic.length[k]),
                   float(traffic.speed[k]), sv.speed, sv.length, cfg, follower)
    return bool(sv.x >= float(lo))


def can_fall_back(sv: SVView, traffic: TrafficView, cfg: GapConfig) -> NDArray[np.bool_]:
    """Which TVs can still come down to the SV's speed behind its rear, their standstill
    gap short of it, braking at `cfg.ask_decel` (all of them with inf): the ones worth
    asking to make room. Arrays over TVs."""
    x = np.asarray(traffic.x, dtype=float)
    if math.isinf(cfg.ask_decel):
        return np.ones(x.size, dtype=bool)
    closing = np.maximum(np.asarray(traffic.speed, dtype=float) - max(sv.speed, 0.0), 0.0)
    room = (sv.x - 0.5 * sv.length) - (x + 0.5 * np.asarray(traffic.length, dtype=float))
    return closing * closing / (2.0 * cfg.ask_decel) <= room - cfg.min_gap


def in_lane(lane: int, traffic: TrafficView, lanes: LaneLayout) -> NDArray[np.bool_]:
    """Which TVs' bodies touch `lane` (a TV half way through a change is in both), and
    those announced over V2V to be changing into it (an automated vehicle's broadcast
    lane change: in the lane from its start, so that two changing into one lane from
    both sides take one gap each, the later one's entry tested against the earlier)."""
    lo, hi = lanes.lanes_touched(traffic.y, 0.5 * np.asarray(traffic.width, dtype=float))
    inside = (lo <= lane) & (hi >= lane)
    if traffic.joining is not None:
        inside |= traffic.joining == lane
    return inside
