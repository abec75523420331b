"""V2V messages: what a traffic vehicle (TV) tells the subject vehicle (SV).

Assumption S1 of the paper: every TV within range publishes its state, its
lane-change intention and, while changing lanes, its reference trajectory. The
planner's TV prediction (categories C1/C2/C3) reads only these messages.

`V2VChannel` carries them: a range around the SV, a fixed latency, independent
loss of each message (seeded RNG), and a perception-only mode (the paper's
Remark 2 without V2V: noisy measured state, no intention, no trajectory).
A TV changing lanes under SUMO's `--lanechange.duration` moves sideways at a
constant speed W/D; `lateral_motion` turns what is measured (lateral position
and speed) back into the `LateralMotion` it would broadcast.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from cosim.errors import InputError
from cosim.params import RoadParams

if TYPE_CHECKING:
    from cosim.planning.trajectory import LaneChangeTrajectory
    from cosim.traffic.sumo import TrafficSnapshot


@dataclass(frozen=True)
class LateralMotion:
    """A TV's lane change as it broadcasts it (category C3).

    `profile` "quintic": the paper's min-jerk lane change (eq. 2, 4) with these
    boundary values; "linear": SUMO's `--lanechange.duration` motion, constant
    lateral speed width/tau, longitudinal speed constant at vx0.
    """

    t0: float  # s, simulation time the lane change started
    tau: float  # s, its duration
    x0: float  # m, global x of the TV's centre at t0
    y0: float  # m, global y of the TV's centre at t0
    vx0: float  # m/s, longitudinal speed at t0
    vxf: float  # m/s, longitudinal speed at t0 + tau
    width: float  # m, signed lateral displacement (+ to the left)
    profile: str = "quintic"  # "quintic" | "linear"
    # "quintic": the start's accelerations and lateral speed (0 for a plan, which starts
    # from rest; a re-check's rescue starts under way)
    ax0: float = 0.0  # m/s^2, longitudinal acceleration at t0
    vy0: float = 0.0  # m/s, lateral speed at t0
    ay0: float = 0.0  # m/s^2, lateral acceleration at t0

    @classmethod
    def of(cls, tr: LaneChangeTrajectory) -> LateralMotion:
        """The broadcast of a planned lane change (eq. 2, 4), exactly as it is flown."""
        return cls(t0=tr.t0, tau=tr.tau, x0=tr.x0, y0=tr.y0, vx0=tr.vx0, vxf=tr.vxf,
                   width=tr.width, ax0=tr.ax0, vy0=tr.vy0, ay0=tr.ay0)

    @property
    def from_rest(self) -> bool:
        """A quintic change from rest laterally and at constant speed (eq. 2, 4 as the
        paper plans it: x'' = y' = y'' = 0 at t0)."""
        return self.ax0 == 0.0 and self.vy0 == 0.0 and self.ay0 == 0.0

    def position(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """m, global (x, y) of the TV's centre at absolute time(s) t.

        Before t0 the TV is taken at (x0, y0) moving at vx0; after t0 + tau it
        keeps vxf in the target lane. "quintic": eq. 2 and eq. 4; "linear":
        constant lateral speed width/tau, longitudinal speed vx0.
        """
        t = np.asarray(t, dtype=float)
        dt = t - self.t0
        if self.profile == "linear":
            s = np.clip(dt / self.tau, 0.0, 1.0)
            return self.x0 + self.vx0 * dt, self.y0 + self.width * s
        if self.profile != "quintic":
            raise ValueError(f"unknown LateralMotion profile {self.profile!r}")
        from cosim.planning.trajectory import LaneChangeTrajectory  # planning imports v2v

        ref = LaneChangeTrajectory(
            t0=self.t0, tau=self.tau, x0=self.x0, y0=self.y0,
            vx0=self.vx0, vxf=self.vxf, width=self.width,
            ax0=self.ax0, vy0=self.vy0, ay0=self.ay0,
        )  # fmt: skip
        x, y = ref.position(np.maximum(t, self.t0))
        before = dt < 0.0
        return np.where(before, self.x0 + self.vx0 * dt, x), np.where(before, self.y0, y)


@dataclass(frozen=True)
class V2VMessage:
    """One TV's broadcast, measured at simulation time `t`."""

    vehicle_id: str
    t: float  # s, simulation time of the measurement
    x: float  # m, global x of the vehicle's centre
    y: float  # m, global y of the vehicle's centre
    heading: float  # rad, math convention (0 along +x, counter-clockwise)
    speed: float  # m/s
    accel: float  # m/s^2, longitudinal
    lane: int  # SUMO lane index
    lateral_speed: float  # m/s, + to the left
    length: float  # m
    width: float  # m
    intention: int  # -1 wants to change right, 0 none, +1 wants to change left (blinker)
    motion: LateralMotion | None = None  # set while the TV is changing lanes (C3)
    since: float = math.nan  # s, when its intention began (an automated vehicle's own
    # announcement, cosim.run.announcements; nan: not known)


# m/s, below this a TV is not changing lanes: SUMO's lane changes move sideways at
# width / lanechange.duration (about 1 m/s) or its sublane maxSpeedLat (1 m/s); slower
# drift (a vehicle SUMO takes back from moveToXY settling on its lane) would read as a
# change lasting hours and stretch every collision check over it
LATERAL_SPEED_EPS = 0.1


def lateral_motion(
    t: float,
    x: float,
    y: float,
    heading: float,
    speed: float,
    lateral_speed: float,
    length: float,
    road: RoadParams,
) -> LateralMotion | None:
    """The linear lane change a TV is in, reconstructed from one measurement.

    SUMO's `--lanechange.duration` moves the front bumper sideways at a constant
    speed from the origin lane's centre; the origin lane is the one whose centre
    the front has left behind (by at most a lane width). The front's line gives
    the start, the centre follows it L/(2|v|) later; tau = W / |vy|. Measured: the
    centre's y 1 s ahead: 99th percentile 6 cm, max 9 cm (16 veh/km/lane).

    With SUMO's sublane model instead, the lateral speed is a trapezoid and a change
    need not end on a lane centre: this reconstruction is then only approximate
    (measured 1 s ahead: median 3 cm, 90th percentile 0.42 m, max 0.89 m).
    """
    if abs(lateral_speed) < LATERAL_SPEED_EPS:
        return None
    sign = 1.0 if lateral_speed > 0 else -1.0
    y_front = y + 0.5 * length * math.sin(heading)
    u = (y_front - road.y_right) / road.lane_width - 0.5  # lane coordinate of the front
    # the front leaves the origin centre in the first step and sits exactly on the
    # target centre in the last one (SUMO still reports the lateral speed then)
    origin = math.ceil(u - 1e-6) - 1 if sign > 0 else math.floor(u + 1e-6) + 1
    y0 = road.lane_center(origin)
    vx = speed  # SUMO's speed is along the lane; the sideways motion comes on top
    # the centre trails the front by L/2 sin(h), h = atan2(vy, vx) once the body has
    # turned (SUMO turns it within a few steps): the centre's line is the front's,
    # L / (2 |v|) later; from the front this holds from the first step on
    t0 = t - (y_front - y0) / lateral_speed + 0.5 * length / math.hypot(vx, lateral_speed)
    return LateralMotion(
        t0=t0,
        tau=road.lane_width / abs(lateral_speed),
        x0=x - vx * (t - t0),
        y0=y0,
        vx0=vx,
        vxf=vx,
        width=sign * road.lane_width,
        profile="linear",
    )


class Override(NamedTuple):
    """What a vehicle that knows its own plan announces instead of what SUMO shows."""

    intention: int  # -1 right, 0 none, +1 left
    motion: LateralMotion | None  # its lane change under way (C3; None: none)
    since: float = math.nan  # s, when the intention began (nan: not known)


# what `messages` builds once per step for all receivers (`shared`): per vehicle, the
# measurement its message is made of, and the message
Shared = dict[str, tuple[tuple[object, ...], "V2VMessage"]]


def messages(
    snapshot: TrafficSnapshot,
    road: RoadParams,
    overrides: Mapping[str, Override] | None = None,
    shared: Shared | None = None,
) -> list[V2VMessage]:
    """What every vehicle of `snapshot` broadcasts (S1): state, blinker, lane change.

    A SUMO TV's lane change is rebuilt from its lateral motion (`lateral_motion`).
    `overrides` replaces (intention, motion) for vehicles that know their own plan:
    the automated vehicles of a fleet broadcast their blinker and the lane change they
    fly (cosim.run.announcements).
    `shared` (one dict per step and `road`, for receivers of rows of one snapshot: a
    fleet's AVs): a vehicle's message without an override is built once and handed to
    every receiver that has the same measurement of it (its fields compared; rows of
    one snapshot are the same numbers), the message it would have built itself.
    """
    intention = snapshot.intention.tolist()
    overrides = overrides or {}
    time = snapshot.time
    cols = zip(snapshot.x.tolist(), snapshot.y.tolist(), snapshot.heading.tolist(),
               snapshot.speed.tolist(), snapshot.accel.tolist(), snapshot.lane.tolist(),
               snapshot.lateral_speed.tolist(), snapshot.length.tolist(),
               snapshot.width.tolist(), intention, strict=True)
    out = []
    for vid, row in zip(snapshot.ids, cols, strict=True):
        x, y, heading, speed, accel, lane, lateral_speed, length, width, blinker = row
        override = overrides.get(vid)
        if override is None and shared is not None:
            kept = shared.get(vid)
            if kept is not None and kept[0] == row and kept[1].t == time:
                out.append(kept[1])
                continue
        since = math.nan
        if override is not None:
            announced, motion, since = override
        else:
            announced = int(blinker)
            motion = lateral_motion(time, x, y, heading, speed, lateral_speed, length, road)
        msg = V2VMessage(vehicle_id=vid, t=time, x=x, y=y, heading=heading, speed=speed,
                         accel=accel, lane=int(lane), lateral_speed=lateral_speed,
                         length=length, width=width, intention=int(announced), motion=motion,
                         since=since)
        if override is None and shared is not None:
            shared[vid] = (row, msg)
        out.append(msg)
    return out


@dataclass(frozen=True)
class PerceptionNoise:
    """Standard deviations of what on-board sensors measure (perception-only mode)."""

    position: float = 0.2  # m, x and y of the centre
    heading: float = 0.01  # rad
    speed: float = 0.2  # m/s
    accel: float = 0.3  # m/s^2
    lateral_speed: float = 0.1  # m/s


MODES = ("v2v", "perception")


class V2VChannel:
    """Messages from the TVs within `range` of the SV, `latency` late, each lost with `loss`.

    `exchange(snapshot, sv_x, sv_y)` once per step: the TVs publish, and the
    SV's current view comes back: the newest message it has received from each
    TV, no older than `max_age`. Mode "perception": the SV measures instead
    (same range and latency; noisy state, no intention, no lane-change motion).
    """

    def __init__(
        self,
        road: RoadParams,
        range: float = 300.0,  # m, the scenario's own name for it
        latency: float = 0.0,
        loss: float = 0.0,
        mode: str = "v2v",
        seed: int = 0,
        max_age: float = 1.0,
        noise: PerceptionNoise | None = None,
    ) -> None:
        if range < 0:
            raise InputError("v2v", "range_m", range, ">= 0 m")
        if latency < 0:
            raise InputError("v2v", "latency_s", latency, ">= 0 s")
        if not 0.0 <= loss <= 1.0:
            raise InputError("v2v", "loss", loss, "a probability in [0, 1]")
        if mode not in MODES:
            raise InputError("v2v", "mode", mode, " | ".join(MODES))
        self.road = road
        self.range = float(range)
        self.latency = float(latency)
        self.loss = float(loss)
        self.mode = mode
        self.max_age = float(max_age)
        self.noise = noise or PerceptionNoise()
        self.rng = np.random.default_rng(seed)
        self._queue: deque[tuple[float, V2VMessage]] = deque()  # (arrival time, message)
        self._latest: dict[str, V2VMessage] = {}
        self.sent = 0  # messages published
        self.lost = 0  # messages dropped by the channel

    @classmethod
    def from_spec(cls, spec: object, road: RoadParams, seed: int) -> V2VChannel:
        """From a scenario's V2VSpec (range, latency, loss, mode)."""
        return cls(
            road,
            range=spec.range,  # type: ignore[attr-defined]
            latency=spec.latency,  # type: ignore[attr-defined]
            loss=spec.loss,  # type: ignore[attr-defined]
            mode=spec.mode,  # type: ignore[attr-defined]
            seed=seed,
            noise=PerceptionNoise(
                position=getattr(spec, "noise_position", PerceptionNoise.position),
                heading=getattr(spec, "noise_heading", PerceptionNoise.heading),
                speed=getattr(spec, "noise_speed", PerceptionNoise.speed),
                accel=getattr(spec, "noise_accel", PerceptionNoise.accel),
                lateral_speed=getattr(spec, "noise_lateral_speed", PerceptionNoise.lateral_speed),
            ),
        )

    def publish(
        self,
        snapshot: TrafficSnapshot,
        sv_x: float,
        sv_y: float,
        overrides: Mapping[str, Override] | None = None,
        shared: Shared | None = None,
    ) -> None:
        """The TVs of `snapshot` within range send (or are measured) now.

        `overrides`: (intention, motion) of vehicles that announce their own plan
        (scripted TVs); ignored in perception mode, where nobody announces anything.
        `shared`: messages built this step for other receivers (`messages`).
        """
        near = np.hypot(snapshot.x - sv_x, snapshot.y - sv_y) <= self.range
        snap = snapshot.select(near)
        if len(snap) == 0:
            return
        kept = self.rng.random(len(snap)) >= self.loss  # drawn for every message: reproducible
        self.sent += len(snap)
        self.lost += int(np.sum(~kept))
        snap = snap.select(kept)
        measured = self.mode == "perception"
        batch = (self._measure(snap) if measured
                 else messages(snap, self.road, overrides, shared))
        arrival = snapshot.time + self.latency
        self._queue.extend((arrival, m) for m in batch)

    def _measure(self, snap: TrafficSnapshot) -> list[V2VMessage]:
        n, nz = len(snap), self.noise
        r = self.rng.standard_normal((6, n))
        return [
            V2VMessage(
                vehicle_id=vid,
                t=snap.time,
                x=float(snap.x[i] + nz.position * r[0, i]),
                y=float(snap.y[i] + nz.position * r[1, i]),
                heading=float(snap.heading[i] + nz.heading * r[2, i]),
                speed=float(snap.speed[i] + nz.speed * r[3, i]),
                accel=float(snap.accel[i] + nz.accel * r[4, i]),
                lane=self.road.lane_of(float(snap.y[i] + nz.position * r[1, i])),
                lateral_speed=float(snap.lateral_speed[i] + nz.lateral_speed * r[5, i]),
                length=float(snap.length[i]),
                width=float(snap.width[i]),
                intention=0,
                motion=None,
            )
            for i, vid in enumerate(snap.ids)
        ]

    def receive(self, t: float) -> list[V2VMessage]:
        """The SV's view at time t: newest delivered message per TV, at most max_age old."""
        while self._queue and self._queue[0][0] <= t + 1e-9:
            _, msg = self._queue.popleft()
            self._latest[msg.vehicle_id] = msg
        stale = [vid for vid, m in self._latest.items() if t - m.t > self.max_age + 1e-9]
        for vid in stale:
            del self._latest[vid]
        return list(self._latest.values())

    def exchange(
        self,
        snapshot: TrafficSnapshot,
        sv_x: float,
        sv_y: float,
        overrides: Mapping[str, Override] | None = None,
        shared: Shared | None = None,
    ) -> list[V2VMessage]:
        """publish + receive at the snapshot's time (one call per step)."""
        self.publish(snapshot, sv_x, sv_y, overrides, shared)
        return self.receive(snapshot.time)
