"""Every vehicle's state at one time, read from SUMO in one pass (numpy arrays).

`SnapshotReader` holds the reading side of the SUMO adapter (cosim.traffic.sumo):
seven libsumo getters per vehicle (with libsumo, its compiled functions directly:
the Python wrappers around them double the read time), body sizes cached per
vehicle, SUMO's front-bumper positions and navigational degrees turned into body
centres and math radians. Plain and context subscriptions are no faster than these
getters.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from itertools import chain, compress, repeat
from types import ModuleType
from typing import Any

import numpy as np

from cosim.errors import SimulationError

NEAR_REFRESH = 1.0  # s, how often snapshot_near re-selects its candidates
NEAR_MARGIN = 60.0  # m, most two vehicles' x distance can shrink in NEAR_REFRESH
INVALID = -1e9  # m, SUMO reports -1073741824 (INVALID_DOUBLE_VALUE) for vehicles off the network
SIGNAL_BLINKER_RIGHT = 1  # SUMO signal bits
SIGNAL_BLINKER_LEFT = 2
GETTERS = ("getPosition", "getAngle", "getSpeed", "getAcceleration", "getLaneID",
           "getLateralSpeed", "getSignals")  # fmt: skip


def getters(api: ModuleType, names: tuple[str, ...] = GETTERS) -> tuple[Callable[[str], Any], ...]:
    """libsumo's compiled vehicle getters of these names (traci's methods otherwise)."""
    raw = getattr(api, "_libsumo", None)
    if raw is not None and all(hasattr(raw, f"vehicle_{n}") for n in names):
        return tuple(getattr(raw, f"vehicle_{n}") for n in names)
    return tuple(getattr(api.vehicle, n) for n in names)


@dataclass(frozen=True)
class TrafficSnapshot:
    """Every vehicle's state at one time, read in one pass; arrays indexed alike.

    x, y are the CENTRE of the body rectangle (global frame, m); heading in rad.
    """

    time: float  # s
    ids: tuple[str, ...]
    x: np.ndarray  # m, centre
    y: np.ndarray  # m, centre
    heading: np.ndarray  # rad, math convention
    speed: np.ndarray  # m/s, along the lane
    accel: np.ndarray  # m/s^2, longitudinal
    # int, the SV lane the vehicle is on (cosim.traffic.route_lanes: the SV's lane k is track
    # k, a track of the route's first edge, running through or ending on the route; on
    # the one-edge road SUMO's lane index); -1: on none (a road crossing the route on a
    # bridge, another road such as an on-ramp, off the network, a lane added along it)
    lane: np.ndarray
    lateral_speed: np.ndarray  # m/s, + to the left (non-zero while changing lanes)
    length: np.ndarray  # m
    width: np.ndarray  # m
    signals: np.ndarray  # int, SUMO signal bits (1 right blinker, 2 left blinker)
    # seen in road coordinates (cosim.traffic.road_view): the Cartesian centre poses
    # (x, y above are then s, d); None: x, y, heading are the Cartesian ones
    cx: np.ndarray | None = None  # m
    cy: np.ndarray | None = None  # m
    ch: np.ndarray | None = None  # rad

    @property
    def cartesian(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, heading): the Cartesian centre poses, whichever view this is."""
        if self.cx is None or self.cy is None or self.ch is None:
            return self.x, self.y, self.heading
        return self.cx, self.cy, self.ch

    @property
    def intention(self) -> np.ndarray:
        """int, -1 wants/changes right, +1 left, 0 none (from the blinkers)."""
        left = (self.signals & SIGNAL_BLINKER_LEFT) != 0
        right = (self.signals & SIGNAL_BLINKER_RIGHT) != 0
        return left.astype(int) - right.astype(int)

    @property
    def changing(self) -> np.ndarray:
        """bool, the vehicle is moving sideways (a continuous lane change under way)."""
        return np.abs(self.lateral_speed) > 1e-9

    def __len__(self) -> int:
        return len(self.ids)

    def index(self, vehicle_id: str) -> int:
        """Row of a vehicle (ValueError if absent)."""
        return self.ids.index(vehicle_id)

    def select(self, mask: np.ndarray) -> TrafficSnapshot:
        """The rows where `mask` is true (taken by their indices: on a few dozen rows
        half the cost of masking each array, the same arrays)."""
        mask = np.asarray(mask, dtype=bool)
        rows = np.flatnonzero(mask)
        return TrafficSnapshot(
            time=self.time,
            ids=tuple(compress(self.ids, mask.tolist())),
            x=self.x[rows],
            y=self.y[rows],
            heading=self.heading[rows],
            speed=self.speed[rows],
            accel=self.accel[rows],
            lane=self.lane[rows],
            lateral_speed=self.lateral_speed[rows],
            length=self.length[rows],
            width=self.width[rows],
            signals=self.signals[rows],
            cx=None if self.cx is None else self.cx[rows],
            cy=None if self.cy is None else self.cy[rows],
            ch=None if self.ch is None else self.ch[rows],
        )


