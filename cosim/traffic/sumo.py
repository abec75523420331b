"""The SUMO adapter: the only module that imports libsumo / traci.

`SumoSim` starts SUMO on the highway network, steps it, reads every traffic
vehicle (TV) in one pass into a `TrafficSnapshot`, and lets the co-simulation
drive vehicles it controls itself (the SV and scripted TVs) with
`vehicle.moveToXY(..., keepRoute=2)`.

Conventions at this boundary (SUMO_NOTES.md): SUMO positions are the centre of
the front bumper and angles are navigational degrees (0 north, clockwise). cosim
uses the centre of the body rectangle (= the CG, the body is centred on it) and
math radians. So, with L the body length,

    front = centre + L/2 (cos h, sin h),   angle = (90 - degrees(h)) mod 360.

SUMO is started with `--collision.action warn --collision.mingap-factor 0` (the
default teleport action silently ignores collisions of moved vehicles; a
collision is then a real overlap, not a gap below minGap), `--time-to-teleport
-1` (no jam teleports: every vehicle stays visible to the SV) and
`--no-warnings` with an `--error-log` file: warnings are captured, readable
through `SumoSim.warnings()`, and not printed.

Traffic vehicles keep the lane speed bands (Section 5): each TV has a place in
[0, 1] within a band, and whenever its lane index changes its desired speed
(maxSpeed; speedFactor 1) is set to that place in the new lane's band. SUMO's
lane-change model decides the changes; `--lanechange.duration` makes them
continuous (constant lateral speed), the sublane model is the alternative.

Controlled vehicles (SV, scripted TVs) leave SUMO's control (speed mode 0,
lane-change mode 0); a pending moveToXY is flushed by one step before close
(it would leak into the next simulation in the process), and one that takes a
vehicle off the network (SUMO drops it silently) raises SimulationError.

One libsumo simulation per process: a second start silently replaces the first,
so `start` refuses while another SumoSim is running.
"""

from __future__ import annotations

import contextlib
import math
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

import numpy as np

from cosim.errors import InputError, SimulationError
from cosim.params import RoadParams
from cosim.traffic import gui as gui_window
from cosim.traffic.gui import GuiSettings
from cosim.traffic.network import Highway, load_highway

ROUTE_ID = "highway_route"
TV_TYPE = "tv"
NEAR_REFRESH = 1.0  # s, how often snapshot_near re-selects its candidates
NEAR_MARGIN = 60.0  # m, most two vehicles' x distance can shrink in NEAR_REFRESH
INVALID = -1e9  # m, SUMO reports -1073741824 (INVALID_DOUBLE_VALUE) for vehicles off the network
SIGNAL_BLINKER_RIGHT = 1  # SUMO signal bits
SIGNAL_BLINKER_LEFT = 2
CONTROLLED_MAX_SPEED = 70.0  # m/s, a controlled vehicle's type cap (SUMO warns above it)
TV_LENGTH = 4.32  # m, traffic vehicles are the Table 1 car (assumption S3: all alike)
TV_WIDTH = 1.8  # m
TV_SIGMA = 0.2  # -, Krauss driver imperfection of traffic vehicles

_active: SumoSim | None = None  # the one simulation of this process


def sumo_angle(heading: float) -> float:
    """SUMO navigational degrees (0 north, clockwise) of a math heading in radians."""
    return (90.0 - math.degrees(heading)) % 360.0


def heading_from_angle(angle: float) -> float:
    """Math heading in radians, in (-pi, pi], of SUMO navigational degrees."""
    h = math.radians(90.0 - angle)
    return math.atan2(math.sin(h), math.cos(h))


def front_from_centre(x: float, y: float, heading: float, length: float) -> tuple[float, float]:
    """m, the front-bumper centre SUMO uses, of a body rectangle centred on (x, y)."""
    half = 0.5 * length
    return x + half * math.cos(heading), y + half * math.sin(heading)


def centre_from_front(xf: float, yf: float, heading: float, length: float) -> tuple[float, float]:
    """m, the body centre of a vehicle whose front-bumper centre SUMO reports."""
    half = 0.5 * length
    return xf - half * math.cos(heading), yf - half * math.sin(heading)


