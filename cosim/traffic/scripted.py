"""Scripted traffic vehicles: the exact kinematics of a scenario's [[tv]] entries.

A scripted TV drives at constant acceleration in its lane (speed clipped at 0);
a [tv.brake] brakes it to a standstill, and with a hold time it drives off again
that long after stopping (stop-and-go: `restart_accel` up to `restart_speed`, its
initial speed by default); or, if it has a lane change, follows the paper's
min-jerk lane change (eq. 2, 4) from its state at the start: vx0 its speed then,
vxf the given target speed or the band rule, width the distance between the two
lane centres; afterwards it keeps vxf in the target lane. A start before 0 means
the change is already under way at t = 0: the TV's `speed` is its speed when the
change started, and its `gap` is where it is at t = 0.

The co-simulation drives scripted TVs in SUMO with exactly these kinematics, and
`cosim plan` builds its situation from them. What they broadcast (`message`):
intention +-1 from t = 0 until the change ends if broadcast is "reference" or
"intention"; the reference (LateralMotion, C3) while the change is under way if
"reference"; nothing about the change if "none" (C1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.params import RoadParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.traffic.v2v import LateralMotion, V2VMessage

if TYPE_CHECKING:
    from cosim.scenario.model import TVSpec

Array = NDArray[np.float64]

RESTART_ACCEL = 1.5  # m/s^2, a stopped scripted TV's default acceleration when it drives off


@dataclass(frozen=True)
class TVKinematics:
    """A scripted TV at times t (arrays shaped like t)."""

    x: Array  # m, global x of the centre
    y: Array  # m, global y of the centre
    heading: Array  # rad
    speed: Array  # m/s, along the path
    accel: Array  # m/s^2, along the path
    lateral_speed: Array  # m/s, + to the left


def _constant_accel(x0: float, v0: float, a: float, t: Array) -> tuple[Array, Array, Array]:
    """(x, v, a) from (x0, v0) at t = 0 under constant a, speed clipped at 0."""
    tt = t
    if a < 0.0:
        tt = np.minimum(t, v0 / -a)
    moving = (v0 + a * t > 0.0) | (a >= 0.0)
    return x0 + v0 * tt + 0.5 * a * tt * tt, np.maximum(v0 + a * t, 0.0), np.where(moving, a, 0.0)


def _restart(x0: float, a: float, v_max: float, t: Array) -> tuple[Array, Array, Array]:
    """(x, v, a) of a TV starting from rest at x0 at t = 0 (nothing before): `a` up to
    `v_max`, then steady."""
    tt = np.maximum(t, 0.0)
    t_top = v_max / a
    ta = np.minimum(tt, t_top)
    x = x0 + 0.5 * a * ta * ta + v_max * (tt - ta)
    return x, np.minimum(a * tt, v_max), np.where((t >= 0.0) & (tt < t_top), a, 0.0)


def lane_change_trajectory(
    tv: TVSpec, road: RoadParams, sv_position: float
) -> LaneChangeTrajectory | None:
    """The TV's lane change as a min-jerk trajectory in global coordinates (None: none)."""
    lc = tv.lane_change
    if lc is None:
        return None
    x_at_0 = sv_position + tv.gap
    y0 = road.lane_center(tv.lane)
    width = road.lane_center(lc.target_lane) - y0
    vxf = lc.target_speed if lc.target_speed is not None else road.target_speed(
        tv.lane, lc.target_lane
    )
    if lc.start > 0.0:
        xs, vs, _ = _constant_accel(x_at_0, tv.speed, tv.accel, np.array([lc.start]))
        return LaneChangeTrajectory(lc.start, lc.tau, float(xs[0]), y0, float(vs[0]), vxf, width)
    # already under way at t = 0: anchor it so that it passes x_at_0 at t = 0
    probe = LaneChangeTrajectory(lc.start, lc.tau, 0.0, y0, tv.speed, vxf, width)
    x_rel0 = float(probe.position(np.array([0.0]))[0][0])
    return LaneChangeTrajectory(lc.start, lc.tau, x_at_0 - x_rel0, y0, tv.speed, vxf, width)


