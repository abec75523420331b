"""SUMO's floating-car data (fcd.xml, `cosim run --fcd`) on the route: every vehicle's
record on an SV lane as (time, vehicle, track, s, speed) arrays, the time-space
diagram's data (cosim.plots.time_space).

A record's s is where SUMO's lane position (the vehicle's front bumper) lies along the
route: per SUMO lane of a track, s sampled along the lane (route_lanes.lane_samples) and
interpolated (on the straight road exactly linear). Records on lanes no SV lane's
track runs through (an on-ramp, a lane added along the route) are left out.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cosim.road.road import Road
from cosim.traffic.route_lanes import lane_samples, sv_tracks

Array = NDArray[np.float64]


@dataclass(frozen=True)
class RouteRecords:
    """FCD records on the SV lanes, arrays indexed alike (by time, then SUMO's order)."""

    t: Array  # s, on the run's clock
    vehicle: NDArray[np.int64]  # index into `ids`
    track: NDArray[np.int64]  # the SV lane (track) the record's lane belongs to
    s: Array  # m, along the route (the front bumper)
    speed: Array  # m/s
    ids: tuple[str, ...]  # vehicle ids

    def of(self, vehicle_id: str) -> NDArray[np.bool_]:
        """The records of one vehicle (none if it never was on an SV lane)."""
        if vehicle_id not in self.ids:
            return np.zeros(len(self.t), dtype=bool)
        return self.vehicle == self.ids.index(vehicle_id)


def _lane_maps(route_road: Road) -> dict[str, tuple[int, Array, Array]]:
    """SUMO lane id -> (track, lane positions, their s) for every lane of an SV lane."""
    maps = {}
    for table in sv_tracks(route_road):
        for k, piece in enumerate(table.track.pieces):
            s, positions = lane_samples(route_road, table.id, k)
            maps[piece.lane] = (table.id, positions, s)
    return maps


def read_route_records(path: Path, route_road: Road, t0: float = 0.0,
                       every: float = 0.0) -> RouteRecords:
    """The records of fcd.xml at `path` on the SV lanes of `route_road`, times on the run's
    clock (SUMO's minus `t0`); `every` > 0 keeps only the time steps on that grid (s)."""
    maps = _lane_maps(route_road)
    t: list[float] = []
    lanes: list[str] = []
    vids: list[int] = []
    pos: list[float] = []
    speed: list[float] = []
    index: dict[str, int] = {}
    keep = True
    for event, node in ET.iterparse(path, events=("start", "end")):
        if node.tag == "timestep":
            if event == "start":
                now = float(node.attrib["time"])
                keep = every <= 0.0 or abs(now / every - round(now / every)) < 1e-6
            else:
                node.clear()
            continue
        if event != "end" or node.tag != "vehicle" or not keep:
            continue
        lane = node.attrib.get("lane")
        if lane in maps:
            t.append(now - t0)
            lanes.append(lane)
            vids.append(index.setdefault(node.attrib["id"], len(index)))
            pos.append(float(node.attrib["pos"]))
            speed.append(float(node.attrib["speed"]))
    lane_arr = np.array(lanes, dtype=object)
    pos_arr = np.array(pos, dtype=float)
    s = np.empty(len(pos_arr))
    track = np.empty(len(pos_arr), dtype=np.int64)
    for lane in set(lanes):
        on = lane_arr == lane
        k, p, ss = maps[lane]
        s[on] = np.interp(pos_arr[on], p, ss)
        track[on] = k
    return RouteRecords(np.array(t, dtype=float), np.array(vids, dtype=np.int64), track, s,
                        np.array(speed, dtype=float), tuple(index))