class SnapshotReader:
    """Reads snapshots from a running SUMO (see the module docstring).

    `dims` (vehicle id -> (length, width), m) is shared with the adapter, which knows
    the sizes of the vehicles it adds; `lateral_speeds()` gives the sideways speeds
    of the vehicles moved by moveToXY (SUMO reports 0 for them); `tracks` maps SUMO's
    lane ids of the route's SV lanes (cosim.traffic.route_lanes.sv_tracks) to their track ids
    (a vehicle's `lane`)."""

    def __init__(self, api: ModuleType, dims: dict[str, tuple[float, float]],
                 lateral_speeds: Callable[[], Mapping[str, float]],
                 tracks: Mapping[str, int]) -> None:
        self.api = api
        self.tracks = tracks
        self.dims = dims
        self.lateral_speeds = lateral_speeds
        self.getters = getters(api)
        self.cached: TrafficSnapshot | None = None  # every vehicle, this step
        self.near_key: tuple[str, float] | None = None  # (centre id, radius) of the candidates
        self.near_next = -math.inf  # s, simulation time of the next candidate refresh
        self.near_candidates: tuple[str, ...] = ()
        # candidates gone since the refresh (arrived); None: not tracked (a teleport or
        # a removal), then each call asks SUMO who is present
        self.near_gone: set[str] | None = None
        # the sizes of the last `read`'s vehicles (ids, length, width, length / 2): the
        # candidates change only at a refresh or an arrival, their sizes never while they
        # are on the network; cleared when a vehicle leaves (an id may come back)
        self._sizes: tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray] | None = None

    def snapshot(self, exclude: Iterable[str] = ()) -> TrafficSnapshot:
        """Every vehicle now (except `exclude`), centre poses, in one pass."""
        if self.cached is None:
            self.cached = self.read(tuple(self.api.vehicle.getIDList()))
        snap = self.cached
        skip = set(exclude)
        if not skip:
            return snap
        return snap.select(np.array([vid not in skip for vid in snap.ids], dtype=bool))

    def snapshot_near(self, center_id: str, radius: float, *, full: bool = True
                      ) -> TrafficSnapshot:
        """Vehicles whose centre is within `radius` m of vehicle `center_id`'s centre
        (itself included): the cost follows the traffic near it, not the whole road's.

        Every NEAR_REFRESH s of simulated time one cheap pass over all positions picks
        the candidates within radius + NEAR_MARGIN along x (no vehicle closes in on
        another by more than NEAR_MARGIN in that time); each call reads the seven
        values of the candidates only (five without `full`: no acceleration, NaN,
        and no signals, 0). (A SUMO context subscription does the same selection but
        costs more inside simulationStep than this whole read.)"""
        api = self.api
        t = float(api.simulation.getTime())
        key = (center_id, float(radius))
        refresh = self.near_key != key or t >= self.near_next - 1e-9
        alive: set[str] | None = None
        gone = self.near_gone
        if not refresh and gone is not None:  # who left is known: no ID list to read
            refresh = center_id in gone
            ids = tuple(vid for vid in self.near_candidates if vid not in gone) if gone \
                else self.near_candidates
        else:
            present = api.vehicle.getIDList()
            alive = set(present)
            refresh = refresh or center_id not in alive
        if refresh:
            if alive is None:
                present = api.vehicle.getIDList()
                alive = set(present)
            get_pos = self.getters[0]
            cx = get_pos(center_id)[0] if center_id in alive else math.nan
            reach = radius + NEAR_MARGIN
            self.near_candidates = tuple(sorted(
                vid for vid in present if abs(get_pos(vid)[0] - cx) <= reach))
            self.near_key = key
            self.near_next = t + NEAR_REFRESH
            self.near_gone = set()
        if alive is not None:
            ids = tuple(vid for vid in self.near_candidates if vid in alive)
        return self.read(ids, t, full=full, near=(center_id, float(radius)))

    def left(self, vehicle_ids: Iterable[str], *, untracked: bool = False) -> None:
        """Vehicles that left the network in the last step (arrived): snapshot_near
        drops them from its candidates without reading SUMO's ID list; `untracked`:
        others may have left too (teleports), see `untracked`."""
        if untracked:
            self.untracked()
        elif vehicle_ids:
            self._sizes = None
            if self.near_gone is not None:
                self.near_gone.update(vehicle_ids)

    def untracked(self) -> None:
        """A vehicle may have left other than by arriving (teleport, removal, a lost
        controlled vehicle): snapshot_near reads the ID list until its next refresh."""
        self.near_gone = None
        self._sizes = None

    def read(self, ids: tuple[str, ...], t: float | None = None, *, full: bool = True,
             near: tuple[str, float] | None = None) -> TrafficSnapshot:
        """The snapshot of the vehicles `ids` (all present now), in that order; `t`:
        SUMO's time if known; without `full` no acceleration (NaN) and no signals (0);
        `near` (id, radius in m): only those whose centre is within radius of that
        vehicle's (none if it is not in `ids`); their other values are read after the
        poses, for them alone."""
        n = len(ids)
        get_pos, get_angle, get_speed, get_accel, get_lane, get_lat, get_signals = self.getters
        pos = np.fromiter(chain.from_iterable(map(get_pos, ids)), float, 2 * n).reshape(n, 2)
        xf, yf = pos[:, 0], pos[:, 1]
        angle = np.fromiter(map(get_angle, ids), float, n)
        length, width, half = self._sizes_of(ids)
        h = np.radians(90.0 - angle)
        h = np.arctan2(np.sin(h), np.cos(h))
        x = xf - half * np.cos(h)
        y = yf - half * np.sin(h)
        if near is not None:
            center_id, radius = near
            if center_id in ids:
                i = ids.index(center_id)
                keep = np.hypot(x - x[i], y - y[i]) <= radius
            else:
                keep = np.zeros(n, dtype=bool)
            ids = tuple(compress(ids, keep.tolist()))
            rows = np.flatnonzero(keep)  # (indices: cheaper than masks on a few dozen)
            xf, x, y, h, length, width = (a[rows] for a in (xf, x, y, h, length, width))
            n = len(ids)
        else:  # the snapshot's own arrays, not the cache's
            length, width = length.copy(), width.copy()
        speed = np.fromiter(map(get_speed, ids), float, n)
        lane = np.fromiter(map(self.tracks.get, map(get_lane, ids), repeat(-1)), int, n)
        lat = np.fromiter(map(get_lat, ids), float, n)
        if full:
            accel = np.fromiter(map(get_accel, ids), float, n)
            signals = np.fromiter(map(get_signals, ids), int, n)
        else:
            accel, signals = np.full(n, np.nan), np.zeros(n, dtype=int)
        lane[xf < INVALID] = -1
        # SUMO reports no sideways speed of a moved vehicle: dy/dt of its poses
        for vid, speed_y in self.lateral_speeds().items():
            if vid in ids:
                lat[ids.index(vid)] = speed_y
        return TrafficSnapshot(
            time=float(self.api.simulation.getTime()) if t is None else t,
            ids=ids,
            x=x,
            y=y,
            heading=h,
            speed=speed,
            accel=accel,
            lane=lane,
            lateral_speed=lat,
            length=length,
            width=width,
            signals=signals,
        )

    # ------------------------------------------------------------------ one vehicle
    def pose(self, vehicle_id: str) -> tuple[float, float, float]:
        """(x, y, heading) of a vehicle's centre as SUMO has it now (m, m, rad)."""
        vehicle = self.api.vehicle
        xf, yf = vehicle.getPosition(vehicle_id)
        if xf < INVALID:
            t = float(self.api.simulation.getTime())
            raise SimulationError(t, f"{vehicle_id} is not on the network")
        h = heading_from_angle(vehicle.getAngle(vehicle_id))
        length = self._length(vehicle_id)
        x, y = centre_from_front(xf, yf, h, length)
        return x, y, h

    def speed(self, vehicle_id: str) -> float:
        """m/s, SUMO's speed of a vehicle."""
        return float(self.api.vehicle.getSpeed(vehicle_id))

    def leader(self, vehicle_id: str, distance: float = 200.0) -> tuple[str, float] | None:
        """(id, gap in m bumper to bumper) of the leader in the vehicle's lane, or None."""
        vehicle = self.api.vehicle
        found = vehicle.getLeader(vehicle_id, distance)
        if not found or not found[0]:
            return None
        # SUMO measures from the follower's front + its minGap: add the minGap back
        return str(found[0]), float(found[1]) + float(vehicle.getMinGap(vehicle_id))

    def _length(self, vehicle_id: str) -> float:
        return (self.dims.get(vehicle_id) or self._read_dims(vehicle_id))[0]

    def lane_position(self, vehicle_id: str) -> float:
        """m, distance of the vehicle's front bumper from the start of the road."""
        return float(self.api.vehicle.getLanePosition(vehicle_id))

    def vehicle_ids(self) -> tuple[str, ...]:
        """Every vehicle on the network now."""
        return tuple(self.api.vehicle.getIDList())

    def pending(self) -> tuple[str, ...]:
        """Vehicles added but not yet inserted (no room at their position yet)."""
        return tuple(self.api.simulation.getPendingVehicles())

    def _sizes_of(self, ids: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """m, the vehicles' lengths, widths and half lengths, the last call's arrays when
        the vehicles are the same (never modified: `read` hands out copies)."""
        cached = self._sizes
        if cached is None or cached[0] != ids:
            dims = self.dims
            sizes = np.fromiter(chain.from_iterable(dims.get(vid) or self._read_dims(vid)
                                                    for vid in ids), float, 2 * len(ids))
            sizes = sizes.reshape(len(ids), 2)
            length, width = sizes[:, 0].copy(), sizes[:, 1].copy()
            cached = self._sizes = (ids, length, width, 0.5 * length)
        return cached[1], cached[2], cached[3]

    def _read_dims(self, vehicle_id: str) -> tuple[float, float]:
        vehicle = self.api.vehicle
        dims = (float(vehicle.getLength(vehicle_id)), float(vehicle.getWidth(vehicle_id)))
        self.dims[vehicle_id] = dims
        return dims


def heading_from_angle(angle: float) -> float:
    """Math heading in radians, in (-pi, pi], of SUMO navigational degrees."""
    h = math.radians(90.0 - angle)
    return math.atan2(math.sin(h), math.cos(h))


def centre_from_front(xf: float, yf: float, heading: float, length: float) -> tuple[float, float]:
    """m, the body centre of a vehicle whose front-bumper centre SUMO reports."""
    half = 0.5 * length
    return xf - half * math.cos(heading), yf - half * math.sin(heading)
