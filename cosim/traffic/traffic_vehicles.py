"""Traffic vehicles (TVs): inserted where asked, each keeping the speed band of the lane
it is on (cosim.traffic.sumo's traffic part).

Traffic vehicles keep the lane speed bands (Section 5): each TV has a place in [0, 1]
within a band, and whenever its track (cosim.road.tracks) changes its desired speed
(maxSpeed; speedFactor 1) is set to that place in the new track's band. SUMO's
lane-change model decides the changes; `--lanechange.duration` makes them continuous
(constant lateral speed), the sublane model is the alternative.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from cosim.errors import InputError

TV_TYPE = "tv"
TV_LENGTH = 4.32  # m, traffic vehicles are the Table 1 car (assumption S3: all alike)
TV_WIDTH = 1.8  # m
TV_SIGMA = 0.2  # -, Krauss driver imperfection of traffic vehicles


class TrafficVehicles:
    """The TVs of a simulation: inserted at a place on a track with a place in its speed
    band, their desired speeds kept to the band of the track they are on."""

    def __init__(self, sim: Any, bands: SpeedBands) -> None:  # sim: the SumoSim
        self.sim = sim
        self.bands = bands

    def add(self, vehicle_id: str, track: int, s: float, quantile: float,
            speed: float | None = None) -> None:
        """Insert a TV with its centre at arc length `s` (m) on `track`, desired speed
        from the track's band; it departs on the rest of the route from the edge its
        front is on (a junction's internal lane: the next edge), or, before the track's
        start (s < its begin), on the lane that feeds it from before the route
        (RouteLanes.upstream_place), where there is one.

        It is inserted in the next step at `speed` (default: its desired speed),
        reduced by SUMO if that is unsafe behind its leader.
        """
        sim = self.sim
        lanes = sim.lanes
        front = s + 0.5 * TV_LENGTH
        place = lanes.upstream_place(track, front) or lanes.place(track, front)
        desired = self.bands.speed(track, quantile)
        api = sim.api
        api.vehicle.add(
            vehicle_id,
            lanes.route_id_of(api, place),
            typeID=TV_TYPE,
            departLane=str(place.index),
            departPos=repr(float(place.position)),
            departSpeed="max" if speed is None else repr(float(min(speed, desired))),
        )
        api.vehicle.setMaxSpeed(vehicle_id, desired)
        self.bands.add(vehicle_id, track, quantile)
        sim.dims[vehicle_id] = (TV_LENGTH, TV_WIDTH)


class SpeedBands:
    """Each TV's desired speed from the speed band of the track it is on (Section 5): a
    place in [0, 1] within a band per TV, applied whenever its track changes (SUMO's lane
    index of one track may change along the route: the band follows the track, not the
    index). A track that is not a through track has its neighbour's band
    (cosim.traffic.route_lanes).

    A track change is seen as a TV new in a lane's vehicle list (one list per lane of
    the route's edges a step, not one lane read per TV: on the one-edge road three lists,
    about 10x cheaper)."""

    def __init__(self, bands: tuple[tuple[float, float], ...],
                 lanes: tuple[tuple[str, int], ...], band_index: dict[int, int]) -> None:
        self.bands = bands
        self.lane_ids = tuple(lane for lane, _ in lanes)  # SUMO lane ids, route edges only
        self.lane_track = tuple(track for _, track in lanes)  # the track of each
        self.band_index = band_index  # track id -> its band
        self.quantile: dict[str, float] = {}  # TV id -> its place in a speed band
        self.track: dict[str, int] = {}  # TV id -> track its desired speed was set for
        self.seen: list[set[str]] = [set() for _ in lanes]  # each lane's vehicles last step
        self.seen_ids: list[Any] = [None for _ in lanes]  # the lists as SUMO gave them

    def speed(self, track: int, quantile: float) -> float:
        """m/s, the desired speed at `quantile` in [0, 1] of a track's speed band."""
        if track not in self.band_index:
            raise InputError("traffic", "track", track,
                             f"a track of the route {sorted(self.band_index)}")
        lo, hi = self.bands[self.band_index[track]]
        return lo + quantile * (hi - lo)

    def add(self, vehicle_id: str, track: int, quantile: float) -> None:
        self.quantile[vehicle_id] = float(quantile)
        self.track[vehicle_id] = track

    def forget(self, vehicle_id: str) -> None:
        self.quantile.pop(vehicle_id, None)
        self.track.pop(vehicle_id, None)

    def keep(self, api: ModuleType) -> None:
        """After a step: a TV whose track changed gets its new track's band."""
        if not self.track:
            return
        on_lane = getattr(getattr(api, "_libsumo", None), "lane_getLastStepVehicleIDs", None) \
            or api.lane.getLastStepVehicleIDs
        set_max_speed = api.vehicle.setMaxSpeed
        was = self.track
        for i, lane_id in enumerate(self.lane_ids):
            ids = on_lane(lane_id)
            if ids == self.seen_ids[i]:  # most steps: nobody came or went
                continue
            now = set(ids)
            track = self.lane_track[i]
            for vid in sorted(now - self.seen[i]):  # a fixed order of SUMO calls
                if was.get(vid, track) != track:
                    set_max_speed(vid, self.speed(track, self.quantile[vid]))
                    was[vid] = track
            self.seen[i], self.seen_ids[i] = now, ids
