"""The lane-change planner: cluster -> stable set -> TV futures -> collision-free set -> tau.

Sections 2-3 of the paper put together: the trajectory cluster over tau (eq. 2,
4), the handling envelope's stable set (eq. 5-8), the TVs' predicted futures
(C1-C3), the collision check (eq. 9-11; exact by default), and the choice of tau
(eq. 13, 35). `LaneChangePlanner.plan` returns a `Plan` that says what it chose
and why every other tau was rejected; `check` re-tests a committed trajectory
against fresh messages.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from cosim.errors import InputError
from cosim.params import G, PlannerConfig, RoadParams, VehicleParams
from cosim.planning.collision import (
    COLLISION_TESTS,
    CollisionTest,
    SVCandidates,
    TVHypotheses,
    check_candidates,
)
from cosim.planning.deadline import merging_messages
from cosim.planning.envelope import (
    ENVELOPES,
    MODES,
    YAW_MODELS,
    StableSet,
    TauMinMap,
    envelope_margin,
    fill_maps,
    stable_set,
)
from cosim.planning.prediction import (
    C2Options,
    LazyFutures,
    TVFutures,
    c2_lanes,
    constant_acceleration,
    predict_lazy,
)
from cosim.planning.selection import choose, intervals, omega
from cosim.planning.trajectory import (
    BoundaryConditions,
    LaneChangeTrajectory,
    cluster_derivatives,
    longitudinal_coefficients,
)
from cosim.road.frame import distortion_margin
from cosim.traffic.v2v import V2VMessage

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

COLLISION_STEP = 0.05  # s, sample step of the collision check (continuous: see collision.py)
MAP_WIDTH_TOLERANCE = 0.02  # m, widths this close to a lane width use the tau_min maps
# how long a slower vehicle ahead in the target lane is looked at (`_follow_horizon`)
FOLLOW_STANDSTILL_M = 2.0  # m, gap kept at standstill
FOLLOW_HEADWAY_S = 1.0  # s, time gap kept behind it
FOLLOW_DECEL_G = 0.3  # -, share of mu g the SV brakes with to fall in behind it
HORIZON_CAP_S = 30.0  # s, at most this much past the usual horizon
LANE_END = "lane end"  # a Rejection's reason: the plan would end past `plan`'s x_limit


@dataclass(frozen=True)
class SVPlanState:
    """The subject vehicle's state when it plans."""

    x: float  # m, global x of the CG
    y: float  # m, global y of the CG (the lateral start of the plan)
    heading: float  # rad
    vx: float  # m/s, longitudinal speed
    ax: float  # m/s^2, longitudinal acceleration
    vy: float  # m/s, lateral speed (+ left)
    ay: float  # m/s^2, lateral acceleration
    lane: int  # SUMO index of the origin lane

    def boundary(self, vxf: float, width: float) -> BoundaryConditions:
        """The SV's cluster from this state: to speed vxf (m/s), `width` (m) to the side."""
        return BoundaryConditions(self.vx, vxf, width, self.ax, self.vy, self.ay)


@dataclass(frozen=True)
class PredictionOptions:
    """How the planner predicts the TVs, beyond the paper's C1-C3, as a policy needs it
    (cosim.driving: each policy class names its own)."""

    # a C2 TV ends its change no faster than its leader in the target lane (the gap
    # policy's own rule for its SV: cosim.planning.prediction.predict_lazy)
    gap_end_speed: bool = False


class Rejection(NamedTuple):
    """Why one tau was not taken (a named tuple: a plan holds one per rejected tau)."""

    tau: float  # s
    reason: str  # "unstable" | "collision" | LANE_END
    vehicle_id: str | None = None  # the TV it would hit first
    time: float | None = None  # s, simulation time of that first overlap


