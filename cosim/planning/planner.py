"""The lane-change planner: cluster -> stable set -> TV futures -> collision-free set -> tau.

Sections 2-3 of the paper put together: the trajectory cluster over tau (eq. 2,
4), the handling envelope's stable set (eq. 5-8), the TVs' predicted futures
(C1-C3), the collision check (eq. 9-11; exact by default), and the choice of tau
(eq. 13, 35). `LaneChangePlanner.plan` returns a `Plan` that says what it chose
and why every other tau was rejected; `check` re-tests a committed trajectory
against fresh messages.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.errors import InputError
from cosim.params import PlannerConfig, RoadParams, VehicleParams
from cosim.planning.collision import (
    COLLISION_TESTS,
    ArrayCluster,
    ClusterMotion,
    PoseFn,
    StandardCluster,
    SVCluster,
    TVClosedForm,
    check_sv_cluster,
    cluster_motion,
    standard_cluster_motion,
)
from cosim.planning.envelope import (
    ENVELOPES,
    MODES,
    YAW_MODELS,
    StableSet,
    TauMinMap,
    envelope_margin,
    stable_set,
)
from cosim.planning.prediction import LazyFutures, TVFutures, predict_lazy
from cosim.planning.selection import choose, intervals, omega
from cosim.planning.trajectory import (
    LaneChangeTrajectory,
    cluster_derivatives,
    standard_positions_at,
    standard_velocities,
)
from cosim.traffic.v2v import V2VMessage

Array = NDArray[np.float64]

COLLISION_STEP = 0.05  # s, sample step of the collision check (rectangles padded, see collision.py)
MAP_WIDTH_TOLERANCE = 0.02  # m, widths this close to a lane width use the tau_min maps


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


@dataclass(frozen=True)
class Rejection:
    """Why one tau was not taken."""

    tau: float  # s
    reason: str  # "unstable" | "collision"
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
    stable_intervals: list[tuple[float, float]]  # s
    collision_free_intervals: list[tuple[float, float]]  # s
    omega: float  # -, eq. 35 (clipped)
    tau_opt: float  # s, eq. 13 over the collision-free set (nan: empty)
    tau: float | None  # s, chosen; None: keep the lane
    trajectory: LaneChangeTrajectory | None
    rejections: list[Rejection]
    planning_time_s: float  # s, wall time of plan()
    vxf: float = math.nan  # m/s, target speed of the lane change
    categories: dict[str, str] = field(default_factory=dict)  # TV id -> "C1" | "C2" | "C3"
    # the TVs' futures (LazyFutures: arrays x, y, heading computed on first access)
    futures: TVFutures | LazyFutures | None = field(default=None, repr=False, compare=False)
    sv: SVPlanState | None = field(default=None, repr=False, compare=False)  # planned from

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


class LaneChangePlanner:
    """Plans a lane change of one vehicle (Sections 2-3)."""

    def __init__(
        self, vehicle: VehicleParams, road: RoadParams, config: PlannerConfig,
        *, collision_step: float = COLLISION_STEP, use_maps: bool = True,
    ) -> None:
        """`use_maps`: take tau_min of lane changes that start from rest laterally (the
        SV from its lane centre, C2 TVs) from a `TauMinMap` built once per mode
        (eq. 7 with our envelope); starts mid-manoeuvre always run the envelope."""
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
        n = int(round((config.tau_max - config.tau_min_floor) / config.tau_step))
        grid = config.tau_min_floor + config.tau_step * np.arange(n + 1)
        self.grid = grid[grid <= config.tau_max + 1e-9]
        self.use_maps = use_maps and config.envelope in YAW_MODELS
        self._maps: dict[tuple[float, float], TauMinMap] = {}

    # -- pieces ------------------------------------------------------------------

    def tau_min_map(self, vxf: float, width: float) -> TauMinMap:
        """The (lazily built) map vx0 -> tau_min for this target speed and width."""
        key = (round(vxf, 9), round(width, 9))
        if key not in self._maps:
            cfg = self.config
            self._maps[key] = TauMinMap(
                vxf, width, self.road.mu, self.vehicle, tau_lo=cfg.tau_min_floor,
                tau_hi=cfg.tau_max, safety_factor=cfg.safety_factor, yaw_model=cfg.envelope,
            )
        return self._maps[key]

    def _map_tau_min(self, vx0: float, vxf: float, width: float, ax0: float, vy0: float,
                     ay0: float) -> float:
        """tau_min from a map, or nan where the map does not apply: a start that is not
        at rest laterally, or a width more than MAP_WIDTH_TOLERANCE off a lane width
        (within it, tau_min is scaled by sqrt(|width| / lane width): the lateral
        acceleration goes as W / tau^2)."""
        lane = self.road.lane_width
        if not (self.use_maps and abs(ax0) < 1e-9 and abs(vy0) < 1e-9 and abs(ay0) < 1e-9
                and abs(abs(width) - lane) <= MAP_WIDTH_TOLERANCE):
            return math.nan
        tau_min = float(self.tau_min_map(vxf, math.copysign(lane, width))(vx0))
        return tau_min * math.sqrt(abs(width) / lane)

    def _stable_set(self, vx0: float, vxf: float, width: float, ax0: float, vy0: float,
                    ay0: float, mode: int | None) -> StableSet:
        cfg = self.config
        tau_min = self._map_tau_min(vx0, vxf, width, ax0, vy0, ay0)
        if math.isfinite(tau_min):
            stable = self.grid >= tau_min - 1e-12
            return StableSet(self.grid, np.where(stable, 0.0, np.inf), stable, tau_min)
        return stable_set(
            vx0, vxf, width, self.grid, self.road.mu, self.vehicle, envelope=cfg.envelope,
            safety_factor=cfg.safety_factor, ax0=ax0, vy0=vy0, ay0=ay0, mode=mode,
            tau_floor=cfg.tau_min_floor,
        )

    def _tv_stable(self, vx0: Array, vxf: Array, width: Array, vy0: Array) -> NDArray[np.bool_]:
        """(n_tv, n_tau) stable masks of C2 TVs' clusters (S3: built like the SV): from
        the maps where they apply, the rest in one batched envelope call."""
        n, grid = vx0.size, self.grid
        tau_min = np.array([self._map_tau_min(float(vx0[i]), float(vxf[i]), float(width[i]),
                                              0.0, float(vy0[i]), 0.0) for i in range(n)])
        out = grid[None, :] >= tau_min[:, None] - 1e-12
        rest = np.flatnonzero(~np.isfinite(tau_min))
        if rest.size:
            cfg = self.config
            k = grid.size
            margin = envelope_margin(
                np.repeat(vx0[rest], k), np.repeat(vxf[rest], k), np.repeat(width[rest], k),
                np.tile(grid, rest.size), self.road.mu, self.vehicle,
                safety_factor=cfg.safety_factor, yaw_model=cfg.envelope,
                vy0=np.repeat(vy0[rest], k),
            )
            out[rest] = (margin <= 1.0).reshape(rest.size, k)
        return out

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

    def _sv_cluster(
        self, sv: SVPlanState, vxf: float, width: float, taus: Array, t_rel: Array
    ) -> tuple[SVCluster, ClusterMotion, PoseFn]:
        """Every candidate's global pose on the time grid (computed where the check asks
        for it: the cluster of eq. 2 / eq. 4 from rest is never stored whole) and the
        bounds on its motion per sample step."""
        kw = {"ax0": sv.ax, "vy0": sv.vy, "ay0": sv.ay}
        at_rest = abs(sv.ax) < 1e-12 and abs(sv.vy) < 1e-12 and abs(sv.ay) < 1e-12

        def heading(c: NDArray[np.int64], k: NDArray[np.int64]) -> Array:
            if at_rest:
                xd, yd = standard_velocities(sv.vx, vxf, width, taus[c], t_rel[k])
                return np.arctan2(yd, xd)
            xd, yd = cluster_derivatives(
                sv.vx, vxf, width, taus[c][:, None], t_rel[k][:, None], (1,), **kw
            )[1]
            return np.arctan2(yd[:, 0], xd[:, 0])

        def pose(c: NDArray[np.int64], tt: Array) -> tuple[Array, Array, Array]:
            if at_rest:  # eq. 2 / eq. 4 in closed form (the same to rounding)
                tau_c = taus[c][:, None]
                px, py = standard_positions_at(sv.vx, vxf, width, tau_c, tt)
                vx, vy = standard_velocities(sv.vx, vxf, width, tau_c, tt)
                px += sv.x
                py += sv.y
                return px, py, np.arctan2(vy, vx)
            d = cluster_derivatives(sv.vx, vxf, width, taus[c][:, None], tt, (0, 1), **kw)
            (px, py), (vx, vy) = d[0], d[1]
            return px + sv.x, py + sv.y, np.arctan2(vy, vx)

        cluster: SVCluster
        if at_rest and taus.size:  # eq. 2 / eq. 4 as printed: closed forms and bounds
            cluster = StandardCluster(t_rel, taus, sv.x, sv.y, sv.vx, vxf, width, heading)
            motion = standard_cluster_motion(sv.vx, vxf, width, float(taus.min()),
                                             self.collision_step)
        else:
            x, y = cluster_derivatives(sv.vx, vxf, width, taus, t_rel, (0,), **kw)[0]
            motion = cluster_motion(x, y)
            cluster = ArrayCluster(x + sv.x, y + sv.y, heading)
        return cluster, motion, pose

    def _collisions(
        self, t: float, t_rel: Array, cluster: SVCluster, sv_end: Array,
        futures: LazyFutures, motion: ClusterMotion, pose: PoseFn | None = None,
    ) -> tuple[NDArray[np.bool_], list[str | None], list[float | None]]:
        """(collides (n_c,), first TV id, first time) of every SV candidate."""
        cfg = self.config
        n_c = cluster.n_c
        if futures.n_hypotheses == 0 or n_c == 0:
            return np.zeros(n_c, dtype=bool), [None] * n_c, [None] * n_c
        r_sv = 0.5 * math.hypot(self.vehicle.length, self.vehicle.width)
        tv_end = np.where(np.isfinite(futures.t_end), futures.t_end - t, -np.inf)
        hits = check_sv_cluster(
            t_rel, cluster, self.vehicle.length, self.vehicle.width,
            sv_end + cfg.horizon_extra, TVClosedForm(futures, motion, r_sv),
            tv_end + cfg.horizon_extra, margin=cfg.safety_margin, test=cfg.collision_test,
            sv_max_heading=motion.max_heading, sv_pose=pose,
        )
        ids: list[str | None] = [None] * n_c
        when: list[float | None] = [None] * n_c
        cs = np.flatnonzero(hits.collides)  # only to name the culprits
        owners = futures.owner[hits.first_hypothesis[cs]].tolist()
        times = (t + t_rel[hits.first_index[cs]]).tolist()
        for c, o, tc in zip(cs.tolist(), owners, times, strict=True):
            ids[c] = futures.vehicle_ids[o]
            when[c] = tc
        return hits.collides, ids, when

    # -- the planner -------------------------------------------------------------

    def plan(
        self, t: float, sv: SVPlanState, target_lane: int, messages: Sequence[V2VMessage],
        occupant: float,
    ) -> Plan:
        """Plan a lane change from sv.lane to `target_lane` at simulation time t."""
        start = time.perf_counter()
        self._validate(sv, target_lane, occupant)
        cfg, road = self.config, self.road
        vxf = road.target_speed(sv.lane, target_lane)
        width = road.lane_center(target_lane) - sv.y
        st = self._stable_set(sv.vx, vxf, width, sv.ax, sv.vy, sv.ay,
                              MODES.get((sv.lane, target_lane)))
        taus, stable = st.taus, st.stable
        if math.isfinite(st.tau_min) and not (
            np.abs(taus - st.tau_min) <= 1e-9 + 1e-5 * abs(st.tau_min)  # np.isclose, atol 1e-9
        ).any():
            # the interval starts at tau_min itself, not at the next grid point
            at = int(np.searchsorted(taus, st.tau_min))
            taus = np.concatenate((taus[:at], [st.tau_min], taus[at:]))
            stable = np.concatenate((stable[:at], [True], stable[at:]))
        cand = np.flatnonzero(stable)
        tv_last = max((m.motion.t0 + m.motion.tau - t for m in messages if m.motion), default=0.0)
        t_rel = self._time_grid(max(cfg.tau_max, tv_last) + cfg.horizon_extra)
        futures = predict_lazy(
            messages, t, t_rel, road, self.vehicle, self.grid,
            envelope=cfg.envelope, safety_factor=cfg.safety_factor,
            stable_fn=self._tv_stable if self.use_maps else None,
        )
        collides, ids, when = np.zeros(0, dtype=bool), [], []  # no stable tau: nothing to test
        if cand.size:  # (an empty general-start cluster has no motion bounds)
            cluster, motion, pose = self._sv_cluster(sv, vxf, width, taus[cand], t_rel)
            collides, ids, when = self._collisions(t, t_rel, cluster, taus[cand], futures,
                                                   motion, pose)
        free = np.zeros(taus.size, dtype=bool)
        free[cand[~collides]] = True
        w = omega(occupant, road.mu)
        tau, t_opt = choose(taus, free, w)
        # one reason per rejected tau, in tau order
        cand_of = np.full(taus.size, -1)
        cand_of[cand] = np.arange(cand.size)
        tau_l, cand_l = taus.tolist(), cand_of.tolist()
        rejections = [
            Rejection(tau_l[i], "unstable") if cand_l[i] < 0
            else Rejection(tau_l[i], "collision", ids[cand_l[i]], when[cand_l[i]])
            for i in np.flatnonzero(~free).tolist()
        ]
        trajectory = None
        if tau is not None:
            trajectory = LaneChangeTrajectory(
                t0=t, tau=tau, x0=sv.x, y0=sv.y, vx0=sv.vx, vxf=vxf, width=width,
                ax0=sv.ax, vy0=sv.vy, ay0=sv.ay,
            )
        return Plan(
            t=t, origin_lane=sv.lane, target_lane=target_lane, taus=taus, stable=stable,
            collision_free=free, tau_min=st.tau_min, tau_max=cfg.tau_max,
            stable_intervals=intervals(taus, stable),
            collision_free_intervals=intervals(taus, free), omega=w, tau_opt=t_opt,
            tau=tau, trajectory=trajectory, rejections=rejections,
            planning_time_s=time.perf_counter() - start, vxf=vxf,
            categories=dict(zip(futures.vehicle_ids, futures.categories, strict=True)),
            futures=futures, sv=sv,
        )

    def check(
        self, trajectory: LaneChangeTrajectory, t: float, messages: Sequence[V2VMessage]
    ) -> Rejection | None:
        """Re-check a committed trajectory from time t on against fresh predictions:
        the first collision it would now have, or None."""
        cfg = self.config
        remaining = max(trajectory.t_end - t, 0.0)
        tv_last = max((m.motion.t0 + m.motion.tau - t for m in messages if m.motion), default=0.0)
        t_rel = self._time_grid(max(remaining, tv_last, cfg.tau_max) + cfg.horizon_extra)
        futures = predict_lazy(
            messages, t, t_rel, self.road, self.vehicle, self.grid,
            envelope=cfg.envelope, safety_factor=cfg.safety_factor,
            stable_fn=self._tv_stable if self.use_maps else None,
        )
        ts = t + t_rel
        x, y = trajectory.position(ts)
        h = trajectory.heading(ts)

        def pose(c: NDArray[np.int64], tt: Array) -> tuple[Array, Array, Array]:
            px, py = trajectory.position(tt)
            return px, py, trajectory.heading(tt)

        collides, ids, when = self._collisions(
            t, t_rel, ArrayCluster(x[None, :], y[None, :], h[None, :]), np.array([remaining]),
            futures, cluster_motion(x[None, :], y[None, :]), pose=pose,
        )
        if not collides[0]:
            return None
        return Rejection(trajectory.tau, "collision", ids[0], when[0])
