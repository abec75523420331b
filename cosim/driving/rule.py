"""The paper's trigger: when the SV in traffic wants to change lanes (the decision rule),
and how it follows when it keeps its lane (IDM).

Beyond the paper (which starts every case with "SV decides to change lanes"):

- Lane-change rule: the SV's leader (nearest vehicle ahead sharing its lane,
  within `look_ahead`) drives slower than the SV wants by more than
  `speed_margin`, and an adjacent lane (left first: overtaking; then right) is
  faster — its own leader, if any within `look_ahead`, is faster than the SV's
  leader by `speed_margin`, and its band allows more — and free enough: the gap to its
  leader at least `min_gap + time_gap_ahead * v_sv`, the gap to its follower at
  least `min_gap + time_gap_behind * v_follower + closing * closing_time` (closing:
  how much faster the follower is than the SV will be at the end of the change).
  This is a pre-filter; the planner's collision check decides.
  A TV belongs to every lane its rectangle touches (a TV half way through a
  lane change blocks both).
- Keeping the lane: the intelligent driver model (IDM, Treiber et al. 2000)
  gives an acceleration toward the desired speed with a safe gap to the
  leader; the loop turns it into a straight reference along the lane centre.
- After the planner found no collision-free tau the SV keeps its lane and asks
  again `retry_interval` later; after any manoeuvre it waits `cooldown`.

Vehicles are numpy arrays (one entry per TV, cosim.driving.view.TrafficView); the leader /
follower search along a lane is the lane layout's (cosim.driving.layout, a compiled loop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cosim.driving.layout import LaneLayout, Neighbours
from cosim.driving.view import SVView, TrafficView


@dataclass(frozen=True)
class DecisionConfig:
    """Decision rule and car-following (IDM) settings."""

    speed_margin: float = 2.0  # m/s, leader slower than desired by more than this: overtake
    look_ahead: float = 100.0  # m, bumper-to-bumper gap within which a vehicle is a leader
    min_gap: float = 5.0  # m, smallest gap ahead/behind in the target lane
    time_gap_ahead: float = 0.5  # s, extra gap ahead per m/s of the SV's speed
    time_gap_behind: float = 0.5  # s, extra gap behind per m/s of the follower's speed
    closing_time: float = 2.0  # s, how long a faster follower closes in on the SV
    retry_interval: float = 1.0  # s, wait before planning again after a failure
    cooldown: float = 3.0  # s, wait after a manoeuvre before the next request
    idm_accel: float = 1.0  # m/s^2, IDM maximum acceleration a
    idm_decel: float = 2.0  # m/s^2, IDM comfortable deceleration b
    idm_time_gap: float = 1.5  # s, IDM desired time headway T
    idm_min_gap: float = 2.0  # m, IDM standstill gap s0
    idm_delta: float = 4.0  # -, IDM acceleration exponent
    max_brake: float = 8.0  # m/s^2, the IDM deceleration is clipped here
    idm_coolness: float = 0.0  # -, c of Kesting-Treiber-Helbing's ACC model (IDM + the
    # constant-acceleration heuristic, 2010): 0 plain IDM (the paper's rule), 0.99 the
    # ACC model's value: a small gap behind a leader that is not slower (a cut-in, a
    # merge) costs about idm_decel instead of the IDM's over-reaction


def idm_acceleration(
    speed: float, desired_speed: float, gap: float, leader_speed: float, cfg: DecisionConfig
) -> float:
    """m/s^2, IDM acceleration; gap = inf (no leader) gives free-road driving."""
    v0 = max(desired_speed, 0.1)
    free = 1.0 - (max(speed, 0.0) / v0) ** cfg.idm_delta
    if math.isfinite(gap):
        dv = speed - leader_speed
        brake_term = speed * dv / (2.0 * math.sqrt(cfg.idm_accel * cfg.idm_decel))
        s_star = cfg.idm_min_gap + max(0.0, speed * cfg.idm_time_gap + brake_term)
        interaction = (s_star / max(gap, 0.1)) ** 2
    else:
        interaction = 0.0
    a_idm = cfg.idm_accel * (free - interaction)
    if cfg.idm_coolness > 0.0 and math.isfinite(gap):
        a_idm = acc_blend(a_idm, speed, gap, leader_speed, cfg)
    return float(max(a_idm, -cfg.max_brake))


def acc_blend(a_idm: float, speed: float, gap: float, leader_speed: float,
              cfg: DecisionConfig) -> float:
    """m/s^2, the ACC model's acceleration (Kesting, Treiber, Helbing 2010, "Enhanced
    intelligent driver model to access the impact of driving strategies on traffic
    capacity", Phil. Trans. R. Soc. A 368, eqs. 2.4-2.5) from the IDM's `a_idm`: where
    the IDM brakes harder than the constant-acceleration heuristic (CAH: what keeps
    the gap from closing if the leader keeps its speed; the leader's acceleration is
    not measured here and taken as 0, the heuristic's conservative case for a leader
    that does not brake), the two are blended with coolness c so that braking beyond
    the CAH is limited to about idm_decel (tanh); a leader that brakes makes the CAH,
    and so the ACC, brake too (the closing speed enters it)."""
    closing = max(speed, 0.0) - max(leader_speed, 0.0)
    # CAH with the leader's acceleration 0: 0 while the gap does not close, else the
    # braking that matches the leader's speed within the gap
    a_cah = -closing * closing / (2.0 * max(gap, 0.1)) if closing > 0.0 else 0.0
    if a_idm >= a_cah:
        return a_idm
    c, b = cfg.idm_coolness, cfg.idm_decel
    return (1.0 - c) * a_idm + c * (a_cah + b * math.tanh((a_idm - a_cah) / b))


def lane_free(n: Neighbours, sv_speed: float, cfg: DecisionConfig,
              end_speed: float | None = None) -> bool:
    """Enough room ahead and behind in a lane to start a lane change into it.

    Ahead: min_gap + time_gap_ahead * v_sv. Behind: min_gap + time_gap_behind *
    v_follower, plus what a faster follower closes in half a typical lane change
    (`closing_time`) on the SV, which will be at `end_speed` (the band rule's
    target speed) by the end of the change."""
    need_ahead = cfg.min_gap + cfg.time_gap_ahead * sv_speed
    ok_ahead = n.gap_ahead >= need_ahead
    if n.follower < 0:
        return bool(ok_ahead)
    v_end = max(sv_speed, end_speed if end_speed is not None else sv_speed)
    closing = max(n.follower_speed - v_end, 0.0)
    need_behind = (cfg.min_gap + cfg.time_gap_behind * n.follower_speed
                   + closing * cfg.closing_time)
    return bool(ok_ahead and n.gap_behind >= need_behind)


@dataclass(frozen=True)
class Decision:
    """What the SV does this step when it is not changing lanes."""

    target_lane: int | None  # SUMO index to request a lane change to, None: keep lane
    accel: float  # m/s^2, car-following acceleration in the current lane (IDM)
    leader_gap: float  # m, bumper-to-bumper gap to the leader (inf: none)
    reason: str  # why (for the trace / plans log)
    leader_speed: float = math.inf  # m/s, the leader's speed (inf: none)


def decide(sv: SVView, traffic: TrafficView, lanes: LaneLayout, cfg: DecisionConfig, *,
           allow_change: bool = True) -> Decision:
    """The rule of the module docstring for `sv` among `traffic` (a TV leaving the
    SV's lane, by its lateral speed, is not its leader; target lanes still count
    every TV touching them)."""
    lane = lanes.lane_of(sv.y)
    own = neighbours(lane, sv, traffic, lanes, leaving=True)
    lead_v = own.leader_speed if own.leader >= 0 else math.inf
    within = own.gap_ahead <= cfg.look_ahead
    accel = idm_acceleration(sv.speed, sv.desired_speed, own.gap_ahead, lead_v, cfg)
    slow_leader = within and lead_v < sv.desired_speed - cfg.speed_margin
    if not (allow_change and slow_leader):
        reason = "slow leader, waiting" if slow_leader else "keep lane"
        return Decision(None, accel, own.gap_ahead, reason, lead_v)
    for target in (lane + 1, lane - 1):  # left (overtaking) first
        if not 0 <= target < lanes.n_lanes:
            continue
        n = neighbours(target, sv, traffic, lanes)
        lane_speed = lanes.speed_limit(target)
        if n.leader >= 0 and n.gap_ahead <= cfg.look_ahead:
            lane_speed = min(lane_speed, n.leader_speed)
        if lane_speed < lead_v + cfg.speed_margin:
            continue
        if lane_free(n, sv.speed, cfg, lanes.end_speed(lane, target)):
            return Decision(target, accel, own.gap_ahead, f"slow leader, lane {target} free",
                            lead_v)
    return Decision(None, accel, own.gap_ahead, "slow leader, no free faster lane", lead_v)


def neighbours(lane: int, sv: SVView, traffic: TrafficView, lanes: LaneLayout, *,
               leaving: bool = False) -> Neighbours:
    """The SV's leader and follower in `lane` (`leaving`: a TV moving out of the lane,
    by its lateral speed when known, does not count)."""
    return lanes.neighbours(lane, sv.x, sv.length, traffic, leaving=leaving)
