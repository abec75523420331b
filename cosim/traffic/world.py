"""The world the SV drives in: SUMO (through SumoSim) started for a scenario, its
random traffic placed, and at the top of each step the scene around the SV.

`World.start` starts SUMO on the scenario's network and populates the traffic
(leaving the SV's start free); the loop then adds the scripted TVs (observer)
and the SV (ego), and `World.step` inserts them all. Each step `World.read`
reads every vehicle within `radius` of the SV (SumoSim.snapshot_near: the cost
follows the traffic near the SV, not the whole road's), and `Scene.around`
keeps the TVs within NEAR_RANGE (x) of the SV, which the policy's decision rule,
the recorder and the figures use. SUMO's own collisions involving the SV are
read after each step (a cross-check of our exact overlap test).

Nothing outside cosim.traffic reaches SUMO: the ego, the observer and the policy's
ports (cosim.driving.base.WorldPorts) go through the named calls below (the SV and
the scripted TVs placed and moved, the SV's blinker, a lane change SUMO makes for the
SUMO-driven SV, gap requests to TVs through the cooperation channels).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cosim.errors import SimulationError, check_signals
from cosim.params import RoadParams
from cosim.scenario.model import Scenario
from cosim.traffic.cooperation import (
    COURTESY,
    CooperationChannel,
    CooperationConfig,
    done_yielding,
)
from cosim.traffic.gui import GuiSettings
from cosim.traffic.process import SumoOptions
from cosim.traffic.road_view import (
    cartesian_pose,
    is_identity,
    place_upstream,
    road_view,
    upstream_lanes,
)
from cosim.traffic.route_lanes import load_route_road, sv_start
from cosim.traffic.sumo import SumoSim, TrafficSnapshot
from cosim.traffic.sumo_measures import SumoMeasures

if TYPE_CHECKING:
    from cosim.traffic.scripted import ScriptedTraffic

Array = NDArray[np.float64]
# Told the warm-up's number of steps, it returns what counts each step done.
WarmupProgress = Callable[[int], Callable[[int], None]]

SV_ID = "sv"
SV_LANE_CHANGE_DURATION = 30.0  # s, SUMO keeps trying a lane change it is asked for this long
COOPERATION_STREAM = 16  # -, second seed word of the V2V gap requests' generator
COURTESY_STREAM = 17  # -, the same for the traffic's courtesy
SV_LENGTH_MARGIN = 2.0  # SV lengths kept free of random traffic around the SV at t = 0
NEAR_RANGE = 150.0  # m, TVs within this x distance of the SV are recorded for the figures


@dataclass(frozen=True)
class SVState:
    """The SV's state at the top of a step, as the policy and the recorder see it: its
    centre in road coordinates (s along the route's reference line, d across it, heading
    to the road: cosim.traffic.road_view; on the one straight edge these are the
    Cartesian x, y, heading), its Cartesian centre pose in `cartesian`."""

    x: float  # m, s of the centre
    y: float  # m, d of the centre, + to the left
    heading: float  # rad, to the road's direction
    vx: float  # m/s, body longitudinal speed in road coordinates (the car's: stretch vx)
    vy: float  # m/s, body lateral speed
    sumo_lane: int  # SUMO's lane index of the SV on `edge` (-1: off the network)
    edge: str = ""  # SUMO's road id of the SV (a junction's internal edge too; "": off it)
    # (x m, y m, heading rad) in the Cartesian plane when x, y, heading are road
    # coordinates of a curved frame; None: the frame is the identity, they are the same
    cartesian: tuple[float, float, float] | None = None
    stretch: float = 1.0  # -, q of the frame at the SV: its speed is q vx (road_view)

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x m, y m, heading rad): the Cartesian centre pose."""
        return self.cartesian if self.cartesian is not None else (self.x, self.y, self.heading)


