"""Futures of the traffic vehicles from their V2V messages (Section 3.2, S1-S3, C1-C3).

- C1, no lane-change intention: constant acceleration, speed clipped at 0, lane kept.
- C2, intention +-1 and no motion yet: every trajectory of the TV's own stable
  cluster (S3: the TVs are built like the SV, same envelope) to the adjacent lane
  in that direction, with the band-rule target speed, starting at the planning
  instant. The SV must be safe against all of them: one hypothesis per stable tau.
- C3, motion broadcast: the reference it sends (quintic min-jerk, eq. 2 and 4, or
  SUMO's linear lateral motion).

Output: `TVFutures`, arrays over (hypothesis, time) of centre x, y and heading.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cosim.params import RoadParams, VehicleParams
from cosim.planning.envelope import MODES, envelope_margin, paper_map_tau_min
from cosim.planning.trajectory import (
    cluster_derivatives,
    standard_positions,
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


def category(msg: V2VMessage) -> str:
    """C3 when a motion is broadcast, C2 when only an intention, else C1."""
    if msg.motion is not None:
        return "C3"
    return "C2" if msg.intention != 0 else "C1"


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


def constant_acceleration(msg: V2VMessage, t: Array) -> tuple[Array, Array]:
    """(x, speed) at absolute times t from the message's state, speed clipped at 0 (C1)."""
    dt = t - msg.t
    v, a = msg.speed, msg.accel
    if a < 0.0:
        dt = np.minimum(dt, v / -a)  # stopped: stays
    return msg.x + v * dt + 0.5 * a * dt * dt, np.maximum(v + a * dt, 0.0)


def motion_path(m: LateralMotion, t: Array) -> tuple[Array, Array, Array]:
    """(x, y, heading) of a broadcast lane change (C3) at absolute times t."""
    rel = t - m.t0
    if m.profile == "linear":
        s = np.clip(rel / m.tau, 0.0, 1.0)
        moving = (rel > 0) & (rel < m.tau)
        heading = np.where(moving, np.arctan2(m.width / m.tau, m.vx0), 0.0)
        return m.x0 + m.vx0 * rel, m.y0 + m.width * s, heading
    d = cluster_derivatives(m.vx0, m.vxf, m.width, np.array([m.tau]), rel, (0, 1))
    (x, y), (xd, yd) = d[0], d[1]
    return x[0] + m.x0, y[0] + m.y0, np.arctan2(yd[0], xd[0])


StableFn = Callable[[Array, Array, Array, Array], NDArray[np.bool_]]