def kinematics(tv: TVSpec, t: ArrayLike, road: RoadParams, sv_position: float) -> TVKinematics:
    """The TV at simulation times t (vectorised); `sv_position` is the SV's x at t = 0."""
    tt = np.asarray(t, dtype=float)
    y_lane = road.lane_center(tv.lane)
    traj = lane_change_trajectory(tv, road, sv_position)
    x, v, a = _constant_accel(sv_position + tv.gap, tv.speed, tv.accel, tt)
    zeros = np.zeros_like(tt)
    if traj is None:
        br = getattr(tv, "brake", None)
        if br is not None:  # constant accel until br.at, then -br.decel down to standstill
            xb, vb, _ = _constant_accel(sv_position + tv.gap, tv.speed, tv.accel,
                                        np.array([br.at]))
            x2, v2, a2 = _constant_accel(float(xb[0]), float(vb[0]), -br.decel, tt - br.at)
            after = tt >= br.at
            x, v, a = np.where(after, x2, x), np.where(after, v2, v), np.where(after, a2, a)
            if br.hold is not None:  # stop-and-go: `hold` s at rest, then off again
                t_go = br.at + float(vb[0]) / br.decel + br.hold
                x_stop = float(xb[0]) + float(vb[0]) ** 2 / (2.0 * br.decel)
                v_top = br.restart_speed if br.restart_speed is not None else tv.speed
                accel = br.restart_accel if br.restart_accel is not None else RESTART_ACCEL
                x3, v3, a3 = _restart(x_stop, accel, v_top, tt - t_go)
                go = tt >= t_go
                x, v, a = np.where(go, x3, x), np.where(go, v3, v), np.where(go, a3, a)
        return TVKinematics(x, zeros + y_lane, zeros, v, a, zeros)
    before = tt < traj.t0
    if traj.t0 <= 0.0:  # before a change under way at 0: steady at its start speed
        x = traj.x0 + traj.vx0 * (tt - traj.t0)
        v, a = zeros + traj.vx0, zeros
    tc = np.where(before, traj.t0, tt)  # the trajectory is evaluated from its start on
    lx, ly = traj.position(tc)
    vx, vy = traj.derivative(tc, 1)
    return TVKinematics(
        x=np.where(before, x, lx),
        y=np.where(before, y_lane, ly),
        heading=np.where(before, 0.0, np.arctan2(vy, vx)),
        speed=np.where(before, v, np.hypot(vx, vy)),
        accel=np.where(before, a, traj.acceleration(tc)),
        lateral_speed=np.where(before, 0.0, vy),
    )


def message(tv: TVSpec, t: float, road: RoadParams, sv_position: float) -> V2VMessage:
    """What the TV broadcasts at simulation time t (measured at t, no latency)."""
    k = kinematics(tv, np.array([t]), road, sv_position)
    x, y = float(k.x[0]), float(k.y[0])
    lc = tv.lane_change
    intention = 0
    motion = None
    if lc is not None and t < lc.start + lc.tau:
        if lc.broadcast in ("reference", "intention"):
            intention = 1 if lc.target_lane > tv.lane else -1
        if lc.broadcast == "reference" and t >= lc.start:
            traj = lane_change_trajectory(tv, road, sv_position)
            assert traj is not None
            motion = LateralMotion(
                t0=traj.t0, tau=traj.tau, x0=traj.x0, y0=traj.y0, vx0=traj.vx0,
                vxf=traj.vxf, width=traj.width, profile="quintic",
            )
    return V2VMessage(
        vehicle_id=tv.id, t=t, x=x, y=y, heading=float(k.heading[0]),
        speed=float(k.speed[0]), accel=float(k.accel[0]), lane=road.lane_of(y),
        lateral_speed=float(k.lateral_speed[0]), length=tv.length, width=tv.width,
        intention=intention, motion=motion,
    )


class ScriptedTV:
    """One scripted TV bound to a road and the SV's start (for the co-simulation)."""

    def __init__(self, spec: TVSpec, road: RoadParams, sv_position: float) -> None:
        self.spec = spec
        self.road = road
        self.sv_position = sv_position

    def kinematics(self, t: ArrayLike) -> TVKinematics:
        return kinematics(self.spec, t, self.road, self.sv_position)

    def message(self, t: float) -> V2VMessage:
        return message(self.spec, t, self.road, self.sv_position)


class ScriptedTraffic:
    """A scenario's scripted TVs in one run: their poses at the run's step times
    t_k = k dt, k = 0 .. n - 1, evaluated once (the scripts are known in advance)."""

    def __init__(self, specs: Sequence[TVSpec], road: RoadParams, sv_position: float,
                 dt: float, n: int) -> None:
        self.dt = dt  # s
        self.tvs = [ScriptedTV(spec, road, sv_position) for spec in specs]
        self.ids: tuple[str, ...] = tuple(spec.id for spec in specs)
        times = dt * np.arange(n)
        # per TV, per step: (x m, y m, heading rad, speed m/s, accel m/s^2) in road coordinates
        self.poses: list[list[tuple[float, ...]]] = []
        for tv in self.tvs:
            k = tv.kinematics(times)
            self.poses.append(list(zip(k.x.tolist(), k.y.tolist(), k.heading.tolist(),
                                       k.speed.tolist(), k.accel.tolist(), strict=True)))

    def at(self, t: float) -> list[tuple[ScriptedTV, tuple[float, ...]]]:
        """Every scripted TV with its pose at step time t."""
        k = int(round(t / self.dt))
        return [(tv, poses[k]) for tv, poses in zip(self.tvs, self.poses, strict=True)]

    def messages(self, t: float) -> list[V2VMessage]:
        """The scripted TVs' own messages at t (`ScriptedTV.message`)."""
        return [m for m in (tv.message(t) for tv in self.tvs) if m is not None]
