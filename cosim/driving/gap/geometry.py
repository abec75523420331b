"""Which gap in the target lane the SV aims for, the speed that takes it there, and
when it is reached so that the paper's manoeuvre can be planned into it (beyond the
paper, whose SV starts its change where it is, at the band rule's vxf).

The target lane's vehicles, sorted by x, leave n + 1 gaps: gap j lies between
vehicle j - 1 (its follower; none for j = 0) and vehicle j (its leader; none for
j = n). Each gap moves: its speed v_g is its leader's speed within the lane's band
(the band rule's target speed without a leader): the speed the SV ends its change at
(the manoeuvre's vxf), so it never closes on its new leader.

Where the SV may start its change (its centre x, a *slot* [lo, hi] moving with
the gap, arrays over gaps):
- behind the leader: its front at least the SV's secure gap behind the leader's rear
  (Krauss's secure gap, `interaction.secure_gap`, with the SV's own headway),
- ahead of the follower: its rear at least the gap at which the follower, by its
  model (SUMO's Krauss by default), brakes no harder than `entry_decel` (0.5 m/s^2,
  about its own dawdling) when the SV enters (`interaction.accepted_gap`; the plan's
  check keeps MOBIL's b_safe as the hard limit) ahead of the follower's
  front, plus what a faster follower closes before then: the SV enters the lane
  about `entry_delay` after the start of its change and SUMO's follower does not see
  it before (SUMO_NOTES.md), while it slows for its own leader, the gap's: half the
  speed difference on average. `interaction.check_follower` checks the planned
  manoeuvre itself.

Approach: the SV aims at the point of the slot nearest to it, inside by `margin` or
`margin_share` of the slot's length (a buffer for the planner's tau); the
relative motion (SV minus gap) is a double integrator, and `reach_time` is its
time-optimal transfer to rest at the aim under the approach acceleration bound,
no sooner than the SV's own lane's speed limit lets it close on a gap ahead.
The chosen gap is the cheapest (`gap_cost`: the reach time plus the speed the SV,
its own lane's followers and its new follower give up, so the gap reached first
when nobody has to brake; ties: the one whose speed is nearest the SV's desired
speed); a gap whose slot is shorter than the SV needs, that closes before it is
reached, that lies beyond the SV's own leader, that moves ahead at or above the
SV's own lane's limit (out of reach), or whose aim is more than `reach` away (the
open ends of the lane are open only as far as the SV sees) is not a candidate.
The target speed takes the SV to the aim and brakes it to the gap's speed as it
arrives: v_g + sign(e) min(|e| / approach_time, sqrt(2 a |e|), max_rel_speed) (near
the aim a first-order approach, farther the curve along which the relative speed can
still be braked away at a, far away a bounded relative speed). When to plan is
`entry_test`'s (a change started now, predicted to its entry into the lane); the
chosen gap only steers the approach. The gap is *reachable* (no courtesy asked of its
follower then) when the SV is inside the slot recomputed for the speed it will have
when it enters the lane (half way from its speed to v_g: the manoeuvre changes speed
from vx0 to vxf), within `max_speed_change` of v_g.

Vehicles are arrays (one entry per TV or gap); no Python loop over vehicles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.driving.manoeuvre import PLANNER_MIN_SPEED
from cosim.driving.view import SVView
from cosim.planning.interaction import (
    FollowerModel,
    LaneTraffic,
    accepted_gap,
    check_follower,
    krauss_safe_speed,
    secure_gap,
)
from cosim.planning.trajectory import LaneChangeTrajectory

Array = NDArray[np.float64]

MIN_CLOSING = 0.2  # m/s, a gap ahead the SV closes on slower than this is out of reach


@dataclass(frozen=True)
class GapConfig:
    """Gap choice and approach settings (SI units)."""

    approach_accel: float = 1.5  # m/s^2, bound on the relative acceleration of the approach
    approach_time: float = 1.5  # s, time constant of the approach near the aim (a gap
    # behind, or the TV ahead in a slower target lane to drop back behind: the entry test
    # passes sooner the sooner the SV has fallen back, its plan speeding up to the gap's
    # speed again)
    # tuned: docs/tuned_constants.md
    max_rel_speed: float = 6.0  # m/s, largest speed relative to the gap while approaching
    speed_time: float = 0.5  # s, time constant of the SV's speed toward the approach speed
    # (the SV reaches its lane's limit, where a faster follower lets it in, sooner)
    # tuned: docs/tuned_constants.md
    headway: float = 0.6  # s, the SV's headway behind its new leader when it goes: the
    # slot's front end is the SV's Krauss secure gap with this tau (SUMO's lane changer
    # asks its own changers for the same with SUMO's tau 1 s: MSLaneChanger::checkChange,
    # secureFrontGap); from it the SV's car following (IDM + CAH,
    # DecisionConfig.idm_coolness) reopens its gap braking less than `comfort_decel`
    # while the new leader keeps its speed; a longer headway leaves no slot in the gaps
    # of dense fast traffic
    # tuned: docs/tuned_constants.md
    comfort_decel: float = 2.0  # m/s^2, the SV's comfortable braking limit after a merge
    # (the IDM's b, MOBIL's comfortable deceleration): the slot's headway keeps within it
    approach_decel: float = 3.5  # m/s^2, the hardest the SV brakes toward the approach
    # speed while it seeks a gap (a target lane much slower than its own, a gap behind):
    # ACC's 3.5 m/s^2 limit above 20 m/s (ISO 15622), below SUMO's own driver's decel
    # (4.5), which matches a slower target lane before it changes
    # tuned: docs/tuned_constants.md
    min_gap: float = 2.5  # m, the SV's standstill gap to its new leader
    decel: float = 4.5  # m/s^2, the SV's braking assumed in its secure gap
    margin: float = 2.0  # m, aim at least this far inside the slot's ends ...
    margin_share: float = 0.25  # -, ... or this share of the slot's length (half at most)
    entry_delay: float = 3.0  # s, from the start of the change to the SV entering the lane
    max_speed_change: float = 8.0  # m/s, largest |v_sv - v_g| to plan a change from
    horizon: float = 8.0  # s, gaps reached later are not candidates: without a gap in
    # reach the SV paces the lane and asks for room instead of dropping back far
    # tuned: docs/tuned_constants.md
    reach: float = 80.0  # m, nor gaps whose aim is farther (the lane is seen to ~150 m)
    min_speed: float = PLANNER_MIN_SPEED  # m/s, no lane change is planned below this,
    # nor into a gap moving slower (a crawling queue: every candidate hits it, found late)
    follow_tau: float = 1.0  # s, the SV's Krauss headway behind its own leader while seeking
    # (SUMO's tau: SUMO's own SV closes up this far before it changes lanes)
    follow_decel: float = 4.5  # m/s^2, the braking assumed of the SV and its own leader then
    entry_decel: float = 0.5  # m/s^2, the most a slot lets the SV's entry ask of its new
    # follower (SUMO's own changer waits for the follower's secure gap: none); the plan's
    # check keeps MOBIL's b_safe as the hard limit
    plan_decel: float = 1.0  # m/s^2, the most a flown plan may ask of its new follower as
    # predicted (within b_safe)
    patience: float = 0.5  # s, after seeking this long without an entry within plan_decel,
    # the SV takes one that asks its new follower up to `insist_decel` (SUMO's own driver
    # goes at once into gaps whose follower then brakes at its full decel)
    # tuned: docs/tuned_constants.md
    insist_decel: float = 2.0  # m/s^2, that limit: a comfortable deceleration (the IDM's
    # b, the courtesy's COURTESY_DECEL), so that with SUMO's dawdling (up to 0.52 m/s^2)
    # the new follower brakes less than 3 m/s^2; an entry that makes it brake at its
    # decel (4.5) at once is never taken
    # tuned: docs/tuned_constants.md
    hold_after: float = 0.7  # s, after seeking this long a scripted change also takes an
    # entry that counts on the TVs yielding to the SV braking on as they do until it is
    # in their lane (their courtesy held, GapDecision.held); sooner, an entry that asks
    # nothing of them would often have come
    # tuned: docs/tuned_constants.md
    insist_margin: float = 1.0  # m/s, an insisted entry must hold with the TVs behind
    # the SV this much faster as well (SUMO's dawdling and acceleration since the last
    # sample are not in the prediction)
    # tuned: docs/tuned_constants.md
    ask_decel: float = math.inf  # m/s^2, with no gap in reach, the TV asked to make room
    # is the nearest behind the SV that can still fall back behind its rear braking this
    # hard (inf: the nearest; a mandatory change: the courtesy's, decision.mandatory_config)
    wary_share: float = 0.7  # -, a new follower refused moments ago (`wary_memory`) is
    # taken only if it is asked for at most this share of the limit ...
    wary_gap: float = 1.0  # m, ... and kept this much farther than its minimum gap: the
    # entry rule's hysteresis (a refusal does not flip to an acceptance a step later on a
    # prediction that moved by a few cm/s)
    wary_memory: float = 1.0  # s, how long a refused follower is remembered
    # tuned: docs/tuned_constants.md
    nominal_tau: float = 3.45  # s, the manoeuvre's duration the entry test assumes (the
    # planner's eq. 13 optimum at the speeds of motorway traffic)
    # tuned: docs/tuned_constants.md
    max_tau: float = 3.0  # s, the longest manoeuvre it plans when a shorter one is free
    # (SUMO's drivers' change: the SV's centre crosses the line 1.5 s after the start, its
    # peak lateral acceleration 2.4 m/s^2 on a 3.75 m lane; eq. 13 on a wet road, mu 0.4,
    # asks for 8-9 s); the entry test keeps nominal_tau (a shorter nominal manoeuvre
    # enters closer to a faster follower and is taken later)
    # tuned: docs/tuned_constants.md
    merge_max_tau: float = 3.5  # s, a mandatory change's longest (a merge from a lane that
    # ends): the cap the merge study's distance left at the merge was measured with

    def follow_model(self) -> FollowerModel:
        """The SV as a Krauss follower of its own leader while it seeks a gap."""
        return FollowerModel(decel=self.follow_decel, tau=self.follow_tau,
                             min_gap=self.min_gap, leader_decel=self.follow_decel)

    def sv_model(self) -> FollowerModel:
        """The SV as a Krauss follower of its new leader (for its secure gap)."""
        return FollowerModel(decel=self.decel, tau=self.headway, min_gap=self.min_gap)


@dataclass(frozen=True)
class TargetLane:
    """The lane the SV wants: its TVs and its speeds."""

    tvs: LaneTraffic  # the TVs (`tvs.in_target`: those in this lane)
    lane_speed: float  # m/s, the speed of the lane open ahead (the band rule's target speed)
    max_speed: float = math.inf  # m/s, caps the TVs' speeds as gap speeds (the lane's band)


@dataclass(frozen=True)
class Gaps:
    """The target lane's gaps at the current time (arrays over the n + 1 gaps)."""

    follower: NDArray[np.int64]  # index into the caller's TV arrays, -1: none
    leader: NDArray[np.int64]  # index, -1: none
    lo: Array  # m, the slot's rear end (the SV's centre x), -inf: no follower
    hi: Array  # m, the slot's front end, +inf: no leader
    v_lo: Array  # m/s, speed of the rear end (the follower's speed)
    v_hi: Array  # m/s, speed of the front end (the leader's speed)
    speed: Array  # m/s, v_g: the gap's speed, the manoeuvre's vxf
    rear: Array  # m, the follower's front bumper x (-inf: none)
    front: Array  # m, the leader's rear bumper x (+inf: none)