@dataclass(frozen=True)
class TrafficEvent:
    """Something SUMO did that a run must record: a teleport, a vehicle lost."""

    time: float  # s, simulation time
    kind: str  # "teleport" | "lost" (a controlled vehicle SUMO dropped)
    vehicle_id: str
    detail: str


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
    lane: np.ndarray  # int, SUMO lane index (-1: off the network)
    lateral_speed: np.ndarray  # m/s, + to the left (non-zero while changing lanes)
    length: np.ndarray  # m
    width: np.ndarray  # m
    signals: np.ndarray  # int, SUMO signal bits (1 right blinker, 2 left blinker)

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
        """The rows where `mask` is true."""
        mask = np.asarray(mask, dtype=bool)
        return TrafficSnapshot(
            time=self.time,
            ids=tuple(i for i, keep in zip(self.ids, mask, strict=True) if keep),
            x=self.x[mask],
            y=self.y[mask],
            heading=self.heading[mask],
            speed=self.speed[mask],
            accel=self.accel[mask],
            lane=self.lane[mask],
            lateral_speed=self.lateral_speed[mask],
            length=self.length[mask],
            width=self.width[mask],
            signals=self.signals[mask],
        )


@dataclass
class _Controlled:
    length: float  # m
    width: float  # m
    last: tuple[float, float, float]  # m, m, rad: the last centre pose written
    inserted: bool = False  # SUMO has it on the network (it inserts it in the next step)
    t_write: float = -1.0  # s, simulation time of the last write
    y_before: float | None = None  # m, centre y written in the step before that
    lateral_speed: float = 0.0  # m/s, dy/dt of the written poses (SUMO reports 0 for them)
    signals: int = -1  # SUMO signal bits to hold (-1: leave them to SUMO)


def _import_api(use_traci: bool) -> ModuleType:
    if use_traci:
        import traci  # sumo-gui needs the socket client; libsumo has no GUI

        return traci
    import libsumo

    return libsumo


