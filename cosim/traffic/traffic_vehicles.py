"""Traffic vehicles (TVs): inserted where asked, each keeping the speed band of the lane
it is in (cosim.traffic.sumo's traffic part).

Traffic vehicles keep the lane speed bands (Section 5): each TV has a place in [0, 1]
within a band, and whenever its lane changes its desired speed (maxSpeed; speedFactor
1) is set to that place in the new lane's band. SUMO's lane-change model decides the
changes; `--lanechange.duration` makes them continuous (constant lateral speed), the
sublane model is the alternative.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from cosim.errors import InputError
from cosim.traffic.route import ROUTE_ID

TV_TYPE = "tv"
TV_LENGTH = 4.32  # m, traffic vehicles are the Table 1 car (assumption S3: all alike)
TV_WIDTH = 1.8  # m
TV_SIGMA = 0.2  # -, Krauss driver imperfection of traffic vehicles


class TrafficVehicles:
    """The TVs of a simulation: inserted at a place in a lane with a place in its speed
    band, their desired speeds kept to the band of the lane they are in."""

    def __init__(self, sim: Any, bands: SpeedBands) -> None:  # sim: the SumoSim
        self.sim = sim
        self.bands = bands

    def add(self, vehicle_id: str, lane: int, x: float, quantile: float,
            speed: float | None = None) -> None:
        """Insert a TV with its centre at global x in `lane`, desired speed from the band.

        It is inserted in the next step at `speed` (default: its desired speed),
        reduced by SUMO if that is unsafe behind its leader.
        """
        sim = self.sim
        highway = sim.highway
        if not 0 <= lane < highway.n_lanes:
            raise InputError("traffic", "lane", lane, f"0 .. {highway.n_lanes - 1}")
        desired = self.bands.speed(lane, quantile)
        front = x - highway.x_start + 0.5 * TV_LENGTH
        api = sim.api
        api.vehicle.add(
            vehicle_id,
            ROUTE_ID,
            typeID=TV_TYPE,
            departLane=str(lane),
            departPos=repr(float(front)),
            departSpeed="max" if speed is None else repr(float(min(speed, desired))),
        )
        api.vehicle.setMaxSpeed(vehicle_id, desired)
        self.bands.add(vehicle_id, lane, quantile)
        sim.dims[vehicle_id] = (TV_LENGTH, TV_WIDTH)


class SpeedBands:
    """Each TV's desired speed from the speed band of the lane it is in (Section 5):
    a place in [0, 1] within a band per TV, applied whenever its lane changes.

    A lane change is seen as a TV new in a lane's vehicle list (three lists a step,
    not one lane-index read per TV: the same lanes, measured ~10x cheaper)."""

    def __init__(self, bands: tuple[tuple[float, float], ...], lane_ids: tuple[str, ...]) -> None:
        self.bands = bands
        self.lane_ids = lane_ids
        self.quantile: dict[str, float] = {}  # TV id -> its place in a speed band
        self.lane: dict[str, int] = {}  # TV id -> lane its desired speed was set for
        self.seen: list[set[str]] = [set() for _ in lane_ids]  # each lane's vehicles last step
        self.seen_ids: list[Any] = [None for _ in lane_ids]  # the lists as SUMO gave them

    def speed(self, lane: int, quantile: float) -> float:
        """m/s, the desired speed at `quantile` in [0, 1] of a lane's speed band."""
        lo, hi = self.bands[lane]
        return lo + quantile * (hi - lo)

    def add(self, vehicle_id: str, lane: int, quantile: float) -> None:
        self.quantile[vehicle_id] = float(quantile)
        self.lane[vehicle_id] = lane

    def forget(self, vehicle_id: str) -> None:
        self.quantile.pop(vehicle_id, None)
        self.lane.pop(vehicle_id, None)

    def keep(self, api: ModuleType) -> None:
        """After a step: a TV whose lane changed gets its new lane's band."""
        if not self.lane:
            return
        on_lane = getattr(getattr(api, "_libsumo", None), "lane_getLastStepVehicleIDs", None) \
            or api.lane.getLastStepVehicleIDs
        set_max_speed = api.vehicle.setMaxSpeed
        was = self.lane
        for lane, lane_id in enumerate(self.lane_ids):
            ids = on_lane(lane_id)
            if ids == self.seen_ids[lane]:  # most steps: nobody came or went
                continue
            now = set(ids)
            for vid in sorted(now - self.seen[lane]):  # a fixed order of SUMO calls
                if was.get(vid, lane) != lane:
                    set_max_speed(vid, self.speed(lane, self.quantile[vid]))
                    was[vid] = lane
            self.seen[lane], self.seen_ids[lane] = now, ids