def lane_gaps(sv_length: float, lane: TargetLane, cfg: GapConfig,
              follower: FollowerModel) -> Gaps:
    """The gaps between the TVs of the target `lane`, for an SV of `sv_length` (m)."""
    tvs = lane.tvs
    x = np.asarray(tvs.x, dtype=float)
    idx = np.flatnonzero(np.asarray(tvs.in_target, dtype=bool))
    idx = idx[np.argsort(x[idx], kind="stable")]
    xs = x[idx]
    vs = np.asarray(tvs.speed, dtype=float)[idx]
    ls = np.asarray(tvs.length, dtype=float)[idx]
    none = np.array([-1])
    fol = np.concatenate([none, idx])
    lead = np.concatenate([idx, none])
    v_f = np.concatenate([[math.nan], vs])
    v_l = np.concatenate([vs, [math.nan]])
    speed = np.where(np.isnan(v_l), lane.lane_speed,
                     np.minimum(v_l, max(lane.max_speed, lane.lane_speed)))
    lo_in = slot_rear(xs + 0.5 * ls, vs, speed[1:], sv_length, cfg, follower)
    hi_in = slot_front(xs - 0.5 * ls, vs, speed[:-1], sv_length, cfg)
    return Gaps(
        rear=np.concatenate([[-math.inf], xs + 0.5 * ls]),
        front=np.concatenate([xs - 0.5 * ls, [math.inf]]),
        follower=fol, leader=lead,
        lo=np.concatenate([[-math.inf], lo_in]), hi=np.concatenate([hi_in, [math.inf]]),
        v_lo=np.where(np.isnan(v_f), speed, v_f), v_hi=np.where(np.isnan(v_l), speed, v_l),
        speed=speed,
    )


