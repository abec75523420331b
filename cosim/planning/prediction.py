"""Futures of the traffic vehicles from their V2V messages (Section 3.2, S1-S3, C1-C3).

- C1, no lane-change intention: constant acceleration, speed clipped at 0, lane kept.
- C2, intention +-1 and no motion yet: every trajectory of the TV's own stable
  cluster (S3: the TVs are built like the SV, same envelope) to the adjacent lane
  in that direction, with the band-rule target speed, starting at the planning
  instant. The SV must be safe against all of them: one hypothesis per listed
  duration, the first a lower bound of the TV's tau_min, then the stable grid
  points; from rest, neighbouring ones bound a cell (`LazyFutures.cell`) that the
  collision check covers for every duration in between.
  On a lane that ends only the durations that end before the lane's end
  are listed (cosim.planning.deadline; the planner signals for a TV that must merge
  and does not: `deadline.merging_messages`).
- C3, motion broadcast: the reference it sends (quintic min-jerk, eq. 2 and 4, or
  SUMO's linear lateral motion).

Output: `TVFutures`, arrays over (hypothesis, time) of centre x, y and heading.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.params import RoadParams, VehicleParams
from cosim.planning.deadline import c2_deadline
from cosim.planning.envelope import MODES, Envelope, envelope_margin, paper_map_tau_min
from cosim.planning.trajectory import (
    LANE_CHANGE,
    BoundaryConditions,
    LaneChangeTrajectory,
    cluster_derivatives,
    standard_positions_at,
    standard_velocities,
)
from cosim.traffic.v2v import LateralMotion, V2VMessage

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

# m, how far past a lane centre (towards the intention) a TV must be before that
# lane counts as reached: a TV that has crossed the line heads for the lane it is in
REACHED_TOLERANCE = 0.1


@dataclass(frozen=True)
class TVFutures:
    """Predicted TV rectangles over a common absolute time grid."""

    t: Array  # s, absolute simulation times (n_t,)
    vehicle_ids: tuple[str, ...]  # (n_tv,)
    categories: tuple[str, ...]  # "C1" | "C2" | "C3" per TV
    owner: IntArray  # (n_h,) index into vehicle_ids of each hypothesis
    tau: Array  # s, (n_h,) the hypothesis' lane-change duration (nan: no lane change)
    t_end: Array  # s, (n_h,) absolute time the hypothesis' manoeuvre ends (-inf: none)
    x: Array  # m, (n_h, n_t) centre
    y: Array  # m, (n_h, n_t)
    heading: Array  # rad, (n_h, n_t)
    length: Array  # m, (n_h,)
    width: Array  # m, (n_h,)

    @property
    def n_hypotheses(self) -> int:
        return int(self.owner.size)


class Category(StrEnum):
    """A TV's prediction category (Section 3.2)."""

    C1 = "C1"  # no lane-change intention: constant acceleration in its lane
    C2 = "C2"  # an intention and no motion yet: its own stable cluster
    C3 = "C3"  # a motion broadcast: the reference it sends


def category(msg: V2VMessage) -> Category:
    """C3 when a motion is broadcast, C2 when only an intention, else C1."""
    if msg.motion is not None:
        return Category.C3
    return Category.C2 if msg.intention != 0 else Category.C1


def c2_lanes(msg: V2VMessage, road: RoadParams) -> tuple[int, int] | None:
    """(origin, target) SUMO lanes of a C2 TV, or None when the target is off the road.

    The target is the next lane centre in the intention's direction that the TV has
    not yet reached (a TV already across the line heads for the lane it is in)."""
    lane = road.lane_of(msg.y)
    ahead = (road.lane_center(lane) - msg.y) * msg.intention > REACHED_TOLERANCE
    target = lane if ahead else lane + msg.intention
    if not 0 <= target < road.n_lanes:
        return None
    return target - msg.intention, target


