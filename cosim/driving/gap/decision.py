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
   seeking the follower's limit is `insist_decel`, `insist` below; for a mandatory one
   it is the urgency law's, `urgent_decel`; for a scripted one, after
   `GapConfig.hold_after`, also an entry that counts on the TVs yielding to the SV
   braking on until it is in their lane, `yielding` below), at the new leader's speed
   (vxf) and only at or above `GapConfig.min_speed`; the planner's collision check and
   the new follower's check on the plan itself (planning.interaction.check_follower)
   then decide;
5. names the TV to ask to open the gap while it blocks it (the chosen gap's
   follower until the SV is inside the gap's slot, or without a gap in reach the TV
   nearest behind the SV in that lane that can still fall back behind it,
   `can_fall_back`), for the traffic's courtesy and cooperative
   V2V (cosim.traffic.cooperation); only a TV that does not already have room for
   the SV (`has_room`) is asked.

Vehicles are arrays (one entry per TV); no Python loop over vehicles.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from cosim.driving.gap.geometry import (
    Entry,
    GapChoice,
    GapConfig,
    approach_speed,
    choose_gap,
    entry_test,
    lane_gaps,
    seeking_accel,
    slot_ends,
)
from cosim.driving.lane_end import MERGE_APPROACH_DECEL, MERGE_INSIST_DECEL
from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig, decide, neighbours
from cosim.driving.view import SVView, TrafficView
from cosim.planning.interaction import FollowerModel, secure_gap
from cosim.traffic.cooperation import COURTESY_DECEL


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
    held: NDArray[np.float64] | None = None  # m/s^2 per TV: the braking of the TVs
    # yielding to the SV that the plan counts on them going on with until the SV is in
    # their lane (their courtesy held; `yielding`); None: it counts on nothing


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
    MERGE_INSIST_DECEL at the end), never more after a patience (patience inf: insisting
    after 1 s made the merge's new follower brake at its full 4.5 m/s^2 in 8 of 20 runs
    at 50 veh/km/lane, SUMO's driver's in 1; the courtesy opens the gap instead, issue
    24); its approach braking no harder than MERGE_APPROACH_DECEL; with no gap in reach,
    the TV asked to make room one that can still fall back behind the SV at the
    courtesy's own braking (COURTESY_DECEL: the nearest one, asked while the SV stood at
    its stop line, could not stop behind it, drove past, and so did the next ones; a
    merge at 20 veh/km/lane waited 31 s and never went)."""
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


def gap_decision(sv: SVView, traffic: TrafficView, lanes: LaneLayout, cfg: DecisionConfig,
                 gap_cfg: GapConfig, follower: FollowerModel, *,
                 wanted_lane: int | None = None, allow_change: bool = True,
                 insist: bool = False, urgency: float = 0.0,
                 yielding: NDArray[np.float64] | None = None) -> GapDecision:
    """The module docstring's steps for `sv` among `traffic`. `wanted_lane`: a
    scripted request's lane (else the rule decides); `allow_change` False:
    car-following only. `urgency` (0-1, a mandatory change): the follower's limit
    before the SV insists grows with it (`urgent_decel`). `yielding` (m/s^2 >= 0 per
    TV, None: not counted on): the braking of the TVs that make room for the SV; an
    entry that holds only if they go on with it until the SV is in their lane is taken
    too (`GapDecision.held`), after one that asks nothing of them."""
    lane = lanes.lane_of(sv.y)
    d = decide(sv, traffic, lanes, wanting_config(cfg),
               allow_change=allow_change and wanted_lane is None)
    target = wanted_lane if allow_change and wanted_lane is not None else d.target_lane
    keep = GapDecision(None, d.accel, d.leader_gap, False, math.nan, None, -1, d.reason,
                       d.leader_speed)
    if target is None or target == lane:
        return keep
    x = np.asarray(traffic.x, dtype=float)
    in_target = in_lane(target, traffic, lanes)
    end_speed, target_max = lanes.end_speed(lane, target), lanes.speed_limit(target)
    gaps = lane_gaps(sv.length, x, traffic.speed, traffic.length, in_target, end_speed,
                     gap_cfg, follower, target_max)
    own = neighbours(lane, sv, traffic, lanes, leaving=True)
    own_limit, own_speed = math.inf, 0.0
    if own.leader >= 0:
        # the SV's centre may get as far as its own leader's rear less half the SV and a
        # standstill gap
        own_limit = sv.x + own.gap_ahead - cfg.idm_min_gap
        own_speed = own.leader_speed
    # seeking: up to its lane's limit, Krauss-safe behind its own leader (gap.seeking_accel)
    lane_max = lanes.speed_limit(lane)
    choice = choose_gap(sv.x, sv.speed, sv.length, sv.desired_speed, gaps, gap_cfg, follower,
                        own_limit, own_speed, max_speed=lane_max)
    leader_speed = own.leader_speed if own.leader >= 0 else math.inf
    # take the first acceptable gap: a change started now that enters a gap whose
    # follower and leader keep their limits is planned now, wherever the chosen gap is
    y0 = lanes.centre(lane)
    width = lanes.centre(target) - y0

    def enters(speeds: NDArray[np.float64], limit: float,
               braking: NDArray[np.float64] | None) -> Entry:
        """`entry_test` of a change to `target` started now, the TVs at `speeds`."""
        return entry_test(sv.x, y0, sv.speed, sv.length, width, x, speeds, traffic.length,
                          in_target, end_speed, gap_cfg, follower.limited(limit),
                          target_max, braking)

    first = urgent_decel(gap_cfg, urgency) if urgency > 0.0 else gap_cfg.plan_decel
    limits = (first, gap_cfg.insist_decel) if insist else (first,)
    speeds = np.asarray(traffic.speed, dtype=float)
    brakings = (None,) if yielding is None or not np.any(yielding > 0.0) else (None, yielding)
    for limit in limits:
        for braking in brakings:
            entry = enters(speeds, limit, braking)
            if entry.ok:
                break
        if entry.ok and entry.follower_decel > gap_cfg.plan_decel:
            # insisting (an entry that asks its follower for more than plan_decel; one
            # that asks less is not, whatever the limit: at urgency 0.57 an entry asking
            # nothing of a TV 54 m behind was refused, since 1 m/s faster its predicted
            # braking flips to 4.5, and the SV stopped at its stop line on a near-empty
            # mainline, issue 24): the entry must hold with the TVs behind the SV a
            # little faster too (a follower predicted to brake at exactly its decel
            # braked at its emergency decel, 9 m/s^2, in 13 of 20 runs at 50 veh/km/lane:
            # SUMO's dawdling and acceleration since the last sample are not in the
            # prediction)
            faster = np.where(x < sv.x, speeds + gap_cfg.insist_margin, speeds)
            entry = replace(entry, ok=enters(faster, limit, braking).ok)
        if entry.ok:
            break
    if entry.ok:
        accel = seeking_accel(sv.speed, entry.vxf, lane_max, own.gap_ahead, leader_speed,
                              gap_cfg)
        return GapDecision(
            target_lane=target, accel=float(accel), leader_gap=d.leader_gap, plan_now=True,
            vxf=entry.vxf, gap=choice, cooperate_with=-1,
            reason=f"lane {target}: gap reached", leader_speed=d.leader_speed,
            follower_decel=limit, held=braking)
    if choice is None:
        # none in reach: the TV nearest behind the SV in that lane (of those that can
        # still fall back behind it) may be asked to yield (if it has no room yet), and
        # the SV keeps pace with that lane's traffic ahead of it (the nearest TV ahead
        # in that lane), so that the gap the asked TV opens behind it comes up beside it
        # (driving toward the lane's band speed instead ran away from the gap being
        # opened: 8-16 s from request to lane, issue 22; pacing the asked TV itself
        # slowed both down together); none ahead: the band speed
        behind = np.where(in_target & (x < sv.x) & can_fall_back(sv, traffic, gap_cfg),
                          x, -np.inf)
        ask = int(np.argmax(behind)) if behind.size and np.isfinite(behind.max()) else -1
        if ask >= 0 and has_room(sv, traffic, ask, gap_cfg, follower):
            ask = -1  # it already has room: nothing to ask of it
        ahead = np.where(in_target & (x >= sv.x), x, np.inf)
        pace = int(np.argmin(ahead)) if ahead.size and np.isfinite(ahead.min()) else -1
        if pace >= 0:
            # ... with its front the SV's secure gap behind that TV's rear, where the
            # entry test wants it (pacing it level left the SV too close behind it to go:
            # 11 m where 24 were needed at 30 veh/km/lane, issue 22)
            v_p = float(traffic.speed[pace])
            rear = float(x[pace] - 0.5 * traffic.length[pace])
            need = float(secure_gap(v_p, v_p, gap_cfg.sv_model()))
            e = min(rear - need - 0.5 * sv.length - sv.x, 0.0)
            v_lane = float(approach_speed(e, v_p, gap_cfg))
        else:
            v_lane = end_speed
        accel = seeking_accel(sv.speed, v_lane, lane_max, own.gap_ahead, leader_speed,
                              gap_cfg)
        return replace(keep, target_lane=target, accel=float(accel), cooperate_with=ask,
                       reason=f"lane {target}: no gap in reach")
    # toward the approach speed, within the approach acceleration
    accel = seeking_accel(sv.speed, choice.target_speed, lane_max, own.gap_ahead,
                          leader_speed, gap_cfg)
    plan_now = False  # not yet: the entry test above decides
    # only a follower that blocks the gap is asked (SUMO's LC2013 informs the blocking
    # follower only): one behind the SV that it is not yet clear of (a gap's follower
    # ahead of the SV would have to brake for a car behind it)
    f = choice.follower
    coop = f if (f >= 0 and not choice.reachable and x[f] < sv.x
                 and not has_room(sv, traffic, f, gap_cfg, follower)) else -1
    return GapDecision(
        target_lane=target, accel=float(accel), leader_gap=d.leader_gap, plan_now=plan_now,
        vxf=choice.speed, gap=choice, cooperate_with=coop,
        reason=f"lane {target}: gap {choice.index} {choice.relation}, {choice.offset:+.1f} m",
        leader_speed=d.leader_speed,
    )


def has_room(sv: SVView, traffic: TrafficView, k: int, cfg: GapConfig,
             follower: FollowerModel) -> bool:
    """Whether TV `k` (behind the SV in the target lane) already has room for the SV
    entering beside it now: its bumper gap to the SV's rear is at least the slot's
    rear end (its accepted gap at `GapConfig.entry_decel` plus what it closes before
    the SV enters, `slot_ends`). Such a TV is not asked to open a gap: its openGap
    would only make it brake for nothing (issue 22: 0.56-0.62 m/s^2 in every run)."""
    lo, _ = slot_ends(float(traffic.x[k]) + 0.5 * float(traffic.length[k]),
                      float(traffic.speed[k]), math.inf, math.inf, sv.speed, sv.speed,
                      sv.length, cfg, follower)
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
    """Which TVs' bodies touch `lane` (a TV half way through a change is in both)."""
    lo, hi = lanes.lanes_touched(traffic.y, 0.5 * np.asarray(traffic.width, dtype=float))
    return (lo <= lane) & (hi >= lane)