def slot_rear(rear: ArrayLike, v_f: ArrayLike, v_sv: ArrayLike, sv_length: float,
              cfg: GapConfig, follower: FollowerModel) -> Array:
    """m, the slot's rear end: the SV's centre x at least this far ahead of a follower
    whose front is at `rear` driving v_f: its accepted gap to the SV at `v_sv` (braking
    at most `entry_decel`), plus what it closes before the SV enters."""
    half = 0.5 * sv_length
    slot_follower = follower.limited(cfg.entry_decel)
    vf = np.asarray(v_f, dtype=float)
    vsf = np.asarray(v_sv, dtype=float)
    closing = 0.5 * np.maximum(vf - vsf, 0.0) * cfg.entry_delay
    return np.asarray(rear, dtype=float) + accepted_gap(vf, vsf, slot_follower) + closing + half


def slot_front(front: ArrayLike, v_l: ArrayLike, v_sv: ArrayLike, sv_length: float,
               cfg: GapConfig) -> Array:
    """m, the slot's front end: the SV's centre x at most this, behind a leader whose
    rear is at `front` driving v_l (the SV's own secure gap at `v_sv`)."""
    return np.asarray(front, dtype=float) - secure_gap(v_sv, v_l, cfg.sv_model()) - 0.5 * sv_length