def constant_acceleration(msgs: Sequence[V2VMessage], t: ArrayLike) -> tuple[Array, Array]:
    """(x, speed) of each message's TV at absolute times t from its state, speed clipped
    at 0 (C1): arrays of shape (len(msgs), *t's shape), one computation for all."""
    mt, v, a, mx = (np.array([getattr(m, f) for m in msgs], dtype=float)
                    for f in ("t", "speed", "accel", "x"))
    tt = np.asarray(t, dtype=float)
    per = (-1,) + (1,) * tt.ndim  # per message, broadcast over the times
    mt, v, a, mx = (q.reshape(per) for q in (mt, v, a, mx))
    dt = tt[None, ...] - mt
    neg = np.flatnonzero(a < 0.0)
    if neg.size:  # stopped: stays
        dt[neg] = np.minimum(dt[neg], v[neg] / -a[neg])
    return mx + v * dt + 0.5 * a * dt * dt, np.maximum(v + a * dt, 0.0)


TV_LEADER_RANGE = 150.0  # m, a C2 TV's leader in its target lane is looked for this far
# m/s, that leader's speed is taken down to this grid: the end speed keys the planner's
# tau_min map of the TV (each speed of it computed once), and in slow traffic the exact
# speed is new at every re-check
LEADER_SPEED_STEP = 0.25  # tuned: docs/tuned_constants.md


def target_leader_speed(messages: Sequence[V2VMessage], t_plan: float,
                        c2: Sequence[tuple[int, V2VMessage, int, int]], x0: Array) -> Array:
    """m/s per C2 TV (index, message, origin, target; centre x0 at t_plan): the speed
    of the nearest vehicle ahead of it in its target lane within TV_LEADER_RANGE, down
    to the LEADER_SPEED_STEP grid (inf: none). Arrays over TVs."""
    x = np.array([m.x + m.speed * (t_plan - m.t) for m in messages])
    v = np.array([m.speed for m in messages])
    lane = np.array([m.lane for m in messages])
    target = np.array([g for _, _, _, g in c2])
    ahead = x[None, :] - np.asarray(x0)[:, None]
    ok = (lane[None, :] == target[:, None]) & (ahead > 0.0) & (ahead <= TV_LEADER_RANGE)
    dist = np.where(ok, ahead, np.inf)
    nearest = np.argmin(dist, axis=1)
    speed = np.floor(v[nearest] / LEADER_SPEED_STEP) * LEADER_SPEED_STEP
    return np.where(np.isfinite(dist.min(axis=1)), speed, np.inf)


def motion_path(m: LateralMotion, t: Array) -> tuple[Array, Array, Array]:
    """(x, y, heading) of a broadcast lane change (C3) at absolute times t."""
    rel = t - m.t0
    if m.profile == "linear":
        s = np.clip(rel / m.tau, 0.0, 1.0)
        moving = (rel > 0) & (rel < m.tau)
        heading = np.where(moving, np.arctan2(m.width / m.tau, m.vx0), 0.0)
        return m.x0 + m.vx0 * rel, m.y0 + m.width * s, heading
    tr = _broadcast_trajectory(m)
    x, y = tr.derivative(t, 0)
    xd, yd = tr.derivative(t, 1)
    return x, y, np.arctan2(yd, xd)


@functools.lru_cache(maxsize=256)
def _broadcast_trajectory(m: LateralMotion) -> LaneChangeTrajectory:
    """The quintic broadcast `m` as a trajectory (eq. 2, 4 with its start): one per
    broadcast, its coefficients kept while the AVs re-check against it step after step."""
    return LaneChangeTrajectory(t0=m.t0, tau=m.tau, x0=m.x0, y0=m.y0, vx0=m.vx0, vxf=m.vxf,
                                width=m.width, ax0=m.ax0, vy0=m.vy0, ay0=m.ay0)


# (vx0, vxf, width, vy0) of n C2 TVs -> (stable (n, n_tau) on the grid, a lower bound of
# each one's shortest stable duration (n,), nan: none known)
StableFn = Callable[[Array, Array, Array, Array], tuple[NDArray[np.bool_], Array]]