@dataclass(frozen=True)
class Plan:
    """The outcome of one planning call."""

    t: float  # s, simulation time of the plan
    origin_lane: int
    target_lane: int
    taus: Array  # s, the tau grid (n_tau,)
    stable: NDArray[np.bool_]  # (n_tau,) inside the handling envelope
    collision_free: NDArray[np.bool_]  # (n_tau,) stable and collision-free
    tau_min: float  # s, shortest stable tau (nan: none)
    tau_max: float  # s
    omega: float  # -, eq. 35 (clipped)
    tau_opt: float  # s, eq. 13 over the collision-free set (nan: empty)
    tau: float | None  # s, chosen; None: keep the lane
    trajectory: LaneChangeTrajectory | None
    hit_vehicle: IntArray  # (n_tau,) index into vehicle_ids of the TV hit first (-1: none)
    hit_time: Array  # s, (n_tau,) simulation time of that first overlap (nan: none)
    planning_time_s: float  # s, wall time of plan()
    vxf: float = math.nan  # m/s, target speed of the lane change
    vehicle_ids: tuple[str, ...] = ()  # the TVs planned against
    tv_categories: tuple[str, ...] = ()  # "C1" | "C2" | "C3" of each
    # the TVs' futures (LazyFutures: arrays x, y, heading computed on first access)
    futures: TVFutures | LazyFutures | None = field(default=None, repr=False, compare=False)
    sv: SVPlanState | None = field(default=None, repr=False, compare=False)  # planned from
    # (n_tau,) stable but ending past the plan's `x_limit` (a lane that ends; None: no limit)
    late: NDArray[np.bool_] | None = field(default=None, repr=False, compare=False)

    @functools.cached_property
    def categories(self) -> dict[str, str]:
        """TV id -> "C1" | "C2" | "C3"."""
        return dict(zip(self.vehicle_ids, self.tv_categories, strict=True))

    @functools.cached_property
    def stable_intervals(self) -> list[tuple[float, float]]:
        """s, the stable set as intervals."""
        return intervals(self.taus, self.stable)

    @functools.cached_property
    def collision_free_intervals(self) -> list[tuple[float, float]]:
        """s, the collision-free set as intervals."""
        return intervals(self.taus, self.collision_free)

    @functools.cached_property
    def rejections(self) -> list[Rejection]:
        """Why each tau not collision-free was rejected, in tau order."""
        ids = self.vehicle_ids
        off = ~self.collision_free
        late = (self.late[off] if self.late is not None
                else np.zeros(int(off.sum()), dtype=bool)).tolist()
        return [
            Rejection(tau, "unstable") if not stable
            else Rejection(tau, LANE_END) if past
            else Rejection(tau, "collision", ids[v], when)
            for tau, stable, past, v, when in zip(
                self.taus[off].tolist(), self.stable[off].tolist(), late,
                self.hit_vehicle[off].tolist(), self.hit_time[off].tolist(), strict=True)
        ]

    @property
    def feasible(self) -> bool:
        """A collision-free tau exists (otherwise: keep the lane)."""
        return self.tau is not None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays of the grid; intervals as [lo, hi] lists)."""

        def num(v: float | None) -> float | None:
            return None if v is None or not math.isfinite(v) else round(float(v), 6)

        return {
            "t": num(self.t),
            "origin_lane": self.origin_lane,
            "target_lane": self.target_lane,
            "tau_min": num(self.tau_min),
            "tau_max": num(self.tau_max),
            "tau_step": num(float(np.median(np.diff(self.taus)))) if self.taus.size > 1 else None,
            "stable": [[num(a), num(b)] for a, b in self.stable_intervals],
            "collision_free": [[num(a), num(b)] for a, b in self.collision_free_intervals],
            "omega": num(self.omega),
            "tau_opt": num(self.tau_opt),
            "tau": num(self.tau),
            "feasible": self.feasible,
            "vxf": num(self.vxf),
            "categories": dict(self.categories),
            "planning_time_s": self.planning_time_s,
            "rejected": [
                {"tau": num(r.tau), "reason": r.reason, "vehicle_id": r.vehicle_id,
                 "time": num(r.time)}
                for r in self.rejections
            ],
        }


@dataclass(frozen=True)
class RoadCurve:
    """How the road frame bends where the SV plans (cosim.road.frame): the plans are
    made in (s, d) as on a straight road; these bound what that leaves out."""

    kappa: float  # 1/m, the reference line's largest |curvature| along the route
    d_abs: float  # m, the largest |offset| of a lane's edge from the reference line
    top_speed: float  # m/s, the fastest the SV drives (its lanes' top band speed)
    tv_half_diagonal: float  # m, the largest traffic vehicle's half-diagonal

    def margin(self, vehicle: VehicleParams) -> float:
        """m, each check rectangle grown by this keeps the (s, d) test sound in the
        Cartesian plane (`frame.distortion_margin` for the larger body at d_abs)."""
        r = max(0.5 * math.hypot(vehicle.length, vehicle.width), self.tv_half_diagonal)
        return float(distortion_margin(self.kappa, self.d_abs, r))

    def friction(self, road: RoadParams) -> float:
        """-, the friction the SV's lane change may use: the curve takes top_speed^2 kappa
        of lateral acceleration at its tightest, what the friction circle leaves is
        sqrt(mu^2 - (v^2 kappa / g)^2) (one value per run: the tau_min maps are built
        per friction)."""
        used = self.top_speed**2 * self.kappa / G
        if used >= road.mu:
            raise InputError("road", "curvature", f"R {1.0 / self.kappa:.0f} m",
                             f"curves the SV can drive at {self.top_speed:.1f} m/s on mu "
                             f"{road.mu:g} (R >= {self.top_speed**2 / (road.mu * G):.0f} m)")
        return math.sqrt(road.mu**2 - used**2)


class LaneChangePlanner:
    """Plans a lane change of one vehicle (Sections 2-3)."""

    def __init__(
        self, vehicle: VehicleParams, road: RoadParams, config: PlannerConfig,
        *, collision_step: float = COLLISION_STEP, use_maps: bool = True,
        prediction: PredictionOptions | None = None, curve: RoadCurve | None = None,
    ) -> None:
        """`use_maps`: take tau_min of lane changes that start from rest laterally (the
        SV from its lane centre, C2 TVs) from a `TauMinMap` built once per mode
        (eq. 7 with our envelope); starts mid-manoeuvre always run the envelope.
        `prediction`: the policy's prediction options (None: the defaults).
        `curve`: the road frame's curvature bound (None: a straight road): the plans are
        made in (s, d) with both check rectangles grown by the frame's distortion
        (`RoadCurve.margin`) and the SV's envelope on the friction the road's curve
        leaves (`RoadCurve.friction`)."""
        if config.envelope not in ENVELOPES:
            raise InputError("planner", "envelope", config.envelope, f"one of {ENVELOPES}")
        if config.collision_test not in COLLISION_TESTS:
            raise InputError("planner", "collision_test", config.collision_test,
                             f"one of {COLLISION_TESTS}")
        if not 0 < config.tau_step <= 1.0:
            raise InputError("planner", "tau_step_s", config.tau_step, "in (0, 1] s")
        if not config.tau_min_floor < config.tau_max:
            raise InputError("planner", "tau_max_s", config.tau_max,
                             f"greater than tau_min_floor ({config.tau_min_floor} s)")
        self.vehicle = vehicle
        self.road = road
        self.config = config
        self.collision_step = collision_step
        self.prediction = prediction or PredictionOptions()
        n = int(round((config.tau_max - config.tau_min_floor) / config.tau_step))
        grid = config.tau_min_floor + config.tau_step * np.arange(n + 1)
        self.grid = grid[grid <= config.tau_max + 1e-9]
        self.use_maps = use_maps and config.envelope in YAW_MODELS
        self._maps: dict[tuple[float, float], TauMinMap] = {}
        self.curve = curve
        # the SV's envelope (eq. 5-8) and the check's margin, on a curved road
        self.mu = road.mu if curve is None else curve.friction(road)
        self.margin = config.safety_margin if curve is None else (
            config.safety_margin + curve.margin(vehicle))

    # -- pieces ------------------------------------------------------------------

    def tau_min_map(self, vxf: float, width: float) -> TauMinMap:
        """The (lazily built) map vx0 -> tau_min for this target speed and width."""
        key = (round(vxf, 9), round(width, 9))
        if key not in self._maps:
            cfg = self.config
            self._maps[key] = _built_tau_min_map(
                vxf, width, self.mu, self.vehicle, cfg.tau_min_floor, cfg.tau_max,
                cfg.safety_factor, cfg.envelope)
        return self._maps[key]

    def _map_tau_min(self, bc: BoundaryConditions, *, lower: bool = False,
                     value: bool = False) -> float:
        """tau_min from a map: an upper bound (the SV's own: every duration it takes is
        stable) or with `lower` a lower bound (a C2 TV's: it may take any stable one),
        `TauMinMap.bounds`; `value`: the map's interpolated value; nan where the map does
        not apply: a start that is not at
        rest laterally, or a width more than MAP_WIDTH_TOLERANCE off a lane width
        (within it, tau_min is scaled by sqrt(|width| / lane width): the lateral
        acceleration goes as W / tau^2)."""
        fmap = self._map_for(bc)
        if fmap is None:
            return math.nan
        lane, width = self.road.lane_width, bc.width
        vx0 = bc.vx0
        lo, hi = fmap.bounds(vx0)
        tau_min = fmap(vx0) if value else lo if lower else hi
        return float(tau_min) * math.sqrt(abs(width) / lane)

    def _map_for(self, bc: BoundaryConditions) -> TauMinMap | None:
        """The map `_map_tau_min` reads for this start (None: none applies)."""
        lane, width = self.road.lane_width, bc.width
        if not (self.use_maps and abs(bc.ax0) < 1e-9 and abs(bc.vy0) < 1e-9
                and abs(bc.ay0) < 1e-9 and abs(abs(width) - lane) <= MAP_WIDTH_TOLERANCE):
            return None
        return self.tau_min_map(bc.vxf, math.copysign(lane, width))

    def _stable_set(self, bc: BoundaryConditions, mode: int | None) -> StableSet:
        cfg = self.config
        tau_min = self._map_tau_min(bc, value=cfg.collision_test == CollisionTest.COL)
        if math.isfinite(tau_min):
            stable = self.grid >= tau_min - 1e-12
            return StableSet(self.grid, np.where(stable, 0.0, np.inf), stable, tau_min)
        return stable_set(bc, self.grid, self.mu, self.vehicle, envelope=cfg.envelope,
                          safety_factor=cfg.safety_factor, mode=mode,
                          tau_floor=cfg.tau_min_floor)

    def _tv_stable(self, vx0: Array, vxf: Array, width: Array,
                   vy0: Array) -> tuple[NDArray[np.bool_], Array]:
        """(n_tv, n_tau) stable masks of C2 TVs' clusters (S3: built like the SV) and a
        lower bound of each one's tau_min (nan: none known): from the maps where they
        apply, the rest in one batched envelope call. (The paper's CoL test takes the
        map's own value, as the paper takes its maps'.)"""
        n, grid = vx0.size, self.grid
        lower = self.config.collision_test == CollisionTest.EXACT
        starts = [BoundaryConditions(float(vx0[i]), float(vxf[i]), float(width[i]), 0.0,
                                     float(vy0[i]), 0.0) for i in range(n)]
        # the grid speeds every TV's map reads, computed together (a lazy map's cost is
        # mostly its calls)
        fill_maps([(fmap, bc.vx0) for bc in starts if (fmap := self._map_for(bc)) is not None])
        tau_min = np.array([self._map_tau_min(bc, lower=lower, value=not lower)
                            for bc in starts])
        out = grid[None, :] >= tau_min[:, None] - 1e-12
        rest = np.flatnonzero(~np.isfinite(tau_min))
        if rest.size:
            out[rest] = self._tv_envelope(vx0[rest], vxf[rest], width[rest], vy0[rest])
        return out, tau_min

    def _tv_envelope(self, vx0: Array, vxf: Array, width: Array,
                     vy0: Array) -> NDArray[np.bool_]:
        """(n, n_tau) stable masks of C2 TVs' clusters by the envelope (starts the maps do
        not cover: a TV already moving laterally), the new ones in one batched call. The
        AVs of a fleet that check at one instant ask for the same TVs: each start's mask
        is kept for the next few (every row is computed on its own: the same masks)."""
        cfg, grid = self.config, self.grid
        envelope = (self.road.mu, self.vehicle, cfg.safety_factor, cfg.envelope,
                    grid.tobytes())
        keys = [(envelope, row.tobytes()) for row in np.stack([vx0, vxf, width, vy0], axis=1)]
        masks = [_TV_ENVELOPES.get(key) for key in keys]
        new = [i for i, mask in enumerate(masks) if mask is None]
        if new:
            at, k = np.array(new), grid.size
            rows = BoundaryConditions(np.repeat(vx0[at], k), np.repeat(vxf[at], k),
                                      np.repeat(width[at], k), vy0=np.repeat(vy0[at], k))
            margin = envelope_margin(rows, np.tile(grid, at.size), self.road.mu, self.vehicle,
                                     safety_factor=cfg.safety_factor, yaw_model=cfg.envelope)
            if len(_TV_ENVELOPES) + at.size > TV_ENVELOPES_KEPT:
                _TV_ENVELOPES.clear()
            for i, stable in zip(new, (margin <= 1.0).reshape(at.size, k), strict=True):
                masks[i] = _TV_ENVELOPES[keys[i]] = stable
        return np.array(masks)

    def c2_options(self) -> C2Options:
        """How this planner's prediction builds the C2 TVs' clusters: with its envelope
        and tau_min maps, cells for the exact test, the end speed its policy asks for."""
        cfg = self.config
        return C2Options(cfg.envelope, cfg.safety_factor,
                         self._tv_stable if self.use_maps else None,
                         cfg.collision_test == CollisionTest.EXACT, self.prediction.gap_end_speed)

    def _validate(self, sv: SVPlanState, target_lane: int, occupant: float) -> None:
        if not 0 <= target_lane < self.road.n_lanes or abs(target_lane - sv.lane) != 1:
            raise InputError("planner", "target_lane", target_lane,
                             f"a lane next to {sv.lane} in 0..{self.road.n_lanes - 1}")
        if not 0.0 <= occupant <= 1.0:
            raise InputError("planner", "occupant", occupant, "in [0, 1]")
        if not sv.vx > 0.0:
            raise InputError("planner", "vx", sv.vx, "a positive speed")

    def _time_grid(self, horizon: float) -> Array:
        n = int(math.ceil(horizon / self.collision_step))
        return self.collision_step * np.arange(n + 1)

    def _follow_horizon(self, t: float, sv_x: float, v_start: float, v_end: float,
                        manoeuvre: float, target_lane: int, messages: Sequence[V2VMessage],
                        base: float) -> Array:
        """s after t, per TV: how long the check must look at it (0: no longer than
        `base`). A TV ahead of the SV that is, or is heading for, the target lane is
        looked at until the SV has closed to the gap from which it can still follow
        it: FOLLOW_STANDSTILL_M + FOLLOW_HEADWAY_S v_tv + (closing speed)^2 /
        (2 FOLLOW_DECEL_G mu g). The TV moves as the check predicts it (C1: constant
        acceleration, speed clipped at 0); the SV as the farthest any candidate gets:
        at max(v_start, v_end) for `manoeuvre` s (its speed lies between the two while it
        changes lanes), at v_end after; at most HORIZON_CAP_S past `base`. Up to there
        the planned SV keeps its target speed and no candidate is closer than it can
        follow from (after it the car following takes over): the check sees the
        approach without blaming a candidate for what the car following would avoid."""
        road = self.road
        out = np.zeros(len(messages))
        ahead: list[int] = []
        for j, m in enumerate(messages):  # a lane per message, as the prediction reads it
            if m.x + m.speed * (t - m.t) <= sv_x:
                continue
            if m.motion is not None:
                lane = road.lane_of(m.motion.y0 + m.motion.width)
            elif m.intention != 0 and (lanes := c2_lanes(m, road)) is not None:
                lane = lanes[1]
            else:
                lane = road.lane_of(m.y)
            if lane == target_lane:
                ahead.append(j)
        if not ahead:
            return out
        cap = base + HORIZON_CAP_S
        s = self._time_grid(cap)
        tv_x, tv_v = constant_acceleration([messages[j] for j in ahead], t + s)
        half = 0.5 * (np.array([messages[j].length for j in ahead]) + self.vehicle.length)
        fast = max(v_start, v_end)
        sv_speed = np.where(s < manoeuvre, fast, v_end)
        sv_at = sv_x + fast * np.minimum(s, manoeuvre) + v_end * np.maximum(s - manoeuvre, 0.0)
        gap = tv_x - sv_at - half[:, None]
        closing = np.maximum(sv_speed - tv_v, 0.0)
        need = (FOLLOW_STANDSTILL_M + FOLLOW_HEADWAY_S * tv_v
                + closing**2 / (2.0 * FOLLOW_DECEL_G * road.mu * G))
        short = gap < need
        # the first time the SV is closer than it can follow from; never (within the
        # cap): it never closes in, no longer look needed
        first = np.where(short.any(axis=1), s[np.argmax(short, axis=1)], 0.0)
        out[ahead] = np.where(first > base, first, 0.0)
        return out

    def _sv_candidates(self, sv: SVPlanState, vxf: float, width: float,
                       taus: Array) -> SVCandidates:
        """Every candidate (eq. 2 / eq. 4, general start; evaluated where the check asks)."""
        return SVCandidates(taus, sv.vx, vxf, width, sv.x, sv.y, sv.ax, sv.vy, sv.ay)

    def _collisions(
        self, t: float, t_rel: Array, sv: SVCandidates, sv_end: Array, futures: LazyFutures,
        follow: Array,
    ) -> tuple[NDArray[np.bool_], IntArray, Array]:
        """(collides, index of the TV hit first (-1: none), simulation time of that first
        overlap (nan: none)) of every SV candidate, each (n_c,). `follow`: s, per TV,
        `_follow_horizon`."""
        cfg = self.config
        n_c = sv.n_c
        if futures.n_hypotheses == 0 or n_c == 0:
            return np.zeros(n_c, dtype=bool), np.full(n_c, -1), np.full(n_c, np.nan)
        tv_end = np.where(np.isfinite(futures.t_end), futures.t_end - t, -np.inf)
        tv_hor = np.maximum(tv_end + cfg.horizon_extra, follow[futures.owner])
        hits = check_candidates(
            t_rel, sv, self.vehicle, sv_end + cfg.horizon_extra,
            TVHypotheses.from_futures(futures), tv_hor, margin=self.margin,
            test=cfg.collision_test,
        )
        c = hits.collides
        vehicle = np.where(c, futures.owner[np.maximum(hits.first_hypothesis, 0)], -1)
        return c, vehicle, np.where(c, t + t_rel[hits.first_index], np.nan)

    def _horizon(self, t: float, remaining: float, sv_x: float, v_start: float, v_end: float,
                 target_lane: int, messages: Sequence[V2VMessage]) -> tuple[Array, Array]:
        """(the check's time grid, `_follow_horizon` per TV): up to max(tau_max, the SV's
        remaining manoeuvre, the TVs' broadcast manoeuvres, at most HORIZON_CAP_S past
        the SV's) + horizon_extra, or longer for a slower vehicle ahead in the target lane."""
        cfg = self.config
        own = max(cfg.tau_max, remaining)
        tv_last = max((m.motion.t0 + m.motion.tau - t for m in messages if m.motion), default=0.0)
        base = max(own, min(tv_last, own + HORIZON_CAP_S)) + cfg.horizon_extra
        # the SV's speed lies between v_start and v_end for the longest candidate (plan) or
        # what is left of the committed one (re-check)
        follow = self._follow_horizon(t, sv_x, v_start, v_end,
                                      remaining if remaining > 0.0 else cfg.tau_max,
                                      target_lane, messages, base)
        return self._time_grid(max(base, float(follow.max(initial=0.0)))), follow

    # -- the planner -------------------------------------------------------------

    def plan(
        self, t: float, sv: SVPlanState, target_lane: int, messages: Sequence[V2VMessage],
        occupant: float, vxf: float | None = None, x_limit: float = math.inf,
        max_curvature: float = math.inf, max_tau: float = math.inf,
        max_accel: float = math.inf,
    ) -> Plan:
        """Plan a lane change from sv.lane to `target_lane` at simulation time t, ending
        at `vxf` (m/s; None: the band rule's target speed). `x_limit` (m): the latest
        centre x at the plan's end (a lane that ends, cosim.planning.deadline): longer
        plans are rejected ("lane end"). On a road with lanes that end, a TV that must
        leave its lane is predicted as signalling it (`deadline.merging_messages`).
        `max_curvature` (1/m): plans whose path bends more sharply anywhere are not
        stable (a steering limit the envelope does not have at low speed: a merge from a
        standstill, cosim.driving.lane_end). `max_tau` (s): the chosen tau is the free one
        nearest min(eq. 13's tau_opt, max_tau) (`selection.choose`). `max_accel` (m/s^2):
        plans that speed up harder anywhere are not stable (a comfort bound: a merge from
        a slow start, cosim.driving.lane_end)."""
        start = time.perf_counter()
        self._validate(sv, target_lane, occupant)
        cfg, road = self.config, self.road
        messages = merging_messages(messages, road, t)
        if vxf is None:
            vxf = road.target_speed(sv.lane, target_lane)
        width = road.lane_center(target_lane) - sv.y
        st, taus, stable, late = self._stable_candidates(sv, vxf, width, target_lane,
                                                         max_curvature, x_limit, max_accel)
        cand = np.flatnonzero(stable if late is None else stable & ~late)
        t_rel, follow = self._horizon(t, 0.0, sv.x, sv.vx, vxf, target_lane, messages)
        futures = predict_lazy(messages, t, t_rel, road, self.vehicle, self.grid,
                               self.c2_options())
        hit_vehicle, hit_time = np.full(taus.size, -1), np.full(taus.size, np.nan)
        free = np.zeros(taus.size, dtype=bool)
        if cand.size:  # (an empty general-start cluster has no motion bounds)
            collides, hit_vehicle[cand], hit_time[cand] = self._collisions(
                t, t_rel, self._sv_candidates(sv, vxf, width, taus[cand]), taus[cand],
                futures, follow)
            free[cand[~collides]] = True
        w = omega(occupant, road.mu)
        tau, t_opt = choose(taus, free, w, max_tau)
        trajectory = None
        if tau is not None:
            trajectory = LaneChangeTrajectory(
                t0=t, tau=tau, x0=sv.x, y0=sv.y, vx0=sv.vx, vxf=vxf, width=width,
                ax0=sv.ax, vy0=sv.vy, ay0=sv.ay,
            )
        return Plan(
            t=t, origin_lane=sv.lane, target_lane=target_lane, taus=taus, stable=stable,
            collision_free=free, tau_min=st.tau_min, tau_max=cfg.tau_max, omega=w,
            tau_opt=t_opt, tau=tau, trajectory=trajectory, hit_vehicle=hit_vehicle,
            hit_time=hit_time, planning_time_s=time.perf_counter() - start, vxf=vxf,
            vehicle_ids=futures.vehicle_ids, tv_categories=futures.categories,
            futures=futures, sv=sv, late=late,
        )

    def _stable_candidates(
        self, sv: SVPlanState, vxf: float, width: float, target_lane: int,
        max_curvature: float, x_limit: float, max_accel: float = math.inf,
    ) -> tuple[StableSet, Array, NDArray[np.bool_], NDArray[np.bool_] | None]:
        """(the stable set, its durations with tau_min itself among them, which are stable,
        bend no more than `max_curvature` and accelerate no more than `max_accel`, which
        of those end past `x_limit`, or None without a limit)."""
        st = self._stable_set(sv.boundary(vxf, width), MODES.get((sv.lane, target_lane)))
        taus, stable = st.taus, st.stable
        if math.isfinite(st.tau_min) and not (
            np.abs(taus - st.tau_min) <= 1e-9 + 1e-5 * abs(st.tau_min)  # np.isclose, atol 1e-9
        ).any():
            # the interval starts at tau_min itself, not at the next grid point
            at = int(np.searchsorted(taus, st.tau_min))
            taus = np.concatenate((taus[:at], [st.tau_min], taus[at:]))
            stable = np.concatenate((stable[:at], [True], stable[at:]))
        if math.isfinite(max_curvature):
            stable = stable & (path_curvature(sv, vxf, width, taus) <= max_curvature)
        if math.isfinite(max_accel):
            # a relative tolerance: a cap of end speed at max_accel over a grid tau
            stable = stable & (peak_accel(sv.vx, vxf, sv.ax, taus) <= max_accel * (1 + 1e-6))
        late = None
        if math.isfinite(x_limit):
            # each plan's end x (eq. 2 with a general start), against the deadline
            c3, c4 = longitudinal_coefficients(sv.vx, vxf, taus, sv.ax)
            x_end = sv.x + taus * (sv.vx + taus * (0.5 * sv.ax + taus * (c3 + taus * c4)))
            late = stable & (x_end > x_limit + 1e-9)
        return st, taus, stable, late

    def check(
        self, trajectory: LaneChangeTrajectory, t: float, messages: Sequence[V2VMessage]
    ) -> Rejection | None:
        """Re-check a committed trajectory from time t on against fresh predictions:
        the first collision it would now have, or None."""
        messages = merging_messages(messages, self.road, t)
        remaining = max(trajectory.t_end - t, 0.0)
        tr = trajectory
        x_now = float(tr.position(t)[0])
        target = self.road.lane_of(tr.y_final)
        t_rel, follow = self._horizon(t, remaining, x_now, tr.vx0, tr.vxf, target,
                                      messages)
        futures = predict_lazy(messages, t, t_rel, self.road, self.vehicle, self.grid,
                               self.c2_options())
        cand = SVCandidates(np.array([tr.tau]), tr.vx0, tr.vxf, tr.width, tr.x0, tr.y0,
                             tr.ax0, tr.vy0, tr.ay0, t_shift=t - tr.t0)
        collides, vehicle, when = self._collisions(
            t, t_rel, cand, np.array([remaining]), futures, follow)
        if not collides[0]:
            return None
        return Rejection(trajectory.tau, "collision", futures.vehicle_ids[vehicle[0]],
                         float(when[0]))


def peak_accel(vx0: float, vxf: float, ax0: float, taus: Array) -> Array:
    """m/s^2, (n_tau,) the highest longitudinal acceleration of each candidate (eq. 2
    with a general start: x'' = ax0 + 6 c3 t + 12 c4 t^2, 0 at tau; its vertex at
    t = -c3 / (4 c4) when inside)."""
    c3, c4 = longitudinal_coefficients(vx0, vxf, taus, ax0)
    c3, c4 = np.broadcast_arrays(np.asarray(c3, dtype=float), np.asarray(c4, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = np.where(c4 != 0.0, -c3 / (4.0 * c4), -1.0)
    inside = (tv > 0.0) & (tv < taus)
    tv = np.where(inside, tv, 0.0)
    at_vertex = np.where(inside, ax0 + 6.0 * c3 * tv + 12.0 * c4 * tv * tv, -np.inf)
    return np.maximum(np.maximum(ax0, 0.0), at_vertex)


CURVATURE_SAMPLES = 41  # samples per candidate of `path_curvature`


def path_curvature(sv: SVPlanState, vxf: float, width: float, taus: Array) -> Array:
    """1/m, (n_tau,) the largest |curvature| of each candidate's path (eq. 2 / eq. 4 from
    the SV's start), sampled CURVATURE_SAMPLES times over [0, tau]."""
    s = np.linspace(0.0, 1.0, CURVATURE_SAMPLES)
    tau = np.asarray(taus, dtype=float)[:, None]
    d = cluster_derivatives(sv.boundary(vxf, width), tau, tau * s[None, :], (1, 2))
    (xd, yd), (xdd, ydd) = d[1], d[2]
    speed2 = np.maximum(xd * xd + yd * yd, 1e-12)
    return (np.abs(xd * ydd - yd * xdd) / speed2**1.5).max(axis=1)


# (envelope, start) -> stable mask of `LaneChangePlanner._tv_envelope`: the last few
# instants' C2 TVs already moving laterally
_TV_ENVELOPES: dict[tuple[Any, bytes], NDArray[np.bool_]] = {}
TV_ENVELOPES_KEPT = 256  # masks kept (then all dropped): a fleet's AVs at one instant


# maps kept per process: a fleet's C2 TVs end at speeds on target_leader_speed's grid,
# a few hundred end speeds x two widths over a run (each map some 10 kB)
MAP_CACHE_SIZE = 2048


@functools.lru_cache(maxsize=MAP_CACHE_SIZE)
def _built_tau_min_map(vxf: float, width: float, mu: float, vehicle: VehicleParams,
                       tau_lo: float, tau_hi: float, safety_factor: float,
                       yaw_model: str) -> TauMinMap:
    """A TauMinMap, one per process for exactly these inputs (filled lazily, each grid
    speed once: runs, re-plans and benches in one process share it; the same inputs
    give the same answers, so a run's results do not depend on what ran before it)."""
    return TauMinMap(vxf, width, mu, vehicle, tau_lo=tau_lo, tau_hi=tau_hi,
                     safety_factor=safety_factor, yaw_model=yaw_model)