def reach_time(offset: ArrayLike, rel_speed: ArrayLike, accel: float) -> Array:
    """s, the shortest time to move a double integrator by `offset` (m, + ahead) from
    relative speed `rel_speed` (m/s) to rest, with |acceleration| <= accel (bang-bang:
    one switch on the parabola p = -u |u| / (2 a))."""
    e = np.asarray(offset, dtype=float)
    u = np.asarray(rel_speed, dtype=float)
    p = -e  # position relative to the aim
    s = p + u * np.abs(u) / (2.0 * accel)  # > 0: above the switching curve, brake first
    above = np.sqrt(np.maximum(accel * p + 0.5 * u * u, 0.0))
    below = np.sqrt(np.maximum(-accel * p + 0.5 * u * u, 0.0))
    return np.where(s > 0.0, (u + 2.0 * above) / accel, (-u + 2.0 * below) / accel)


def seeking_accel(sv_speed: float, target_speed: float, max_speed: float,
                  leader_gap: float, leader_speed: float, cfg: GapConfig) -> float:
    """m/s^2, the SV's acceleration while it seeks a gap: toward `target_speed` (the
    approach speed, m/s) but no faster than `max_speed` (its own lane's limit) and
    than Krauss's safe speed behind its own leader (bumper gap `leader_gap`, m, inf:
    none; SUMO's tau and decel, `GapConfig.follow_model`): toward the approach speed
    within [-approach_decel, approach_accel], for that leader down to the follower
    model's decel. As SUMO's own SV does (LC2013 drives
    at its lane's speed behind its leader, Krauss-safe, before it changes), it closes
    up to its leader to reach the faster lane's speed instead of keeping its IDM's
    1.5 s time gap, which holds it below the target lane."""
    v = max(sv_speed, 0.0)
    # the approach within approach_accel and approach_decel, its own leader within
    # follow_decel
    want = min(target_speed, max_speed)
    accel = min(max((want - v) / cfg.speed_time, -cfg.approach_decel), cfg.approach_accel)
    if math.isfinite(leader_gap):
        v_safe = float(krauss_safe_speed(leader_gap, leader_speed, cfg.follow_model()))
        accel = min(accel, max((v_safe - v) / cfg.speed_time, -cfg.follow_decel))
    return accel


