"""When the SV in traffic wants to change lanes, and how it follows when it keeps its lane.

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

Vehicles are numpy arrays (one entry per TV); the leader / follower search is a
compiled loop over them (cosim.proximity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.params import RoadParams
from cosim.proximity import lane_neighbours

Array = NDArray[np.float64]


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


@dataclass(frozen=True)
class Neighbours:
    """Nearest vehicles ahead and behind the SV in one lane (index -1: none)."""

    lane: int
    leader: int  # index into the TV arrays, -1: none
    gap_ahead: float  # m, bumper to bumper (inf: none)
    leader_speed: float  # m/s (nan: none)
    follower: int  # index, -1: none
    gap_behind: float  # m (inf: none)
    follower_speed: float  # m/s (nan: none)


def lanes_touched(y: ArrayLike, half_width: ArrayLike, road: RoadParams) -> tuple[Array, Array]:
    """Lowest and highest lane index each rectangle's lateral extent touches."""
    yy = np.asarray(y, dtype=float)
    hw = np.asarray(half_width, dtype=float)
    lo = np.floor((yy - hw - road.y_right) / road.lane_width)
    hi = np.floor((yy + hw - road.y_right) / road.lane_width)
    return lo, hi


def neighbours(
    lane: int,
    sv_x: float,
    sv_length: float,
    tv_x: ArrayLike,
    tv_y: ArrayLike,
    tv_speed: ArrayLike,
    tv_length: ArrayLike,
    tv_width: ArrayLike,
    road: RoadParams,
    tv_lateral_speed: ArrayLike | None = None,
) -> Neighbours:
    """The SV's leader and follower in `lane` (TVs touching that lane).

    With `tv_lateral_speed` (m/s, + left), a TV whose centre is already in
    another lane and that moves away from `lane` does not count (it is leaving)."""
    def arr(a: ArrayLike) -> Array:
        return np.ascontiguousarray(a, dtype=float)

    v = arr(tv_speed)
    use_vy = tv_lateral_speed is not None
    i_lead, gap_ahead, i_foll, gap_behind = lane_neighbours(
        int(lane), float(sv_x), float(sv_length), arr(tv_x), arr(tv_y), arr(tv_length),
        arr(tv_width), float(road.y_right), float(road.lane_width),
        arr(tv_lateral_speed) if use_vy else np.zeros(0), use_vy)
    return Neighbours(
        lane=lane,
        leader=i_lead,
        gap_ahead=float(gap_ahead),
        leader_speed=float(v[i_lead]) if i_lead >= 0 else math.nan,
        follower=i_foll,
        gap_behind=float(gap_behind),
        follower_speed=float(v[i_foll]) if i_foll >= 0 else math.nan,
    )


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
    return float(max(cfg.idm_accel * (free - interaction), -cfg.max_brake))


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


def decide(
    sv_x: float,
    sv_y: float,
    sv_speed: float,
    sv_length: float,
    desired_speed: float,
    tv_x: ArrayLike,
    tv_y: ArrayLike,
    tv_speed: ArrayLike,
    tv_length: ArrayLike,
    tv_width: ArrayLike,
    road: RoadParams,
    cfg: DecisionConfig,
    *,
    allow_change: bool = True,
    tv_lateral_speed: ArrayLike | None = None,
) -> Decision:
    """The rule of the module docstring, for an SV at (sv_x, sv_y) driving sv_speed.

    `tv_lateral_speed` (m/s, + left): a TV leaving the SV's lane is not its leader
    (target lanes still count every TV touching them)."""
    lane = road.lane_of(sv_y)
    args = (sv_x, sv_length, tv_x, tv_y, tv_speed, tv_length, tv_width, road)
    own = neighbours(lane, *args, tv_lateral_speed)
    lead_v = own.leader_speed if own.leader >= 0 else math.inf
    within = own.gap_ahead <= cfg.look_ahead
    accel = idm_acceleration(sv_speed, desired_speed, own.gap_ahead, lead_v, cfg)
    slow_leader = within and lead_v < desired_speed - cfg.speed_margin
    if not (allow_change and slow_leader):
        reason = "slow leader, waiting" if slow_leader else "keep lane"
        return Decision(None, accel, own.gap_ahead, reason)
    for target in (lane + 1, lane - 1):  # left (overtaking) first
        if not 0 <= target < road.n_lanes:
            continue
        n = neighbours(target, *args)
        lane_speed = road.speed_bands[target][1]
        if n.leader >= 0 and n.gap_ahead <= cfg.look_ahead:
            lane_speed = min(lane_speed, n.leader_speed)
        if lane_speed < lead_v + cfg.speed_margin:
            continue
        if lane_free(n, sv_speed, cfg, road.target_speed(lane, target)):
            return Decision(target, accel, own.gap_ahead, f"slow leader, lane {target} free")
    return Decision(None, accel, own.gap_ahead, "slow leader, no free faster lane")


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

    def planning_failed(self, t: float) -> None:
        self.next_retry = t + self.cfg.retry_interval

    def manoeuvre_done(self, t: float) -> None:
        self.next_decision = t + self.cfg.cooldown