@dataclass(frozen=True)
class Scene:
    """The loop's view at the top of a step: the SV's state and the vehicles around it
    (road coordinates, as `SVState`)."""

    t: float  # s, simulation time (0 at the first step)
    sv: SVState
    everyone: TrafficSnapshot  # every vehicle within the read radius, the SV included
    tvs: TrafficSnapshot  # TVs on the network within NEAR_RANGE (x) of the SV
    tv_vx: Array  # m/s, their global x velocities

    @classmethod
    def around(cls, t: float, sv: SVState, everyone: TrafficSnapshot,
               own_id: str = SV_ID) -> Scene:
        """The scene of an SV (`own_id`: the SV or an automated vehicle of the fleet) in a
        snapshot (its own row is left out of `tvs`)."""
        near = (np.abs(everyone.x - sv.x) <= NEAR_RANGE) & (everyone.lane >= 0)
        near[everyone.index(own_id)] = False
        tvs = everyone.select(near)
        return cls(t, sv, everyone, tvs, tvs.speed * np.cos(tvs.heading))

    @classmethod
    def around_all(cls, t: float, svs: list[SVState], everyone: TrafficSnapshot,
                   own_ids: list[str]) -> list[Scene]:
        """`around` for several SVs in one snapshot at once (the fleet's automated
        vehicles): one (SVs x vehicles) search, the same scenes."""
        if not svs:
            return []
        x = np.array([sv.x for sv in svs])
        near = (np.abs(everyone.x[None, :] - x[:, None]) <= NEAR_RANGE) \
            & (everyone.lane >= 0)[None, :]
        row = {vid: i for i, vid in enumerate(everyone.ids)}
        near[np.arange(len(svs)), [row[vid] for vid in own_ids]] = False
        scenes = []
        for sv, mask in zip(svs, near, strict=True):
            tvs = everyone.select(mask)
            scenes.append(cls(t, sv, everyone, tvs, tvs.speed * np.cos(tvs.heading)))
        return scenes


def cooperation_channels(sc: Scenario, words: tuple[int, ...] = ()
                         ) -> list[CooperationChannel]:
    """The gap requests' channels of a run (cosim.traffic.cooperation): the traffic's
    courtesy (`[traffic] courtesy`) and cooperative V2V (`[v2v] cooperation`); each
    draws from a generator of its own, seeded by the scenario's seed (and `words`: an
    automated vehicle's own, cosim.run.fleet)."""
    configs = []
    if sc.traffic.courtesy:
        configs.append((COURTESY_STREAM, COURTESY))
    if sc.v2v.cooperation:
        configs.append((COOPERATION_STREAM, CooperationConfig(
            enabled=True, compliance=sc.v2v.cooperation_compliance,
            latency=sc.v2v.cooperation_latency)))
    return [CooperationChannel(cfg, np.random.default_rng([sc.seed, stream, *words]))
            for stream, cfg in configs]


def deliver_requests(channels: list[CooperationChannel], api: Any, vehicle_id: str, t: float,
                     tvs: TrafficSnapshot, x: float, length: float, changing: bool) -> None:
    """One step of the gap requests `vehicle_id` (centre x m, `length` m) sent through
    `channels`, among the TVs around it `tvs`: those yielding told when its change
    begins, those due delivered, those ahead of it or standing level released."""
    ahead = done_yielding(tvs.x, tvs.length, tvs.speed, x, length)
    for channel in channels:
        channel.changing(api, vehicle_id, changing, tvs.ids)
        channel.deliver(t, api, vehicle_id, tvs.ids)
        channel.release(api, tvs.ids, ahead)


def in_start_zones(snap: TrafficSnapshot, sc: Scenario, x0: float, track: int) -> list[str]:
    """The ids, sorted, of the vehicles in `snap` that reach into the zones the SV (at
    road coordinate `x0` in `track`) and the scenario's scripted TVs start in: `start_zone`
    in their own lane, SV_LENGTH_MARGIN SV lengths around the SV in every lane."""
    from cosim.traffic.demand import start_zone

    bands = sc.road.speed_bands
    margin = SV_LENGTH_MARGIN * sc.vehicle.length
    zones = [(-1, x0 - margin, x0 + margin),
             (track, *start_zone(x0, sc.vehicle.length, sc.sv.speed, bands[track][1]))]
    for tv in sc.in_tracks(track).tvs:
        if 0 <= tv.lane < len(bands):
            zones.append((tv.lane, *start_zone(x0 + tv.gap, tv.length, tv.speed,
                                               bands[tv.lane][1])))
    lo, hi = snap.x - 0.5 * snap.length, snap.x + 0.5 * snap.length
    inside = np.zeros(len(snap), dtype=bool)
    for lane, z_lo, z_hi in zones:
        on = (snap.lane >= 0) if lane < 0 else (snap.lane == lane)
        inside |= on & (hi >= z_lo) & (lo <= z_hi)
    return sorted(vid for vid, hit in zip(snap.ids, inside, strict=True) if hit)