def approach_speed(offset: ArrayLike, gap_speed: ArrayLike, cfg: GapConfig) -> Array:
    """m/s (>= 0), the SV's target speed toward an aim `offset` (m, + ahead) in a gap
    moving at `gap_speed` (module docstring)."""
    e = np.asarray(offset, dtype=float)
    dv = np.minimum(np.minimum(np.sqrt(2.0 * cfg.approach_accel * np.abs(e)),
                               np.abs(e) / cfg.approach_time), cfg.max_rel_speed)
    return np.maximum(np.asarray(gap_speed, dtype=float) + np.sign(e) * dv, 0.0)


def gap_cost(t: ArrayLike, aim: ArrayLike, sv_x: float, sv_speed: float, sv_length: float,
             gaps: Gaps, cfg: GapConfig, follower: FollowerModel) -> Array:
    """s, what taking each gap costs the SV and the vehicles behind it (arrays over
    gaps): its reach time `t`, plus the speed the SV gives up to get there (the gap's
    speed below its own, and the relative speed of an approach from ahead: what its own
    lane's followers give up with it) and the speed the new follower gives up at once
    when the SV enters at the aim at the gap's speed (Krauss's v_safe),
    each over the approach acceleration. Without braking anywhere it is the reach time:
    the gap reached first (alongside: 0 s) is taken first."""
    aim = np.asarray(aim, dtype=float)
    e = aim - sv_x
    # the SV drops back to a gap behind at up to the approach's relative speed
    back = np.where(e < 0.0, np.minimum(np.sqrt(cfg.approach_accel * np.abs(e)),
                                        cfg.max_rel_speed), 0.0)
    shed = np.maximum(sv_speed - (gaps.speed - back), 0.0)
    has = np.isfinite(gaps.rear)
    gap_f = np.where(has, aim - 0.5 * sv_length - np.where(has, gaps.rear, 0.0), 0.0)
    v_safe = krauss_safe_speed(np.maximum(gap_f, 0.0), gaps.speed, follower)
    loss = np.where(has, np.maximum(gaps.v_lo - v_safe, 0.0), 0.0)
    return np.asarray(t, dtype=float) + (shed + loss) / cfg.approach_accel


class Relation(StrEnum):
    """Where a gap's slot is relative to the SV."""

    AHEAD = "ahead"
    ALONGSIDE = "alongside"
    BEHIND = "behind"


@dataclass(frozen=True)
class GapChoice:
    """The gap the SV aims for now."""

    index: int  # gap index (0: behind every target-lane TV)
    follower: int  # index into the caller's TV arrays, -1: none
    leader: int  # index, -1: none
    relation: Relation  # where the slot is relative to the SV
    aim_x: float  # m, the SV's centre x to start the change from (moves at `speed`)
    offset: float  # m, aim_x - sv_x
    speed: float  # m/s, the gap's speed: vxf of the manoeuvre
    reach_time: float  # s, time-optimal estimate
    target_speed: float  # m/s, what the SV should drive now to get there
    reachable: bool  # inside the slot and at the gap's speed: plan the manoeuvre now


@dataclass(frozen=True)
class OwnLane:
    """How far and how fast the SV may go in its own lane while it seeks a gap."""

    limit_x: float = math.inf  # m, the farthest its centre may get (its leader's rear less
    # half the SV and a standstill gap; inf: no leader) ...
    limit_speed: float = 0.0  # m/s, ... moving at its leader's speed
    max_speed: float = math.inf  # m/s, the most it may drive (its lane's limit)