def predict(
    messages: Sequence[V2VMessage], t_plan: float, t_rel: Array, road: RoadParams,
    vehicle: VehicleParams, taus: Array, *, envelope: str = "inverse_dynamics",
    safety_factor: float = 0.8, stable_fn: StableFn | None = None,
) -> TVFutures:
    """TV futures at absolute times t_plan + t_rel for every message (C1/C2/C3).

    C2 clusters use the planner's tau grid `taus` and its envelope: all C2 TVs are
    checked in one batched envelope call, or by `stable_fn(vx0, vxf, width, vy0)`
    -> (n_c2, n_tau) bool when given (the planner's tau_min maps).
    """
    t = t_plan + np.asarray(t_rel, dtype=float)
    n_t = t.size
    ids = tuple(m.vehicle_id for m in messages)
    cats: list[str] = []
    xs: list[Array] = []
    ys: list[Array] = []
    hs: list[Array] = []
    owner: list[IntArray] = []
    tau_h: list[Array] = []
    t_end: list[Array] = []
    dims: list[Array] = []
    c2: list[tuple[int, V2VMessage, int, int]] = []

    def add(i: int, x: Array, y: Array, h: Array, tau: Array | float, end: Array | float) -> None:
        """One block of hypotheses of TV i: x, y, h shaped (k, n_t) or (n_t,)."""
        x2 = np.atleast_2d(x)
        k = x2.shape[0]
        xs.append(x2)
        ys.append(np.broadcast_to(y, (k, n_t)))
        hs.append(np.broadcast_to(h, (k, n_t)))
        owner.append(np.full(k, i, dtype=np.int64))
        tau_h.append(np.broadcast_to(np.asarray(tau, dtype=float), (k,)))
        t_end.append(np.broadcast_to(np.asarray(end, dtype=float), (k,)))
        dims.append(np.broadcast_to([messages[i].length, messages[i].width], (k, 2)))

    def add_c1(i: int, m: V2VMessage) -> None:
        x, _ = constant_acceleration(m, t)
        add(i, x, np.full(n_t, m.y), np.full(n_t, m.heading), np.nan, -np.inf)

    for i, m in enumerate(messages):
        cat = category(m)
        if cat == "C3":
            assert m.motion is not None
            x, y, h = motion_path(m.motion, t)
            add(i, x, y, h, m.motion.tau, m.motion.t0 + m.motion.tau)
        elif cat == "C2" and (lanes := c2_lanes(m, road)) is not None:
            c2.append((i, m, *lanes))
        else:
            cat = "C1"
            add_c1(i, m)
        cats.append(cat)

    if c2:
        # the TVs' state at the planning instant (they start when the SV does)
        starts = [constant_acceleration(m, np.array([t_plan])) for _, m, _, _ in c2]
        x0 = np.array([s[0][0] for s in starts])
        v0 = np.array([s[1][0] for s in starts])
        vxf = np.array([road.target_speed(o, g) for _, _, o, g in c2])
        width = np.array([road.lane_center(g) - m.y for _, m, _, g in c2])
        vy0 = np.array([m.lateral_speed for _, m, _, _ in c2])
        n_tau = taus.size
        if stable_fn is not None:
            stable = stable_fn(v0, vxf, width, vy0)
        elif envelope == "paper_maps":
            tmin = np.array([
                paper_map_tau_min(MODES.get((o, g), 1), v, road.mu)
                for (_, _, o, g), v in zip(c2, v0, strict=True)
            ])
            stable = taus[None, :] >= tmin[:, None]
        else:
            margin = envelope_margin(
                np.repeat(v0, n_tau), np.repeat(vxf, n_tau), np.repeat(width, n_tau),
                np.tile(taus, len(c2)), road.mu, vehicle, safety_factor=safety_factor,
                yaw_model=envelope, vy0=np.repeat(vy0, n_tau),
            )
            stable = (margin <= 1.0).reshape(len(c2), n_tau)
        rel = t - t_plan
        still = np.abs(vy0) < 1e-12
        # TVs starting from rest laterally: eq. 2 / eq. 4 in closed form, all in one batch
        rows_j, rows_tau = np.nonzero(stable & still[:, None])
        if rows_j.size:
            tau_r = taus[rows_tau]
            x, y = standard_positions(v0[rows_j], vxf[rows_j], width[rows_j], tau_r, rel)
            xd, yd = standard_velocities(v0[rows_j][:, None], vxf[rows_j][:, None],
                                         width[rows_j][:, None], tau_r[:, None], rel[None, :])
            x += x0[rows_j][:, None]
            y += np.array([m.y for _, m, _, _ in c2])[rows_j][:, None]
            heading = np.arctan2(yd, xd)
        for j, (i, m, _, _) in enumerate(c2):
            ok = taus[stable[j]]
            if ok.size == 0:  # it cannot change lanes safely: it keeps its lane
                cats[i] = "C1"
                add_c1(i, m)
            elif still[j]:
                a, b = np.searchsorted(rows_j, [j, j + 1])  # rows are grouped by TV: a view
                add(i, x[a:b], y[a:b], heading[a:b], ok, t_plan + ok)
            else:
                d = cluster_derivatives(v0[j], vxf[j], width[j], ok, rel, (0, 1), vy0=vy0[j])
                (xg, yg), (xdg, ydg) = d[0], d[1]
                add(i, xg + x0[j], yg + m.y, np.arctan2(ydg, xdg), ok, t_plan + ok)

    if not owner:
        empty = np.zeros((0, n_t))
        none = np.zeros(0)
        return TVFutures(t, ids, tuple(cats), np.zeros(0, dtype=np.int64), none, none,
                         empty, empty, empty, none, none)
    dim = np.concatenate(dims)
    return TVFutures(
        t=t,
        vehicle_ids=ids,
        categories=tuple(cats),
        owner=np.concatenate(owner),
        tau=np.concatenate(tau_h),
        t_end=np.concatenate(t_end),
        x=np.concatenate(xs),
        y=np.concatenate(ys),
        heading=np.concatenate(hs),
        length=dim[:, 0].copy(),
        width=dim[:, 1].copy(),
    )