@dataclass(frozen=True)
class LazyFutures:
    """`TVFutures` whose lane changes from rest (eq. 2 / eq. 4 in closed form: C2 clusters
    and C3 quintic broadcasts) are kept as parameters: a dense scene holds hundreds of
    such trajectories, of which the collision check evaluates a few per cent of the
    samples. The other hypotheses are stored rows. `rows(h)`, `x`, `y`, `heading` (and
    `materialise()`) give whole arrays."""

    t: Array  # s, absolute simulation times (n_t,)
    rel: Array  # s, t minus the planning instant (the C2 clusters' own time)
    vehicle_ids: tuple[str, ...]
    categories: tuple[str, ...]
    owner: IntArray  # (n_h,)
    tau: Array  # s, (n_h,)
    t_end: Array  # s, (n_h,)
    length: Array  # m, (n_h,)
    width: Array  # m, (n_h,)
    stored: IntArray  # (n_s,) the hypotheses held as rows, ascending
    row_of: IntArray  # (n_h,) index into the stored rows (-1: a closed-form hypothesis)
    sx: Array  # m, (n_s, n_t) stored rows
    sy: Array  # m
    sh: Array  # rad
    # (n_h,) closed-form hypotheses (`trajectory.LANE_CHANGE`, start relative to the
    # planning instant; nan: stored)
    lc: NDArray[np.void]
    cell: NDArray[np.bool_]  # (n_h,) h and h + 1: neighbouring durations of one C2 cluster

    @property
    def n_hypotheses(self) -> int:
        return int(self.owner.size)

    @property
    def closed(self) -> NDArray[np.bool_]:
        """(n_h,) the hypotheses in closed form."""
        return self.row_of < 0

    def rows(self, h: IntArray) -> tuple[Array, Array, Array]:
        """(x, y, heading) of hypotheses h over the whole grid, each (h.size, n_t)."""
        n_t = self.t.size
        x, y, hd = np.empty((h.size, n_t)), np.empty((h.size, n_t)), np.empty((h.size, n_t))
        r = self.row_of[h]
        s = r >= 0
        x[s], y[s], hd[s] = self.sx[r[s]], self.sy[r[s]], self.sh[r[s]]
        c = np.flatnonzero(~s)
        if c.size:
            q = self.lc[h[c]]
            v0, vxf, dy, tau, x0, y0, t0 = (q[f][:, None] for f in (
                "v0", "vxf", "width", "tau", "x0", "y0", "start"))
            rel = self.rel[None, :] - t0
            cx, cy = standard_positions_at(v0, vxf, dy, tau, rel)
            cx += x0
            cy += y0
            xd, yd = standard_velocities(v0, vxf, dy, tau, rel)
            x[c], y[c], hd[c] = cx, cy, np.arctan2(yd, xd)
        return x, y, hd

    @functools.cached_property
    def _full(self) -> tuple[Array, Array, Array]:
        return self.rows(np.arange(self.n_hypotheses))

    @property
    def x(self) -> Array:
        return self._full[0]

    @property
    def y(self) -> Array:
        return self._full[1]

    @property
    def heading(self) -> Array:
        return self._full[2]

    def materialise(self) -> TVFutures:
        """The same futures as stored arrays."""
        return TVFutures(self.t, self.vehicle_ids, self.categories, self.owner, self.tau,
                         self.t_end, self.x, self.y, self.heading, self.length, self.width)


@dataclass(frozen=True)
class C2Options:
    """How the C2 TVs' clusters are built (S3: like the SV's, on the planner's tau grid)."""

    envelope: str = "inverse_dynamics"  # the yaw-rate envelope, or "paper_maps" (eq. 31-34)
    safety_factor: float = 0.8  # -, f of eq. 6
    # (vx0, vxf, width, vy0) -> (n_c2, n_tau) stable and a lower bound of each tau_min:
    # the planner's tau_min maps; None: all C2 TVs in one batched envelope call
    stable_fn: StableFn | None = None
    # False: a C2 cluster is its stable grid points only, no lower bound of its tau_min
    # and no cells between them (the paper's procedure, for its CoL test)
    cells: bool = True
    # a C2 TV ends its change no faster than its leader in the target lane
    # (`target_leader_speed`), as the gap policy's SV does (S3, all vehicles alike);
    # False: at the band rule's speed, as the paper's SV
    gap_end_speed: bool = False