def choose_gap(sv: SVView, gaps: Gaps, cfg: GapConfig, follower: FollowerModel,
               own: OwnLane = OwnLane()) -> GapChoice | None:
    """The cheapest gap (module docstring: `gap_cost`) for `sv` (its x, speed, length and
    desired speed), or None when no gap is a candidate: a gap ahead whose aim lies
    beyond `own.limit_x` when reached is not; a gap ahead moving at least
    `own.max_speed` cannot be reached (it would be chased for good), one moving slower
    is reached no sooner than the speed difference allows."""
    aim, t, ok = _candidates(sv, gaps, cfg, own)
    if not ok.any():
        return None
    e = aim - sv.x
    cost = np.where(ok, gap_cost(t, aim, sv.x, sv.speed, sv.length, gaps, cfg, follower)
                    + 1e-3 * np.abs(gaps.speed - sv.desired_speed), np.inf)
    j = int(np.argmin(cost))
    inside = bool(gaps.lo[j] <= sv.x <= gaps.hi[j])
    relation = (Relation.ALONGSIDE if inside
                else (Relation.AHEAD if e[j] > 0.0 else Relation.BEHIND))
    target = float(approach_speed(e[j], gaps.speed[j], cfg))
    v_g = float(gaps.speed[j])
    v_in = 0.5 * (sv.speed + v_g)  # the SV's speed when it enters the lane
    lo = slot_rear(gaps.rear[j], gaps.v_lo[j], v_in, sv.length, cfg, follower)
    hi = slot_front(gaps.front[j], gaps.v_hi[j], v_in, sv.length, cfg)
    reachable = bool(lo <= sv.x <= hi) and abs(sv.speed - v_g) <= cfg.max_speed_change
    return GapChoice(
        index=j, follower=int(gaps.follower[j]), leader=int(gaps.leader[j]),
        relation=relation, aim_x=float(aim[j]), offset=float(e[j]),
        speed=float(gaps.speed[j]), reach_time=float(t[j]), target_speed=target,
        reachable=reachable and sv.speed >= cfg.min_speed,
    )


def _candidates(sv: SVView, gaps: Gaps, cfg: GapConfig, own: OwnLane
                ) -> tuple[Array, Array, NDArray[np.bool_]]:
    """(aim, reach time, candidate) per gap: the point of each slot the SV aims at, when
    it gets there, and whether the gap is a candidate (module docstring)."""
    length = gaps.hi - gaps.lo
    room = np.maximum(length, 0.0)
    margin = np.minimum(np.maximum(cfg.margin, cfg.margin_share * np.where(
        np.isfinite(room), room, 0.0)), 0.5 * room)
    aim = np.clip(sv.x, gaps.lo + margin, gaps.hi - margin)
    e = aim - sv.x
    t = reach_time(e, sv.speed - gaps.speed, cfg.approach_accel)
    # within the SV's own speed limit the aim ahead closes at most at max_speed - v_g
    closing = own.max_speed - gaps.speed
    ahead = e > 1e-6
    t = np.where(ahead, np.where(closing > MIN_CLOSING,
                                 np.maximum(t, e / np.maximum(closing, MIN_CLOSING)), np.inf),
                 t)
    # the slot when the SV gets there: its ends move at the follower's / leader's speed
    tf = np.where(np.isfinite(t), t, 0.0)  # out of reach (inf) fails the horizon below
    lo_t = gaps.lo + gaps.v_lo * tf
    hi_t = gaps.hi + gaps.v_hi * tf
    aim_t = aim + gaps.speed * tf
    ok = (length >= 0.0) & (hi_t - lo_t >= 0.0) & (t <= cfg.horizon) & (np.abs(e) <= cfg.reach)
    ok &= (aim_t >= lo_t - 1e-6) & (aim_t <= hi_t + 1e-6)
    if math.isfinite(own.limit_x):
        ok &= (aim_t <= own.limit_x + own.limit_speed * tf) | (e <= 0.0)
    return aim, t, ok


@dataclass(frozen=True)
class ChangeStart:
    """A lane change started now, as the entry test takes it."""

    x: float  # m, the SV's centre along the road
    y: float  # m, its lateral start (the origin lane's centre)
    speed: float  # m/s
    length: float  # m
    width: float  # m, the lateral move (+ left)
    body_width: float = 0.0  # m, the SV's width (0: it enters the lane with its centre)
    accel: float = 0.0  # m/s^2, its acceleration at the start (the plan starts with it)


@dataclass(frozen=True)
class Entry:
    """A lane change started now, as the entry test predicts it (`entry_test`)."""

    ok: bool  # plan it now: its new follower and new leader both keep their limits
    vxf: float  # m/s, its end speed: the new leader's speed within the lane's band
    leader: int  # index of the TV ahead of the SV when it enters (-1: none)
    follower: int  # index of the TV behind it then (-1: none)
    t_enter: float  # s after now, when the SV enters the lane (check_follower; nan: never)
    follower_decel: float  # m/s^2, the new follower's predicted largest braking
    leader_gap: float  # m, bumper gap to the new leader at the entry (inf: none)
    secure: float  # m, the SV's secure gap to it then (GapConfig.headway)
    follower_ok: bool = True  # its new follower keeps its limits (the entry rule)