class World:
    """SUMO with the scenario's traffic, as the loop uses it; `wall` is the wall time
    spent in SUMO's steps and reads (s), `wall_read` the reads' part of it."""

    def __init__(self, scenario: Scenario, *, gui: bool | GuiSettings = False,
                 fcd_output: Path | None = None, detector_output: Path | None = None
                 ) -> None:
        sc = scenario
        tr = sc.traffic
        # the route's road (cosim.road): tracks and the (s, d) frame (on the one straight
        # edge the identity StraightFrame); SUMO runs on its route
        # (built once per process and network file: the scenario's loading built it)
        self.route_road = load_route_road(sc.network, sc.route, source=str(sc.path))
        # SUMO's detectors and SSM device, their outputs written into `detector_output`
        # (None: neither)
        self.measures = SumoMeasures(sc, self.route_road, detector_output, SV_ID)
        self.sumo = SumoSim(
            sc.network, sc.step, sc.seed, SumoOptions(
                lanechange_duration=tr.lanechange_duration, sublane=tr.sublane, gui=gui,
                fcd_output=fcd_output,
                route_files=sc.demand.route_files if sc.demand else (),
                additional_files=sc.demand.additional_files if sc.demand else (),
                detectors=self.measures.detector_additional(),
                measures=self.measures.ssm_options()),
            speed_bands=sc.road.speed_bands,  # sumo-gui's pace: cosim.traffic.gui
            route_road=self.route_road,
        )
        self.scenario = sc
        # everything read and written is converted through the route's frame
        # (cosim.traffic.road_view; the identity on the one straight edge)
        self.frame = self.route_road.frame
        self._s_hint: float | None = None  # m, the SV's s at the last read
        # on a route from an on-ramp: the mainline's lanes beside the ramp, whose vehicles
        # are placed by their lane position (road_view.place_upstream; else empty)
        self._upstream = upstream_lanes(self.route_road, self.sumo.lanes.upstream)
        # the SV's start: (track id, s in m) of [sv] edge, lane, position_m
        self.sv_start = sv_start(self.route_road, sc.sv.edge, sc.sv.lane, sc.sv.position)
        self.started = False
        self.wall = 0.0
        self.wall_read = 0.0
        self.t_offset = 0.0  # s, SUMO's clock when the run's t = 0
        self.gap_requests: list[CooperationChannel] = []  # open_gap_requests
        self.cleared: list[str] = []  # the user's vehicles taken off at the SV's entry
        self.t_warmup = 0.0  # s, SUMO's clock at the end of the warm-up (none: 0)
        self.scripted: ScriptedTraffic | None = None  # add_scripted
        self.warmup_progress: WarmupProgress | None = None  # the warm-up's progress
        self.placed: list[str] = []  # the random traffic's vehicles asked for at t = 0
        self.inserted = 0  # of them, those SUMO inserted in the first step (`insert`)

    def start(self) -> RoadParams:
        """Start SUMO and place the random traffic around the SV's start, or run the
        user's own demand for its warm-up (`warm_up`); returns the road (lane width and
        centres from the network, the scenario's bands and mu)."""
        sc = self.scenario
        tr = sc.traffic
        self.started = True  # `close` ends SUMO even if its start is cut short
        self.sumo.start()
        self.measures.started(self.sumo)
        road = sc.road  # lane geometry: the network's, read once by the scenario
        x0 = self.sv_start_x
        track = self.sv_start_track
        traffic = None
        if tr.density > 0:
            from cosim.traffic.demand import populate, start_zone

            margin = SV_LENGTH_MARGIN * sc.vehicle.length
            # in its own lane the SV starts at its scenario speed, often faster than
            # the queue SUMO inserts: keep room to brake (and for its follower)
            zone = start_zone(x0, sc.vehicle.length, sc.sv.speed,
                              road.speed_bands[track][1])
            traffic = populate(self.sumo, road, tr.density, sc.seed, tr.length,
                               exclude_zone=(x0 - margin, x0 + margin),
                               lane_zones={track: zone})
            self.placed = [vid for ids in traffic.placed.values() for vid in ids]
        if tr.ramp_flow > 0:  # on-ramp traffic, its own random stream
            from cosim.traffic.demand import ramp_flow

            ramp_flow(self.sumo, tr.ramp_flow, sc.seed, traffic)
        if sc.demand is not None:
            self.warm_up(sc.demand.warmup, self.warmup_progress)
        self.measures.warmed_up(self.sumo)
        return road

    def warm_up(self, warmup: float, progress: WarmupProgress | None = None) -> list[str]:
        """The user's own demand (cosim.traffic.own_demand) runs alone for `warmup` s
        (whole steps), then its vehicles inside the zones the SV and the scripted TVs start
        in are taken off the road (the zones random traffic leaves free: `start_zone` in
        their own lane, SV_LENGTH_MARGIN SV lengths around the SV in every lane), so no one
        starts overlapping or too close; returns the ids taken off, in order. `progress`
        is told the number of warm-up steps, then each step done."""
        sc = self.scenario
        steps = int(round(warmup / sc.step))
        count = progress(steps) if progress is not None and steps else None
        for _ in range(steps):
            check_signals()  # a signal ends the warm-up between two steps
            self.sumo.step()
            if count is not None:
                count(1)
        self.t_warmup = self.sumo.time
        removed = in_start_zones(self.read_all(), sc, self.sv_start_x, self.sv_start_track)
        for vid in removed:
            self.sumo.remove(vid)
        self.cleared = removed
        return removed

    @property
    def sv_start_x(self) -> float:
        """m, the SV's centre at t = 0 in road coordinates: s of ([sv] edge, [sv] lane,
        [sv] position_m) along the route's road (`route_road`; on the one-edge road
        s = x - the road's start x, on networks/highway.net.xml s = x exactly)."""
        return self.sv_start[1]

    @property
    def sv_start_track(self) -> int:
        """The track of `route_road` the SV starts on (its SV lane: [sv] lane is SUMO's
        index on [sv] edge, which the track keeps across edges)."""
        return self.sv_start[0]

    def insert(self) -> None:
        """The first step: SUMO inserts every vehicle added so far at its place; the
        run's clock starts here."""
        self.sumo.step()
        self.t_offset = self.sumo.time
        self.measures.clock_starts(self.t_offset)
        self.sumo.follow_in_gui(SV_ID)
        if self.placed:  # SUMO leaves out a vehicle with no room at its minimum gap
            on_road = set(self.sumo.api.vehicle.getIDList())
            self.inserted = sum(vid in on_road for vid in self.placed)

    def start_speed(self, speed: float, mu: float) -> float:
        """m/s, the SV's start speed: `speed` or, when its leader in its lane right after
        insertion is SUMO's traffic (random, or the user's own demand: any vehicle but a
        scripted TV), at most the speed from which it can brake for that leader on a road
        of friction `mu` (`demand.safe_start_speed`: SUMO's departSpeed rule). A scripted
        leader's place and speed are the scenario's: kept."""
        from cosim.traffic.demand import RANDOM_ID, safe_start_speed

        vehicle = self.sumo.api.vehicle
        found = vehicle.getLeader(SV_ID, 1000.0)  # gap from the SV's front + its minGap
        if not found or not found[0]:
            return speed
        leader = str(found[0])
        sc = self.scenario
        # SUMO's traffic: cosim's random vehicles, or any of the user's own demand
        theirs = sc.demand is not None and leader not in {tv.id for tv in sc.tvs}
        if not (RANDOM_ID.fullmatch(leader) or theirs):
            return speed
        gap = float(found[1]) + float(vehicle.getMinGap(SV_ID))
        return safe_start_speed(speed, gap, float(vehicle.getSpeed(leader)), mu)

    def read(self, radius: float, *, full: bool = True) -> TrafficSnapshot:
        """Every vehicle within `radius` of the SV (the SV included); without `full` no
        accelerations and signals (only V2V messages need them)."""
        w0 = time.perf_counter()
        snap = self.sumo.snapshot_near(SV_ID, radius, full=full)
        dt = time.perf_counter() - w0
        self.wall += dt
        self.wall_read += dt
        if SV_ID not in snap.ids:  # the SUMO-driven SV reached the road's end
            raise SimulationError(snap.time - self.t_offset,
                                  "the SV is no longer on the network (end of the road?)")
        if is_identity(self.frame):
            return self._run_clock(snap)
        seen = self._view(snap)
        self._s_hint = float(seen.x[seen.index(SV_ID)])
        return self._run_clock(seen)

    def _view(self, snap: TrafficSnapshot) -> TrafficSnapshot:
        """The snapshot in road coordinates (cosim.traffic.road_view)."""
        seen = road_view(snap, self.frame, self._s_hint)
        return place_upstream(seen, self.frame, self.sumo.api, self._upstream, SV_ID)

    def _run_clock(self, snap: TrafficSnapshot) -> TrafficSnapshot:
        """The snapshot timed on the run's clock past the warm-up (SUMO's time minus the
        warm-up: the V2V messages' and the policy's times); as read without one."""
        if not self.t_warmup:
            return snap
        return replace(snap, time=snap.time - self.t_warmup)

    def cartesian(self, s: float, d: float, heading: float) -> tuple[float, float, float, float]:
        """(x, y, heading, q) of a pose in road coordinates (road_view.cartesian_pose)."""
        return cartesian_pose(self.frame, s, d, heading)

    def step(self) -> set[tuple[str, ...]]:
        """SUMO moves its vehicles to the next step; returns SUMO's collisions of that
        step involving the SV (sorted id pairs)."""
        w0 = time.perf_counter()
        self.sumo.step()
        self.wall += time.perf_counter() - w0
        return {tuple(sorted(p)) for p in self.sumo.collisions() if SV_ID in p}

    def events(self) -> list[str]:
        """SUMO's teleports and lost vehicles, one line each, in the run's time."""
        return [f"{e.time - self.t_offset:.2f} s {e.kind} {e.vehicle_id}: {e.detail}"
                for e in self.sumo.events]

    # ------------------------------------------------ vehicles we place and move
    def add_scripted(self, road: RoadParams) -> ScriptedTraffic:
        """The scenario's [[tv]] vehicles as controlled vehicles at their scripts' start
        (cosim.traffic.scripted, on `road`); `move_scripted` moves them each step."""
        from cosim.traffic.scripted import ScriptedTraffic

        sc = self.scenario
        self.scripted = ScriptedTraffic(sc.tvs, road, self.sv_start_x, sc.step, sc.n_steps + 2)
        for tv, (x, y, h, v, _a) in self.scripted.at(0.0):
            spec = tv.spec
            self.add_controlled(spec.id, x, y, h, v, (spec.length, spec.width), spec.lane,
                                vtype="tv_scripted")
        return self.scripted

    def move_scripted(self, t: float) -> None:
        """The scripted TVs to their poses at step time t (they hold from the next step)."""
        if self.scripted is None:
            return
        for tv, (x, y, h, v, a) in self.scripted.at(t):
            self.move(tv.spec.id, x, y, h, v, a)

    def add_controlled(self, vehicle_id: str, x: float, y: float, heading: float,
                       speed: float, size: tuple[float, float], lane: int,
                       vtype: str = "sv") -> None:
        """A vehicle SUMO does not drive (the SV, a scripted TV) at its centre pose in road
        coordinates (s, d, heading to the road, speed along s); `size`: (length, width) m."""
        cx, cy, ch, q = self.cartesian(x, y, heading)
        self.sumo.add_controlled(vehicle_id, cx, cy, ch, speed * q, size, lane, vtype=vtype)

    def move(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
             accel: float | None = None) -> None:
        """A controlled vehicle's centre pose in road coordinates (holds from the next step)."""
        cx, cy, ch, q = self.cartesian(x, y, heading)
        self.sumo.move(vehicle_id, cx, cy, ch, speed * q, None if accel is None else accel * q,
                       road_pose=(x, y, heading))

    def move_xy(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
                accel: float | None = None,
                road_pose: tuple[float, float, float] | None = None) -> None:
        """A controlled vehicle's Cartesian centre pose (the SV's plant; from the next step);
        `road_pose`: the same pose in road coordinates (s, d, heading to the road), if known."""
        self.sumo.move(vehicle_id, x, y, heading, speed, accel, road_pose=road_pose)

    def replay_sv(self, x: list[float], y: list[float], heading: list[float],
                  speed: list[float], accel: list[float],
                  read: tuple[float, bool] | None = None) -> None:
        """The SV moved along a recorded path, pose k before SUMO's step k, nothing
        checked (`cosim bench cosim`'s floor: what SUMO costs with the SV moved); `read`
        (radius in m, full): the scene also read as the loop reads it (`read`) before
        the first step and after each, nothing else (none: nothing read)."""
        sumo = self.sumo
        if read is not None:
            self.read(read[0], full=read[1])
        for k in range(1, len(x)):
            sumo.move(SV_ID, x[k], y[k], heading[k], speed[k], accel[k])
            sumo.step()
            if read is not None:
                self.read(read[0], full=read[1])

    def add_sumo_driven_sv(self, lane: int, speed: float, desired_speed: float,
                           length: float, width: float, *, own_lane_changes: bool) -> None:
        """The SV as a vehicle SUMO drives (controller "sumo") at its start, on the
        centre of track `lane`; `hand_sv_to_sumo` after the inserting step gives it to SUMO."""
        pose = self.sumo.centre_pose(lane, self.sv_start_x)
        self.sumo.add_driven(SV_ID, lane, pose, speed, desired_speed, length, width,
                             own_lane_changes=own_lane_changes)

    def hand_sv_to_sumo(self) -> None:
        """From now on SUMO drives the SV (its own speed and lane-change modes)."""
        self.sumo.controlled.release(SV_ID)

    def sv_lane(self, vehicle_id: str = SV_ID) -> tuple[str, int]:
        """(road id, lane index on it) of the SV (or another vehicle) now as SUMO has it: an
        edge of the route or a junction's internal edge between two of them, and SUMO's own
        per-edge index (not the route's track; ("", -1): off the network)."""
        lane_id = str(self.sumo.api.vehicle.getLaneID(vehicle_id))
        if not lane_id:
            return "", -1
        road, index = lane_id.rsplit("_", 1)  # SUMO's lane ids: <road id>_<index>
        return road, int(index)

    def sv_acceleration(self) -> float:
        """m/s^2, SUMO's longitudinal acceleration of the SV now (not in every read)."""
        return float(self.sumo.api.vehicle.getAcceleration(SV_ID))

    def set_sv_previous_speed(self, speed: float) -> None:
        """The SUMO-driven SV's speed at t = 0 (m/s), as if driven over the insertion step
        at zero acceleration (SUMO would otherwise report the jump as one)."""
        self.sumo.api.vehicle.setPreviousSpeed(SV_ID, float(speed), 0.0)

    def set_sv_blinker(self, direction: int) -> None:
        """The SV's blinker: -1 right, 0 off, +1 left (what V2V and SUMO's drivers see)."""
        self.sumo.set_blinker(SV_ID, direction)

    def change_sv_lane(self, lane: int) -> None:
        """Ask SUMO to move the SUMO-driven SV to `lane` (with SUMO's safety checks)."""
        self.sumo.change_lane(SV_ID, lane, SV_LANE_CHANGE_DURATION)

    def read_all(self) -> TrafficSnapshot:
        """Every vehicle on the network, accelerations and signals included."""
        return self._run_clock(self._view(self.sumo.snapshot()))

    def read_again(self, ids: tuple[str, ...]) -> TrafficSnapshot:
        """These vehicles again, accelerations and signals included."""
        return self._run_clock(self._view(self.sumo.reader.read(ids)))

    # ------------------------------------------------ gap requests (cooperation)
    def open_gap_requests(self) -> None:
        """Open the scenario's gap-request channels (a policy that asks TVs for gaps)."""
        self.gap_requests = cooperation_channels(self.scenario)

    def ask_gap(self, t: float, tv_id: str) -> bool:
        """Ask the TV `tv_id` to open a gap behind the SV, through every open channel;
        whether there is one (a request is sent once per TV and channel)."""
        for channel in self.gap_requests:
            channel.request(t, tv_id)
        return bool(self.gap_requests)

    def deliver_gap_requests(self, t: float, tvs: TrafficSnapshot, sv_x: float,
                             changing: bool) -> None:
        """The step's gap requests: the yielding TVs told when the SV's change begins,
        the requests due reach their TVs, TVs ahead of the SV or standing level with it
        stop yielding (cooperation.done_yielding)."""
        deliver_requests(self.gap_requests, self.sumo.api, SV_ID, t, tvs, sv_x,
                         self.scenario.vehicle.length, changing)

    def close(self) -> None:
        if self.started:
            self.sumo.close()