def predict(
    messages: Sequence[V2VMessage], t_plan: float, t_rel: Array, road: RoadParams,
    vehicle: VehicleParams, taus: Array, options: C2Options | None = None,
) -> TVFutures:
    """TV futures at absolute times t_plan + t_rel for every message (C1/C2/C3); C2
    clusters on the planner's tau grid `taus`, built as `options` say."""
    return predict_lazy(messages, t_plan, t_rel, road, vehicle, taus, options).materialise()


def predict_lazy(
    messages: Sequence[V2VMessage], t_plan: float, t_rel: Array, road: RoadParams,
    vehicle: VehicleParams, taus: Array, options: C2Options | None = None,
) -> LazyFutures:
    """`predict`, with the C2 clusters from rest left in closed form (`LazyFutures`)."""
    opt = options or C2Options()
    envelope, safety_factor, stable_fn = opt.envelope, opt.safety_factor, opt.stable_fn
    cells, gap_end_speed = opt.cells, opt.gap_end_speed
    t = t_plan + np.asarray(t_rel, dtype=float)
    rel = t - t_plan
    n_t = t.size
    ids = tuple(m.vehicle_id for m in messages)
    cats: list[str] = []
    # blocks of hypotheses in order: stored rows, C1 TVs (rows, computed together) or
    # lane changes from rest in closed form
    blocks: list[_Rows | _C1 | _Closed] = []
    # per hypothesis, as plain lists (one array each at the end)
    owner: list[int] = []
    tau_h: list[float] = []
    t_end: list[float] = []
    lengths: list[float] = []
    widths: list[float] = []
    c2: list[tuple[int, V2VMessage, int, int]] = []

    def meta(i: int, k: int, tau: Array | float, end: Array | float) -> None:
        owner.extend([i] * k)
        tau_h.extend(tau.tolist() if isinstance(tau, np.ndarray) else [float(tau)] * k)
        t_end.extend(end.tolist() if isinstance(end, np.ndarray) else [float(end)] * k)
        lengths.extend([float(messages[i].length)] * k)
        widths.extend([float(messages[i].width)] * k)

    def add(i: int, x: Array, y: Array, h: Array, tau: Array | float, end: Array | float) -> None:
        """One block of hypotheses of TV i: x, y, h shaped (k, n_t) or (n_t,)."""
        x2 = np.atleast_2d(x)
        k = x2.shape[0]
        blocks.append(_Rows(x2, np.broadcast_to(y, (k, n_t)), np.broadcast_to(h, (k, n_t))))
        meta(i, k, tau, end)

    def add_c1(i: int, m: V2VMessage) -> None:
        blocks.append(_C1(m))  # computed below, all C1 TVs at once
        meta(i, 1, np.nan, -np.inf)

    for i, m in enumerate(messages):
        cat = category(m)
        if cat == Category.C3:
            mo = m.motion
            assert mo is not None
            if mo.profile == "quintic" and mo.from_rest and mo.t0 <= t_plan:  # eq. 2 / 4
                blocks.append(_Closed(np.array([mo.tau]), False, mo.vx0, mo.vxf, mo.width,
                                      mo.x0, mo.y0, mo.t0 - t_plan))
                meta(i, 1, mo.tau, mo.t0 + mo.tau)
            else:
                add(i, *motion_path(mo, t), mo.tau, mo.t0 + mo.tau)
        elif cat == Category.C2 and (lanes := c2_lanes(m, road)) is not None:
            c2.append((i, m, *lanes))
        else:
            cat = "C1"
            add_c1(i, m)
        cats.append(cat)

    if c2:
        # the TVs' state at the planning instant (they start when the SV does)
        x0, v0 = constant_acceleration([m for _, m, _, _ in c2], t_plan)
        vxf = np.array([road.target_speed(o, g) for _, _, o, g in c2])
        if gap_end_speed:
            vxf = np.minimum(vxf, target_leader_speed(messages, t_plan, c2, x0))
        width = np.array([road.lane_center(g) - m.y for _, m, _, g in c2])
        vy0 = np.array([m.lateral_speed for _, m, _, _ in c2])
        n_tau = taus.size
        tau_lo = np.full(len(c2), np.nan)
        if stable_fn is not None:
            stable, tau_lo = stable_fn(v0, vxf, width, vy0)
        elif envelope == Envelope.PAPER_MAPS:
            tmin = np.array([
                paper_map_tau_min(MODES.get((o, g), 1), v, road.mu)
                for (_, _, o, g), v in zip(c2, v0, strict=True)
            ])
            stable = taus[None, :] >= tmin[:, None]
            tau_lo = tmin
        else:
            rows = BoundaryConditions(np.repeat(v0, n_tau), np.repeat(vxf, n_tau),
                                      np.repeat(width, n_tau), vy0=np.repeat(vy0, n_tau))
            margin = envelope_margin(rows, np.tile(taus, len(c2)), road.mu, vehicle,
                                     safety_factor=safety_factor, yaw_model=envelope)
            stable = (margin <= 1.0).reshape(len(c2), n_tau)
        if road.lane_ends:
            # a TV on a lane that ends changes before its end: only the durations that
            # end in time (cosim.planning.deadline; none does: all, it must squeeze in)
            end = np.array([road.lane_end(o, float(x))
                            for (_, _, o, _), x in zip(c2, x0, strict=True)])
            length = np.array([m.length for _, m, _, _ in c2])
            fits = c2_deadline(x0, v0, vxf, length, end, taus) & stable
            stable = np.where(fits.any(axis=1)[:, None], fits, stable)
        still = np.abs(vy0) < 1e-12
        for j, (i, m, _, _) in enumerate(c2):
            ok = taus[stable[j]]
            if ok.size == 0:  # it cannot change lanes safely: it keeps its lane
                cats[i] = "C1"
                add_c1(i, m)
            elif still[j]:  # eq. 2 / eq. 4 in closed form, from rest laterally
                if cells:
                    ok = _from_lower_bound(taus, stable[j], float(tau_lo[j]))
                blocks.append(_Closed(ok, cells, v0[j], vxf[j], width[j], x0[j], m.y, 0.0))
                meta(i, ok.size, ok, t_plan + ok)
            else:
                add(i, *_moving_rows(np.array([v0[j], vxf[j], width[j], vy0[j], x0[j], m.y]),
                                     ok, t_plan, rel), ok, t_plan + ok)

    none = np.zeros(0)
    if not owner:
        empty = np.zeros((0, n_t))
        noint = np.zeros(0, dtype=np.int64)
        return LazyFutures(t, rel, ids, tuple(cats), noint, none, none, none, none, noint,
                           noint, empty, empty, empty, np.zeros(0, dtype=LANE_CHANGE),
                           np.zeros(0, dtype=bool))
    n_h = len(owner)
    lc = np.empty(n_h, dtype=LANE_CHANGE)
    lc.view(np.float64).fill(np.nan)  # (every field nan: np.full's structured fill is slow)
    cell = np.zeros(n_h, dtype=bool)
    row_of = np.full(n_h, -1, dtype=np.int64)
    stored: list[int] = []
    at_row: list[tuple[int, _Rows]] = []  # stored blocks: first row, rows
    c1: list[tuple[int, V2VMessage]] = []  # C1 TVs: row, message
    h0 = 0
    for b in blocks:
        if isinstance(b, _Closed):
            k = b.durations.size
            block = lc[h0:h0 + k]
            for name, value in zip(LANE_CHANGE.names, (b.v0, b.vxf, b.width, b.durations,
                                                       b.x0, b.y0, b.start), strict=True):
                block[name] = value
            cell[h0:h0 + k - 1] = b.cells  # a C2 cluster's neighbouring durations
        else:
            k = 1 if isinstance(b, _C1) else b.x.shape[0]
            row_of[h0:h0 + k] = range(len(stored), len(stored) + k)
            if isinstance(b, _C1):
                c1.append((len(stored), b.message))
            else:
                at_row.append((len(stored), b))
            stored.extend(range(h0, h0 + k))
        h0 += k
    sx, sy, sh = (np.empty((len(stored), n_t)) for _ in range(3))
    for r, b in at_row:
        k = b.x.shape[0]
        sx[r:r + k], sy[r:r + k], sh[r:r + k] = b.x, b.y, b.heading
    if c1:  # every C1 TV at once
        rows = np.array([r for r, _ in c1])
        sx[rows] = constant_acceleration([m for _, m in c1], t)[0]
        sy[rows] = np.array([m.y for _, m in c1])[:, None]
        sh[rows] = np.array([m.heading for _, m in c1])[:, None]
    return LazyFutures(
        t=t, rel=rel, vehicle_ids=ids, categories=tuple(cats),
        owner=np.array(owner, dtype=np.int64), tau=np.array(tau_h), t_end=np.array(t_end),
        length=np.array(lengths), width=np.array(widths),
        stored=np.array(stored, dtype=np.int64), row_of=row_of, sx=sx, sy=sy, sh=sh,
        lc=lc, cell=cell,
    )