def entry_test(start: ChangeStart, lane: TargetLane, cfg: GapConfig,
               follower: FollowerModel) -> Entry:
    """Whether a lane change started now (a nominal manoeuvre of `cfg.nominal_tau` from
    the SV's speed to the new leader's) enters a usable gap in `lane`: its TVs keep
    their speeds (or go on braking at `lane.tvs.braking`: those that yield to the SV)
    until the SV enters the lane (its side across the line with `start.body_width`:
    they do not see it before, SUMO_NOTES.md); then
    - its new follower, predicted by its model (`interaction.check_follower`, `follower`
      limited to what the policy asks), keeps its minimum gap and brakes within the
      limit (the entry rule, `FollowerPrediction.safe`), and
    - its new leader's rear is at least the SV's secure gap (`GapConfig.sv_model`, the
      slot's headway) ahead of the SV's front, at the SV's speed then.
    The test of the manoeuvre itself, not of where the SV is: a gap coming up from
    behind is taken as soon as a change started now would end up in it (the paper's
    manoeuvre enters the lane only about tau / 2 after its start), and no plan is
    asked for that its own follower check would refuse (each refusal costs a retry)."""
    tvs = lane.tvs
    x = np.asarray(tvs.x, dtype=float)
    v = np.asarray(tvs.speed, dtype=float)
    half = 0.5 * np.asarray(tvs.length, dtype=float)
    inside = np.asarray(tvs.in_target, dtype=bool)
    tau = cfg.nominal_tau
    # the entry: the SV's centre half way across (the manoeuvre's lateral profile is
    # symmetric in time: at tau / 2)
    t_in = 0.5 * tau
    lead, vxf = _new_leader(start, lane, tau, t_in)
    tr = LaneChangeTrajectory(t0=0.0, tau=tau, x0=start.x, y0=start.y, vx0=start.speed,
                              vxf=vxf, width=start.width, ax0=start.accel)
    xs, _ = tr.position(t_in)
    vs, _ = tr.derivative(t_in, 1)
    x_in, v_in = float(xs), float(vs)
    if lead >= 0:
        gap = float(x[lead] - half[lead] + v[lead] * t_in - x_in - 0.5 * start.length)
        # Krauss-secure, and never closer than the headway in time (a much faster
        # leader's braking distance alone would let the SV in very close behind it)
        need = float(max(secure_gap(v_in, v[lead], cfg.sv_model()),
                         cfg.min_gap + cfg.headway * v_in))
    else:
        gap, need = math.inf, 0.0
    check = check_follower(tr, start.length, tvs, follower, sv_width=start.body_width)
    # nobody beside the SV's body at the entry (neither leader nor follower: level with it)
    beside = inside & (np.abs(x + v * t_in - x_in) < half + 0.5 * start.length)
    ok = (check.safe and not beside.any() and gap >= need
          and abs(start.speed - vxf) <= cfg.max_speed_change
          and min(start.speed, vxf) >= cfg.min_speed)
    return Entry(ok=bool(ok), vxf=vxf, leader=lead, follower=check.follower,
                 t_enter=check.t_enter, follower_decel=check.max_decel, leader_gap=gap,
                 secure=need, follower_ok=check.safe)


def _new_leader(start: ChangeStart, lane: TargetLane, tau: float, t_in: float
                ) -> tuple[int, float]:
    """(index, -1: none; the change's end speed, m/s): the TV of `lane` ahead of the SV
    when it enters at t_in of a change of `tau` at its own speed, and that TV's speed
    within the lane's band (the lane's speed without one)."""
    x = np.asarray(lane.tvs.x, dtype=float)
    v = np.asarray(lane.tvs.speed, dtype=float)
    inside = np.asarray(lane.tvs.in_target, dtype=bool)
    probe = LaneChangeTrajectory(t0=0.0, tau=tau, x0=start.x, y0=start.y, vx0=start.speed,
                                 vxf=start.speed, width=start.width, ax0=start.accel)
    x_in = float(probe.position(t_in)[0])
    ahead = inside & (x + v * t_in > x_in)
    lead = int(np.argmin(np.where(ahead, x + v * t_in, np.inf))) if ahead.any() else -1
    lane_speed, max_speed = lane.lane_speed, lane.max_speed
    vxf = float(min(v[lead], max(max_speed, lane_speed)) if lead >= 0 else lane_speed)
    return lead, vxf
