"""The vehicles SUMO does not drive (the SV, scripted TVs) and the SUMO-driven SV until
it is handed to SUMO (cosim.traffic.sumo's controlled part).

Conventions at this boundary (SUMO_NOTES.md): SUMO positions are the centre of the
front bumper and angles are navigational degrees (0 north, clockwise). cosim uses the
centre of the body rectangle (= the CG, the body is centred on it) and math radians.
So, with L the body length,

    front = centre + L/2 (cos h, sin h),   angle = (90 - degrees(h)) mod 360.

Controlled vehicles leave SUMO's control (speed mode 0, lane-change mode 0), are added
on the route's road (cosim.traffic.route_lanes) and written with `vehicle.moveToXY(...,
keepRoute=2)` with the edge and lane index of the track their front is in as the hint;
one that SUMO takes off the network (it drops it silently) is caught after the step
(`check`). One that moveToXY put on a new lane across the line is inserted afresh once
its body is inside that lane (`ControlledVehicles._reseat`: else SUMO keeps the shadow
lane it gave it in the lane it came from).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from cosim.errors import InputError, SimulationError
from cosim.road.tracks import TrackPiece
from cosim.traffic.snapshot import SIGNAL_BLINKER_LEFT, SIGNAL_BLINKER_RIGHT


def sumo_angle(heading: float) -> float:
    """SUMO navigational degrees (0 north, clockwise) of a math heading in radians."""
    return (90.0 - math.degrees(heading)) % 360.0


def front_from_centre(x: float, y: float, heading: float, length: float) -> tuple[float, float]:
    """m, the front-bumper centre SUMO uses, of a body rectangle centred on (x, y)."""
    half = 0.5 * length
    return x + half * math.cos(heading), y + half * math.sin(heading)


@dataclass(frozen=True)
class TrafficEvent:
    """Something SUMO did that a run must record: a teleport, a vehicle lost."""

    time: float  # s, simulation time
    kind: str  # "teleport" | "lost" (a controlled vehicle SUMO dropped)
    vehicle_id: str
    detail: str


CONTROLLED_MAX_SPEED = 70.0  # m/s, a controlled vehicle's cap (SUMO warns above it)


@dataclass
class _Controlled:
    length: float  # m
    width: float  # m
    last: tuple[float, float, float]  # m, m, rad: the last centre pose written
    inserted: bool = False  # SUMO has it on the network (it inserts it in the next step)
    t_write: float = -1.0  # s, simulation time of the last write
    y_before: float | None = None  # m, centre d (y) written in the step before that
    lateral_speed: float = 0.0  # m/s, dd/dt of the written poses (SUMO reports 0 for them)
    d_last: float = math.nan  # m, the centre's d (y on the straight road) last written
    signals: int = -1  # SUMO signal bits to hold (-1: leave them to SUMO)
    s_front: float = math.nan  # m, s of its front last written (where to look first)
    hint: TrackPiece | None = None  # the SUMO lane of the track its front was in
    # (s_lo, s_hi, d_lo, d_hi) m: where the front may go with `hint` unchanged
    # (RouteLanes.hint_box; NaN: look again)
    hint_box: tuple[float, float, float, float] = (math.nan, math.nan, math.nan, math.nan)
    own_max_speed: float = math.nan  # m/s, a vehicle taken over: its maximum speed in SUMO
    # before (given back with it)
    reseat: bool = False  # SUMO put it on a new lane straddling the line (see `_reseat`)


RESEAT_MARGIN = 0.05  # m, clearance of the lane lines before a vehicle is reseated: SUMO
# sees no overlap of the old lane then (it allows POSITION_EPS, 0.1 mm)
MOVE_NORMAL = 2  # SUMO's vehicle.moveTo reason: a move along the road (no teleport)
SUMO_LANE_CHANGE_MODE = 1621  # SUMO's default lane-change mode (its own strategic changes)


class ControlledVehicles:
    """The vehicles SUMO does not drive (the SV, scripted TVs): added at a centre pose,
    moved with moveToXY each step, their blinkers held, and caught when SUMO drops
    one off the network."""

    def __init__(self, sim: Any) -> None:  # sim: the SumoSim (it imports this module)
        self.sim = sim
        self.vehicles: dict[str, _Controlled] = {}
        self.moved = False  # a moveToXY is pending (must be flushed before close)
        self.release_modes: dict[str, tuple[float, int]] = {}  # add_driven: (desired m/s, lc mode)

    def add(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
            size: tuple[float, float], track: int, type_id: str) -> None:
        """Insert it (in the next step) with speed mode 0 and lane-change mode 0 (out of
        SUMO's control), at its centre pose, of `size` (length, width) m, on `track` (a
        track id of the route: an SV lane k is track k) and on the rest of the route from
        the edge its front is on."""
        length, width = size
        sim = self.sim
        api = sim.api
        lanes = sim.lanes
        s, _ = lanes.route_road.frame.to_frenet(x, y)
        place = lanes.place(track, s + 0.5 * length)
        front = place.position
        if place.route_index == 0:  # its whole body on the route
            front = max(front, length)
        piece = lanes.table(track).track.piece_on(place.edge)
        where = {"typeID": type_id, "departLane": str(place.index),
                 "departPos": repr(float(min(front, piece.length)))}
        route_id = lanes.route_id(api, place.route_index)
        try:
            api.vehicle.add(vehicle_id, route_id, departSpeed=repr(float(max(speed, 0.0))),
                            **where)
        except api.TraCIException:
            # SUMO inserts no vehicle faster than its departure lane's limit beyond its
            # own tolerance, which the scenario's rounding allowance (a limit written as
            # 19.44 m/s, 70 km/h) can exceed: inserted at the limit, its speed set below
            if speed <= piece.speed:
                raise
            api.vehicle.add(vehicle_id, route_id, departSpeed=repr(float(piece.speed)),
                            **where)
        api.vehicle.setSpeedMode(vehicle_id, 0)
        api.vehicle.setLaneChangeMode(vehicle_id, 0)
        self.vehicles[vehicle_id] = _Controlled(length, width, (x, y, heading))
        self.move(vehicle_id, x, y, heading, speed)

    def take(self, vehicle_id: str, x: float, y: float, heading: float,
             size: tuple[float, float]) -> None:
        """Take a vehicle SUMO drives out of its control (an automated vehicle of the fleet,
        at its Cartesian centre pose now, of `size` (length, width) m): speed mode 0 and
        lane-change mode 0, moved by `move` from now on."""
        vehicle = self.sim.api.vehicle
        vehicle.setSpeedMode(vehicle_id, 0)
        vehicle.setLaneChangeMode(vehicle_id, 0)
        # SUMO holds a vehicle's speed (setPreviousSpeed) to its maximum speed, its lane's
        # band for one SUMO drove: above it the others, SUMO's drivers and V2V, would see
        # it at that speed with a wild acceleration; a controlled vehicle's cap instead
        own = vehicle.getMaxSpeed(vehicle_id)
        vehicle.setMaxSpeed(vehicle_id, CONTROLLED_MAX_SPEED)
        length, width = size
        self.vehicles[vehicle_id] = _Controlled(length, width, (x, y, heading), inserted=True,
                                                own_max_speed=own)

    def hand_back(self, vehicle_id: str) -> None:
        """Give a vehicle taken by `take` back to SUMO: its default speed mode (all
        safety checks) and lane-change mode."""
        vehicle = self.sim.api.vehicle
        vehicle.setSpeedMode(vehicle_id, 31)
        vehicle.setLaneChangeMode(vehicle_id, SUMO_LANE_CHANGE_MODE)
        ctl = self.vehicles.pop(vehicle_id, None)
        if ctl is not None and math.isfinite(ctl.own_max_speed):
            vehicle.setMaxSpeed(vehicle_id, ctl.own_max_speed)

    def move(
        self,
        vehicle_id: str,
        x: float,
        y: float,
        heading: float,
        speed: float,
        accel: float | None = None, road_pose: tuple[float, float, float] | None = None,
    ) -> None:
        """Write a controlled vehicle's centre pose (takes effect in the next step).

        Also sets its speed (and acceleration), so the TVs that react to it in
        the next step see the plant's speed, not last step's displacement. `road_pose`: the
        same pose's (s, d, heading to the road), when the caller has it (its lateral
        speed is dd/dt, and the front's place along the road for the hint needs no
        search); else it is found from the Cartesian pose.
        """
        ctl = self.vehicles.get(vehicle_id)
        if ctl is None:
            raise SimulationError(self.sim.time, f"{vehicle_id} is not a controlled vehicle")
        xf, yf = front_from_centre(x, y, heading, ctl.length)
        lanes = self.sim.lanes
        if road_pose is not None:
            s_c, d_c, rel = road_pose
            half = 0.5 * ctl.length
            s_f, d_f = s_c + half * math.cos(rel), d_c + half * math.sin(rel)
        else:
            s_f, d_f = lanes.route_road.frame.to_frenet(xf, yf, s_hint=ctl.s_front)
            d_c = y if lanes.straight else d_f  # (the front's d: near enough for dd/dt)
        if math.isfinite(s_f):  # NaN: no arc's normals reach it; keep the last hint
            box = ctl.hint_box
            if not (box[0] < s_f < box[1] and box[2] <= d_f < box[3]):
                before = ctl.hint
                ctl.hint, ctl.hint_box = lanes.hint_box(s_f, d_f)
                if ctl.hint is not None and before is not None and ctl.hint.lane != before.lane:
                    ctl.reseat = not self._inside(ctl, d_c)
            ctl.s_front = s_f
        vehicle = self.sim.api.vehicle
        # inside both where SUMO has it in this step and where it is written (at its end)
        if (ctl.reseat and ctl.hint is not None and ctl.inserted
                and self._inside(ctl, ctl.d_last) and self._inside(ctl, d_c)):
            self._reseat(vehicle_id, ctl.hint)
            ctl.reseat = False
        # the edge and lane of the track its front is in: keepRoute 2 then keeps it on its
        # route, in that lane, across junctions (where SUMO's lane index may change)
        edge, index = ("", -1) if ctl.hint is None else (ctl.hint.edge, ctl.hint.index)
        vehicle.moveToXY(vehicle_id, edge, index, xf, yf, sumo_angle(heading), keepRoute=2)
        if ctl.inserted:
            if accel is None:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0))
            else:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0), float(accel))
        t = self.sim.time
        if t > ctl.t_write:  # a new step: the previous write becomes the reference
            ctl.y_before, t_before = ctl.d_last, ctl.t_write
            ctl.lateral_speed = 0.0 if t_before < 0 else (d_c - ctl.y_before) / (t - t_before)
        elif ctl.y_before is not None:  # written twice in one step: the latest counts
            ctl.lateral_speed = (d_c - ctl.y_before) / self.sim.step_length
        ctl.t_write = t
        ctl.last = (float(x), float(y), float(heading))
        ctl.d_last = float(d_c)
        if ctl.signals >= 0:  # SUMO resets the signals of a moved vehicle: hold them
            vehicle.setSignals(vehicle_id, ctl.signals)
        self.moved = True

    @staticmethod
    def _inside(ctl: _Controlled, d_c: float) -> bool:
        """Its body (centre d `d_c`) lies in the lane of its hint, clear of both lines."""
        _, _, d_lo, d_hi = ctl.hint_box  # NaN (cannot tell): False
        half = 0.5 * ctl.width + RESEAT_MARGIN
        return d_lo <= d_c - half and d_c + half <= d_hi

    def _reseat(self, vehicle_id: str, hint: TrackPiece) -> None:
        """Insert it afresh on the lane of `hint` (its body inside it), without a shadow lane.

        SUMO gives a vehicle that moveToXY puts on a new lane across the line a shadow
        lane (its partial occupation of the lane it came from) and never recomputes it
        while moveToXY moves it within that lane: SUMO's drivers in the old lane take it
        for a leader overlapping them and brake at their emergency deceleration while it
        passes. Only an insertion recomputes it, and SUMO inserts afresh only a vehicle
        moved to another lane (`vehicle.moveTo` to its own lane just sets its position):
        so it is moved to another lane of the edge and straight back, both now, before
        the step. No step runs in between: no driver, collision check or detector sees
        it on the other lane (moveToXY's own moves take effect at the step's end,
        MSVehicle::Influencer::postProcessRemoteControl), and SUMO's move reason
        "normal" (2) counts no detector entry at the insertions. The moveToXY that
        follows moves it within the lane, onto the written pose."""
        if hint.internal:
            return
        api = self.sim.api
        n_lanes = api.edge.getLaneNumber(hint.edge)
        if n_lanes < 2:  # no lane beside it: no shadow either
            return
        other = hint.index + 1 if hint.index + 1 < n_lanes else hint.index - 1
        position = api.vehicle.getLanePosition(vehicle_id)
        other_lane = f"{hint.edge}_{other}"
        api.vehicle.moveTo(vehicle_id, other_lane,
                           min(position, api.lane.getLength(other_lane)), MOVE_NORMAL)
        api.vehicle.moveTo(vehicle_id, hint.lane, position, MOVE_NORMAL)

    def set_blinker(self, vehicle_id: str, direction: int) -> None:
        """Blinker of a controlled vehicle: -1 right, +1 left, 0 off (what V2V reads)."""
        bits = {-1: SIGNAL_BLINKER_RIGHT, 0: 0, 1: SIGNAL_BLINKER_LEFT}.get(direction)
        if bits is None:
            raise InputError("blinker", "direction", direction, "-1, 0 or +1")
        ctl = self.vehicles.get(vehicle_id)
        if ctl is None:
            raise SimulationError(self.sim.time, f"{vehicle_id} is not a controlled vehicle")
        ctl.signals = bits
        self.sim.api.vehicle.setSignals(vehicle_id, bits)

    def check(self, t: float, teleported: set[str]) -> None:
        """A moveToXY vehicle off the network is dropped silently by SUMO: catch it."""
        if not self.vehicles:
            return
        vehicle = self.sim.api.vehicle
        present = set(vehicle.getIDList()) if len(self.vehicles) > 1 else None
        for vid, ctl in list(self.vehicles.items()):
            try:
                on_road = (present is None or vid in present) and vehicle.getLaneID(vid) != ""
            except self.sim.api.TraCIException:  # an unknown vehicle id
                on_road = False
            if on_road:
                ctl.inserted = True
                continue
            x, y, h = ctl.last
            detail = f"{vid} left the network at x = {x:.2f} m, y = {y:.2f} m"
            if vid in teleported:
                detail += " (SUMO teleported it: a jam with --time-to-teleport set)"
            self.sim.events.append(TrafficEvent(t, "lost", vid, detail))
            self.sim.reader.untracked()
            del self.vehicles[vid]
            if self.sim.strict:
                raise SimulationError(t, detail, f"heading {h:.4f} rad")

    def release(self, vehicle_id: str) -> None:
        """Hand a vehicle placed by `add_driven` to SUMO (call after it is inserted):
        SUMO's speed and lane-change models from now on."""
        desired, lc_mode = self.release_modes.pop(vehicle_id)
        vehicle = self.sim.api.vehicle
        vehicle.setSpeedMode(vehicle_id, 31)  # SUMO's default: all safety checks
        vehicle.setLaneChangeMode(vehicle_id, lc_mode)
        vehicle.setMaxSpeed(vehicle_id, desired)
        self.vehicles.pop(vehicle_id, None)
        self.sim.kept.add(vehicle_id)  # SUMO may never teleport or remove it (SumoSim.step)

    def lateral_speeds(self) -> dict[str, float]:
        """m/s, dy/dt of the poses written to each controlled vehicle."""
        return {vid: ctl.lateral_speed for vid, ctl in self.vehicles.items()}