class _Rows(NamedTuple):
    """Hypotheses stored as rows on the grid, each (k, n_t)."""

    x: Array  # m
    y: Array  # m
    heading: Array  # rad


class _C1(NamedTuple):
    """A C1 TV, its row computed with the others."""

    message: V2VMessage


class _Closed(NamedTuple):
    """Lane changes from rest (eq. 2 / eq. 4), one per duration."""

    durations: Array  # s
    cells: bool  # neighbouring durations bound cells (a C2 cluster)
    v0: float  # m/s
    vxf: float  # m/s
    width: float  # m
    x0: float  # m
    y0: float  # m
    start: float  # s, relative to the planning instant


# (start, durations, t_plan) -> (rel, x, y, heading) of `_moving_rows`: the last few
# instants' C2 TVs already moving laterally
_MOVING: dict[bytes, tuple[Array, Array, Array, Array]] = {}
MOVING_KEPT = 64  # entries kept (then all dropped): a fleet's AVs at one instant


def _moving_rows(start: Array, durations: Array, t_plan: float,
                 rel: Array) -> tuple[Array, Array, Array]:
    """(x, y, heading), each (durations.size, rel.size), of a C2 TV already moving
    laterally that changes lanes in each of `durations` (s) from `start` (vx0, vxf, W,
    vy0, x0, y0 at t_plan), at times rel (s after t_plan). The AVs of a fleet that check
    at one instant predict the same TV from the same message: its rows are computed
    once per instant (each sample on its own, so a longer grid's first columns are a
    shorter one's: the same numbers to the last bit)."""
    key = start.tobytes() + durations.tobytes() + np.float64(t_plan).tobytes()
    kept = _MOVING.get(key)
    n = rel.size
    if kept is not None and kept[0].size >= n and np.array_equal(kept[0][:n], rel):
        return kept[1][:, :n], kept[2][:, :n], kept[3][:, :n]
    v0, vxf, width, vy0, x0, y0 = start.tolist()
    d = cluster_derivatives(BoundaryConditions(v0, vxf, width, vy0=vy0), durations, rel,
                            (0, 1))
    (xg, yg), (xdg, ydg) = d[0], d[1]
    rows = (xg + x0, yg + y0, np.arctan2(ydg, xdg))
    if len(_MOVING) >= MOVING_KEPT:
        _MOVING.clear()
    _MOVING[key] = (rel.copy(), *rows)
    return rows


def _from_lower_bound(taus: Array, stable: NDArray[np.bool_], tau_lo: float) -> Array:
    """s, the durations listed for a C2 cluster from rest: a lower bound of its tau_min
    (given, or the grid point below its first stable one), then its stable grid points
    above it. The check covers every duration between neighbours."""
    ok = taus[stable]
    if not np.isfinite(tau_lo):
        first = int(np.flatnonzero(stable)[0])
        tau_lo = float(taus[max(first - 1, 0)])
    return np.concatenate(([tau_lo], ok[ok > tau_lo + 1e-9]))