class SumoSim:
    """One SUMO simulation of the highway, as a context manager.

    `lanechange_duration` (s) makes traffic lane changes continuous (constant
    lateral speed for that long); `sublane` uses SUMO's sublane model instead
    (`--lateral-resolution`, slower). `gui` runs sumo-gui through traci.
    `speed_bands` (m/s per lane) set each TV's desired speed in the lane it is in.
    `traci` runs the headless binary through traci (what `gui` does, minus the
    window). `strict`: a controlled vehicle leaving the network raises
    SimulationError (else it is only recorded in `events`).
    """

    def __init__(
        self,
        network: Path,
        step: float,
        seed: int,
        *,
        lanechange_duration: float = 3.0,
        sublane: bool = False,
        gui: bool | GuiSettings = False,
        extra_args: Sequence[str] = (),
        speed_bands: tuple[tuple[float, float], ...] | None = None,
        lateral_resolution: float = 0.8,
        strict: bool = True,
        traci: bool = False,
    ) -> None:
        if step <= 0:
            raise InputError("SumoSim", "step", step, "a positive step length in s")
        if lanechange_duration < 0:
            raise InputError("SumoSim", "lanechange_duration", lanechange_duration, ">= 0 s")
        self.highway: Highway = load_highway(Path(network))
        self.step_length = float(step)
        self.seed = int(seed)
        self.lanechange_duration = float(lanechange_duration)
        self.sublane = bool(sublane)
        self.gui = bool(gui)
        # `gui` may carry how to show the run (cosim.traffic.gui); True: the defaults
        self.gui_settings = gui if isinstance(gui, GuiSettings) else GuiSettings()
        self.use_traci = bool(traci) or self.gui  # the GUI is only reachable through traci
        self.extra_args = tuple(extra_args)
        self.lateral_resolution = float(lateral_resolution)
        self.strict = bool(strict)
        base = RoadParams()
        self._road = self.highway.road(
            RoadParams(speed_bands=speed_bands) if speed_bands is not None else base
        )
        if self._road.n_lanes != self.highway.n_lanes:
            raise InputError(
                str(network), "speed_bands", speed_bands, f"{self.highway.n_lanes} (min, max) pairs"
            )
        self.events: list[TrafficEvent] = []
        self._api: ModuleType | None = None
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        self._log_text = ""
        self._controlled: dict[str, _Controlled] = {}
        self._band_quantile: dict[str, float] = {}  # TV id -> its place in a speed band
        self._band_lane: dict[str, int] = {}  # TV id -> lane its desired speed was set for
        self._dims: dict[str, tuple[float, float]] = {}  # vehicle id -> (length, width)
        self._moved = False  # a moveToXY is pending (must be flushed before close)
        self._hooks: list[Callable[[SumoSim], None]] = []
        self._types: set[str] = set()
        self._snapshot: TrafficSnapshot | None = None
        self._near_key: tuple[str, float] | None = None  # (centre id, radius) of the candidates
        self._near_next = -math.inf  # s, simulation time of the next candidate refresh
        self._near_candidates: tuple[str, ...] = ()
        self._release: dict[str, tuple[float, int]] = {}  # add_driven: (desired m/s, lc mode)

    # ------------------------------------------------------------------ lifecycle
    def command(self) -> list[str]:
        """The SUMO command line this simulation starts with (warnings go to a
        temporary log file that lives until close)."""
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="cosim-sumo-")
        binary = "sumo-gui" if self.gui else "sumo"
        try:
            import sumolib

            binary = sumolib.checkBinary(binary)
        except (ImportError, SystemExit):  # sumolib exits if the binary is missing
            pass
        options = [
            ("-n", str(self.highway.path)),
            ("--step-length", repr(self.step_length)),
            ("--seed", str(self.seed)),
            ("--collision.action", "warn"),
            ("--collision.mingap-factor", "0"),
            ("--time-to-teleport", "-1"),
            ("--no-step-log", "true"),
            ("--no-warnings", "true"),
            ("--error-log", str(Path(self._tmp.name) / "sumo-warnings.log")),
            ("--duration-log.disable", "true"),
        ]
        if self.sublane:
            options.append(("--lateral-resolution", repr(self.lateral_resolution)))
        elif self.lanechange_duration > 0:
            options.append(("--lanechange.duration", repr(self.lanechange_duration)))
        if self.gui:
            options += gui_window.options(self.gui_settings)
        # SUMO refuses an option given twice: extra_args replace our defaults
        overridden = {a for a in self.extra_args if a.startswith("-")}
        cmd = [binary]
        for name, value in options:
            if name not in overridden:
                cmd += [name, value]
        return cmd + list(self.extra_args)

    def start(self) -> SumoSim:
        global _active
        if _active is not None and _active is not self and _active._api is not None:
            raise SimulationError(0.0, "another SUMO simulation is running in this process")
        self._api = _import_api(self.use_traci)
        if self.gui:
            gui_window.start(self._api, self.command())
            self.add_hook(gui_window.Pacer(self.gui_settings.speed))
        else:
            self._api.start(self.command())
        _active = self
        self._api.route.add(ROUTE_ID, [self.highway.edge_id])
        self._ensure_type(TV_TYPE, TV_LENGTH, TV_WIDTH, traffic=True)
        return self

    def close(self) -> None:
        """Close SUMO; flush a pending moveToXY first (it would leak into the next run)."""
        global _active
        api = self._api
        if api is None:
            return
        try:
            if self._moved:
                # closing anyway: only the pending move had to be consumed
                with contextlib.suppress(api.TraCIException):
                    api.simulationStep()
                self._moved = False
        finally:
            try:
                if self.gui:
                    gui_window.close(api, self.gui_settings)
                else:
                    api.close()
            finally:
                self._api = None
                _active = None
                if self._tmp is not None:
                    self._log_text = self._read_log()
                    self._tmp.cleanup()
                    self._tmp = None

    def __enter__(self) -> SumoSim:
        return self.start()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def api(self) -> ModuleType:
        if self._api is None:
            raise SimulationError(0.0, "SUMO is not running (use SumoSim as a context manager)")
        return self._api

    # ------------------------------------------------------------------ stepping
    @property
    def time(self) -> float:
        """s, simulation time."""
        return float(self.api.simulation.getTime())

    def road(self) -> RoadParams:
        """Road geometry from the network (lane width, y_right) with the speed bands."""
        return self._road

    def add_hook(self, hook: Callable[[SumoSim], None]) -> None:
        """Call `hook(sim)` after every step (e.g. the traffic inflow of demand.py)."""
        self._hooks.append(hook)

    def step(self) -> None:
        """Advance one step; keep TV speed bands; record teleports and lost controlled
        vehicles (SimulationError if `strict`); run the step hooks. Snapshots are read
        on demand."""
        api = self.api
        api.simulationStep()
        self._moved = False
        t = float(api.simulation.getTime())
        for vid in api.simulation.getArrivedIDList():
            self._band_quantile.pop(vid, None)
            self._band_lane.pop(vid, None)
            self._dims.pop(vid, None)
        teleported = set(api.simulation.getStartingTeleportIDList())
        for vid in sorted(teleported):
            self.events.append(TrafficEvent(t, "teleport", vid, "SUMO teleported it"))
        self._snapshot = None  # read on demand: snapshot() or snapshot_near()
        self._keep_bands()
        self._check_controlled(t, teleported)
        for hook in self._hooks:
            hook(self)

    def _check_controlled(self, t: float, teleported: set[str]) -> None:
        """A moveToXY vehicle off the network is dropped silently by SUMO: catch it."""
        if not self._controlled:
            return
        vehicle = self.api.vehicle
        present = set(vehicle.getIDList()) if len(self._controlled) > 1 else None
        for vid, ctl in list(self._controlled.items()):
            try:
                on_road = (present is None or vid in present) and vehicle.getLaneID(vid) != ""
            except self.api.TraCIException:  # an unknown vehicle id
                on_road = False
            if on_road:
                ctl.inserted = True
                continue
            x, y, h = ctl.last
            detail = f"{vid} left the network at x = {x:.2f} m, y = {y:.2f} m"
            if vid in teleported:
                detail += " (SUMO teleported it: a jam with --time-to-teleport set)"
            self.events.append(TrafficEvent(t, "lost", vid, detail))
            del self._controlled[vid]
            if self.strict:
                raise SimulationError(t, detail, f"heading {h:.4f} rad")

    def _keep_bands(self) -> None:
        """A TV whose lane changed gets its desired speed from its new lane's band
        (one lane-index read per TV and step, ~1 us each with libsumo)."""
        if not self._band_lane:
            return
        vehicle = self.api.vehicle
        get_lane = self._getters()[4]
        bands = self._road.speed_bands
        was = self._band_lane
        for vid, lane_was in was.items():
            try:
                lane = get_lane(vid)
            except self.api.TraCIException:  # added but not inserted yet
                continue
            if lane == lane_was or not 0 <= lane < len(bands):
                continue
            lo, hi = bands[lane]
            vehicle.setMaxSpeed(vid, lo + self._band_quantile[vid] * (hi - lo))
            was[vid] = lane

    # ------------------------------------------------------------------ traffic
    def _ensure_type(self, type_id: str, length: float, width: float, traffic: bool) -> None:
        if type_id in self._types:
            return
        vt = self.api.vehicletype
        vt.copy("DEFAULT_VEHTYPE", type_id)
        vt.setLength(type_id, length)
        vt.setWidth(type_id, width)
        vt.setSpeedFactor(type_id, 1.0)  # desired speed = maxSpeed (set from the band)
        vt.setSpeedDeviation(type_id, 0.0)
        if traffic:
            vt.setImperfection(type_id, TV_SIGMA)
        else:
            vt.setMaxSpeed(type_id, CONTROLLED_MAX_SPEED)
        self._types.add(type_id)

    def band_speed(self, lane: int, quantile: float) -> float:
        """m/s, the desired speed at `quantile` in [0, 1] of a lane's speed band."""
        lo, hi = self._road.speed_bands[lane]
        return lo + quantile * (hi - lo)

    def add_traffic(
        self, vehicle_id: str, lane: int, x: float, quantile: float, speed: float | None = None
    ) -> None:
        """Insert a TV with its centre at global x in `lane`, desired speed from the band.

        It is inserted in the next step at `speed` (default: its desired speed),
        reduced by SUMO if that is unsafe behind its leader.
        """
        if not 0 <= lane < self.highway.n_lanes:
            raise InputError("traffic", "lane", lane, f"0 .. {self.highway.n_lanes - 1}")
        desired = self.band_speed(lane, quantile)
        front = x - self.highway.x_start + 0.5 * TV_LENGTH
        self.api.vehicle.add(
            vehicle_id,
            ROUTE_ID,
            typeID=TV_TYPE,
            departLane=str(lane),
            departPos=repr(float(front)),
            departSpeed="max" if speed is None else repr(float(min(speed, desired))),
        )
        self.api.vehicle.setMaxSpeed(vehicle_id, desired)
        self._band_quantile[vehicle_id] = float(quantile)
        self._band_lane[vehicle_id] = lane
        self._dims[vehicle_id] = (TV_LENGTH, TV_WIDTH)

    def add_driven(
        self, vehicle_id: str, lane: int, x: float, speed: float, desired_speed: float,
        length: float, width: float, *, own_lane_changes: bool = True,
    ) -> None:
        """A vehicle SUMO will drive itself (the SV of the 'sumo' baseline): centre at
        global x in `lane`, its own size, no driver imperfection, desired speed in m/s.

        It is placed like a controlled vehicle (exactly there, whatever the gaps:
        SUMO's own insertion may refuse or delay a car in dense traffic) and handed
        to SUMO by `release` after the step that inserts it. own_lane_changes False:
        SUMO makes no lane change of its own (lane-change mode 512: only
        `change_lane` requests, still with SUMO's safety checks).
        """
        type_id = f"driven_{vehicle_id}"
        self._ensure_type(type_id, length, width, traffic=False)
        self.api.vehicletype.setImperfection(type_id, 0.0)
        self._dims[f"type:{type_id}"] = (length, width)
        self.add_controlled(vehicle_id, x, self._road.lane_center(lane), 0.0, speed, length,
                            width, lane, vtype=type_id)
        self._release[vehicle_id] = (float(desired_speed), 1621 if own_lane_changes else 512)

    def release(self, vehicle_id: str) -> None:
        """Hand a vehicle placed by `add_driven` to SUMO (call after it is inserted):
        SUMO's speed and lane-change models from now on."""
        desired, lc_mode = self._release.pop(vehicle_id)
        vehicle = self.api.vehicle
        vehicle.setSpeedMode(vehicle_id, 31)  # SUMO's default: all safety checks
        vehicle.setLaneChangeMode(vehicle_id, lc_mode)
        vehicle.setMaxSpeed(vehicle_id, desired)
        self._controlled.pop(vehicle_id, None)

    def follow_in_gui(self, vehicle_id: str) -> None:
        """sumo-gui only: keep the main view centred on a vehicle (no-op without GUI)."""
        if self.gui:
            gui_window.follow(self.api, vehicle_id, self.gui_settings)

    def change_lane(self, vehicle_id: str, lane: int, duration: float = 30.0) -> None:
        """Ask SUMO to move a vehicle it drives to `lane` (keeps trying for `duration` s)."""
        self.api.vehicle.changeLane(vehicle_id, lane, duration)

    def lane_position(self, vehicle_id: str) -> float:
        """m, distance of the vehicle's front bumper from the start of the road."""
        return float(self.api.vehicle.getLanePosition(vehicle_id))

    def vehicle_ids(self) -> tuple[str, ...]:
        """Every vehicle on the network now."""
        return tuple(self.api.vehicle.getIDList())

    def pending(self) -> tuple[str, ...]:
        """Vehicles added but not yet inserted (no room at their position yet)."""
        return tuple(self.api.simulation.getPendingVehicles())

    # ------------------------------------------------------------------ controlled vehicles
    def add_controlled(
        self,
        vehicle_id: str,
        x: float,
        y: float,
        heading: float,
        speed: float,
        length: float,
        width: float,
        lane: int,
        vtype: str = "sv",
    ) -> None:
        """Add a vehicle SUMO does not drive (SV, scripted TV): centre pose, its own size.

        Speed mode 0 and lane-change mode 0 take it out of SUMO's control; the
        pose is written with moveToXY and holds from the next step on.
        """
        if length <= 0 or width <= 0:
            raise InputError("vehicle", "length/width", (length, width), "positive sizes in m")
        type_id = vtype
        if type_id in self._types and self._dims.get(f"type:{type_id}") != (length, width):
            type_id = f"{vtype}_{vehicle_id}"  # another size: a type of its own
        if type_id not in self._types:
            self._ensure_type(type_id, length, width, traffic=False)
            self._dims[f"type:{type_id}"] = (length, width)
        api = self.api
        front = x - self.highway.x_start + 0.5 * length
        api.vehicle.add(
            vehicle_id,
            ROUTE_ID,
            typeID=type_id,
            departLane=str(lane),
            departPos=repr(float(min(max(front, length), self.highway.length))),
            departSpeed=repr(float(max(speed, 0.0))),
        )
        api.vehicle.setSpeedMode(vehicle_id, 0)
        api.vehicle.setLaneChangeMode(vehicle_id, 0)
        self._controlled[vehicle_id] = _Controlled(length, width, (x, y, heading))
        self._dims[vehicle_id] = (length, width)
        self.move(vehicle_id, x, y, heading, speed)

    def move(
        self,
        vehicle_id: str,
        x: float,
        y: float,
        heading: float,
        speed: float,
        accel: float | None = None,
    ) -> None:
        """Write a controlled vehicle's centre pose (takes effect in the next step).

        Also sets its speed (and acceleration), so the TVs that react to it in
        the next step see the plant's speed, not last step's displacement.
        """
        ctl = self._controlled.get(vehicle_id)
        if ctl is None:
            raise SimulationError(self.time, f"{vehicle_id} is not a controlled vehicle")
        xf, yf = front_from_centre(x, y, heading, ctl.length)
        lane = self._road.lane_of(yf)
        vehicle = self.api.vehicle
        vehicle.moveToXY(
            vehicle_id, self.highway.edge_id, lane, xf, yf, sumo_angle(heading), keepRoute=2
        )
        if ctl.inserted:
            if accel is None:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0))
            else:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0), float(accel))
        t = self.time
        if t > ctl.t_write:  # a new step: the previous write becomes the reference
            ctl.y_before, t_before = ctl.last[1], ctl.t_write
            ctl.lateral_speed = 0.0 if t_before < 0 else (y - ctl.y_before) / (t - t_before)
        elif ctl.y_before is not None:  # written twice in one step: the latest counts
            ctl.lateral_speed = (y - ctl.y_before) / self.step_length
        ctl.t_write = t
        ctl.last = (float(x), float(y), float(heading))
        if ctl.signals >= 0:  # SUMO resets the signals of a moved vehicle: hold them
            vehicle.setSignals(vehicle_id, ctl.signals)
        self._moved = True

    def set_blinker(self, vehicle_id: str, direction: int) -> None:
        """Blinker of a controlled vehicle: -1 right, +1 left, 0 off (what V2V reads)."""
        bits = {-1: SIGNAL_BLINKER_RIGHT, 0: 0, 1: SIGNAL_BLINKER_LEFT}.get(direction)
        if bits is None:
            raise InputError("blinker", "direction", direction, "-1, 0 or +1")
        ctl = self._controlled.get(vehicle_id)
        if ctl is None:
            raise SimulationError(self.time, f"{vehicle_id} is not a controlled vehicle")
        ctl.signals = bits
        self.api.vehicle.setSignals(vehicle_id, bits)

    # aliases for the scripted-TV code (same operation as for the SV)
    add_vehicle = add_controlled
    move_vehicle = move

    def remove(self, vehicle_id: str) -> None:
        """Take a vehicle off the network (controlled or not)."""
        self.api.vehicle.remove(vehicle_id)
        self._controlled.pop(vehicle_id, None)
        self._band_quantile.pop(vehicle_id, None)
        self._band_lane.pop(vehicle_id, None)

    def pose(self, vehicle_id: str) -> tuple[float, float, float]:
        """(x, y, heading) of a vehicle's centre as SUMO has it now (m, m, rad)."""
        vehicle = self.api.vehicle
        xf, yf = vehicle.getPosition(vehicle_id)
        if xf < INVALID:
            raise SimulationError(self.time, f"{vehicle_id} is not on the network")
        h = heading_from_angle(vehicle.getAngle(vehicle_id))
        length = self._length(vehicle_id)
        x, y = centre_from_front(xf, yf, h, length)
        return x, y, h

    def speed(self, vehicle_id: str) -> float:
        """m/s, SUMO's speed of a vehicle."""
        return float(self.api.vehicle.getSpeed(vehicle_id))

    def lane_index(self, vehicle_id: str) -> int:
        """SUMO lane index of a vehicle (-1 off the network)."""
        if self.api.vehicle.getLaneID(vehicle_id) == "":
            return -1
        return int(self.api.vehicle.getLaneIndex(vehicle_id))

    def leader(self, vehicle_id: str, distance: float = 200.0) -> tuple[str, float] | None:
        """(id, gap in m bumper to bumper) of the leader in the vehicle's lane, or None."""
        vehicle = self.api.vehicle
        found = vehicle.getLeader(vehicle_id, distance)
        if not found or not found[0]:
            return None
        # SUMO measures from the follower's front + its minGap: add the minGap back
        return str(found[0]), float(found[1]) + float(vehicle.getMinGap(vehicle_id))

    def _length(self, vehicle_id: str) -> float:
        dims = self._dims.get(vehicle_id)
        if dims is None:
            vehicle = self.api.vehicle
            dims = (float(vehicle.getLength(vehicle_id)), float(vehicle.getWidth(vehicle_id)))
            self._dims[vehicle_id] = dims
        return dims[0]

    # ------------------------------------------------------------------ reading
    def snapshot(self, exclude: Iterable[str] = ()) -> TrafficSnapshot:
        """Every vehicle now (except `exclude`), centre poses, in one pass."""
        if self._snapshot is None:
            self._snapshot = self._read_all()
        snap = self._snapshot
        skip = set(exclude)
        if not skip:
            return snap
        return snap.select(np.array([vid not in skip for vid in snap.ids], dtype=bool))

    def snapshot_near(self, center_id: str, radius: float) -> TrafficSnapshot:
        """Vehicles whose centre is within `radius` m of vehicle `center_id`'s centre
        (itself included): the cost follows the traffic near it, not the whole road's
        (what the co-simulation's hot path needs).

        Every NEAR_REFRESH s of simulated time one cheap pass over all positions picks
        the candidates within radius + NEAR_MARGIN along x (no vehicle closes in on
        another by more than NEAR_MARGIN in that time); each call reads the seven
        values of the candidates only. (A SUMO context subscription does the same
        selection but costs more inside simulationStep than this whole read.)"""
        api = self.api
        t = float(api.simulation.getTime())
        present = api.vehicle.getIDList()
        key = (center_id, float(radius))
        if self._near_key != key or t >= self._near_next - 1e-9 or center_id not in present:
            get_pos = self._getters()[0]
            cx = get_pos(center_id)[0] if center_id in present else math.nan
            reach = radius + NEAR_MARGIN
            self._near_candidates = tuple(
                vid for vid in present if abs(get_pos(vid)[0] - cx) <= reach)
            self._near_key = key
            self._near_next = t + NEAR_REFRESH
        alive = set(present)
        ids = tuple(sorted(vid for vid in self._near_candidates if vid in alive))
        snap = self._read(ids)
        if center_id not in snap.ids:
            return snap.select(np.zeros(len(snap), dtype=bool))
        i = snap.index(center_id)
        near = np.hypot(snap.x - snap.x[i], snap.y - snap.y[i]) <= radius
        return snap.select(near)

    def _controlled_lateral_speed(self, ids: tuple[str, ...], lat: np.ndarray) -> None:
        """SUMO reports no sideways speed of a moved vehicle: use dy/dt of its written poses."""
        if not self._controlled:
            return
        rows = {vid: i for i, vid in enumerate(ids)}
        for vid, ctl in self._controlled.items():
            if vid in rows:
                lat[rows[vid]] = ctl.lateral_speed

    def _read_dims(self, vehicle_id: str) -> tuple[float, float]:
        vehicle = self.api.vehicle
        dims = (float(vehicle.getLength(vehicle_id)), float(vehicle.getWidth(vehicle_id)))
        self._dims[vehicle_id] = dims
        return dims

    def _getters(self) -> tuple[Callable[[str], Any], ...]:
        """The seven per-vehicle getters of a snapshot. With libsumo, its compiled
        functions directly: the Python wrappers around them double the read time."""
        v = self.api.vehicle
        names = ("getPosition", "getAngle", "getSpeed", "getAcceleration", "getLaneIndex",
                 "getLateralSpeed", "getSignals")  # fmt: skip
        raw = getattr(self.api, "_libsumo", None)
        if raw is not None and all(hasattr(raw, f"vehicle_{n}") for n in names):
            return tuple(getattr(raw, f"vehicle_{n}") for n in names)
        return tuple(getattr(v, n) for n in names)

    def _read_all(self) -> TrafficSnapshot:
        return self._read(tuple(self.api.vehicle.getIDList()))

    def _read(self, ids: tuple[str, ...]) -> TrafficSnapshot:
        """The snapshot of the vehicles `ids` (all present now), in that order."""
        api = self.api
        n = len(ids)
        get_pos, get_angle, get_speed, get_accel, get_lane, get_lat, get_signals = self._getters()
        pos = np.array([get_pos(vid) for vid in ids], dtype=float).reshape(n, 2)
        xf, yf = pos[:, 0], pos[:, 1]
        angle = np.fromiter(map(get_angle, ids), float, n)
        speed = np.fromiter(map(get_speed, ids), float, n)
        accel = np.fromiter(map(get_accel, ids), float, n)
        lane = np.fromiter(map(get_lane, ids), int, n)
        lat = np.fromiter(map(get_lat, ids), float, n)
        signals = np.fromiter(map(get_signals, ids), int, n)
        dims = [self._dims.get(vid) or self._read_dims(vid) for vid in ids]
        length = np.fromiter((d[0] for d in dims), float, n)
        width = np.fromiter((d[1] for d in dims), float, n)
        off = xf < INVALID
        lane[off] = -1
        self._controlled_lateral_speed(ids, lat)
        h = np.radians(90.0 - angle)
        h = np.arctan2(np.sin(h), np.cos(h))
        x = xf - 0.5 * length * np.cos(h)
        y = yf - 0.5 * length * np.sin(h)
        return TrafficSnapshot(
            time=float(api.simulation.getTime()),
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

    def collisions(self) -> list[tuple[str, str]]:
        """(collider, victim) pairs SUMO detected in the last step (cross-check only)."""
        return [(str(c.collider), str(c.victim)) for c in self.api.simulation.getCollisions()]

    def _read_log(self) -> str:
        if self._tmp is None:
            return self._log_text
        log = Path(self._tmp.name) / "sumo-warnings.log"
        try:
            return log.read_text(encoding="utf-8", errors="replace")
        except FileNotFoundError:
            return ""

    def warnings(self) -> list[str]:
        """SUMO's warnings and errors (captured in a log file, not printed).

        SUMO buffers the file: the list is complete once the simulation is closed.
        """
        return [line for line in self._read_log().splitlines() if line.strip()]
