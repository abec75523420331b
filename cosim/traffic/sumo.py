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

from cosim.errors import InputError, SimulationError
from cosim.params import RoadParams
from cosim.traffic import gui as gui_window
from cosim.traffic.gui import GuiSettings
from cosim.traffic.network import Highway, load_highway
from cosim.traffic.snapshot import (  # noqa: F401  (TrafficSnapshot: re-exported)
    INVALID,
    SIGNAL_BLINKER_LEFT,
    SIGNAL_BLINKER_RIGHT,
    SnapshotReader,
    TrafficSnapshot,
    centre_from_front,
    heading_from_angle,
)

ROUTE_ID = "highway_route"
TV_TYPE = "tv"
CONTROLLED_MAX_SPEED = 70.0  # m/s, a controlled vehicle's type cap (SUMO warns above it)
TV_LENGTH = 4.32  # m, traffic vehicles are the Table 1 car (assumption S3: all alike)
TV_WIDTH = 1.8  # m
TV_SIGMA = 0.2  # -, Krauss driver imperfection of traffic vehicles

_active: SumoSim | None = None  # the one simulation of this process


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
    (`--lateral-resolution`, slower). `gui` runs sumo-gui through traci; `traci`
    the headless binary so. `speed_bands` (m/s per lane) set each TV's desired speed
    in the lane it is in. `strict`: a controlled vehicle leaving the network raises
    SimulationError (else it is only recorded in `events`). `fcd_output`: the file SUMO
    writes its floating-car data to (--fcd-output), complete once it is closed.
    """

    def __init__(
        self, network: Path, step: float, seed: int, *,
        lanechange_duration: float = 3.0, sublane: bool = False,
        gui: bool | GuiSettings = False, extra_args: Sequence[str] = (),
        speed_bands: tuple[tuple[float, float], ...] | None = None,
        lateral_resolution: float = 0.8, strict: bool = True, traci: bool = False,
        fcd_output: Path | None = None,
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
        # how sumo-gui shows the run (cosim.traffic.gui; `gui` True: the defaults); None: no GUI
        self.gui = (gui if isinstance(gui, GuiSettings) else GuiSettings()) if gui else None
        self.use_traci = bool(traci) or self.gui is not None  # the GUI is only reachable by traci
        self.extra_args = tuple(extra_args)
        self.lateral_resolution = float(lateral_resolution)
        self.strict = bool(strict)
        self.fcd_output = None if fcd_output is None else Path(fcd_output)  # the caller's
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
        self.controlled = ControlledVehicles(self)
        self.bands = SpeedBands(self._road.speed_bands,
                                 tuple(f"{self.highway.edge_id}_{i}"
                                       for i in range(self.highway.n_lanes)))
        self._dims: dict[str, tuple[float, float]] = {}  # vehicle id -> (length, width)
        self._hooks: list[Callable[[SumoSim], None]] = []
        self._types: set[str] = set()
        self._reader: SnapshotReader | None = None  # the reading side, while running

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
        if self.fcd_output is not None:
            options.append(("--fcd-output", str(self.fcd_output)))
        if self.sublane:
            options.append(("--lateral-resolution", repr(self.lateral_resolution)))
        elif self.lanechange_duration > 0:
            options.append(("--lanechange.duration", repr(self.lanechange_duration)))
        if self.gui:
            options += gui_window.options(self.gui)
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
            self.add_hook(gui_window.Pacer(self.gui.speed))
        else:
            self._api.start(self.command())
        _active = self
        self._reader = SnapshotReader(self._api, self._dims, self.controlled.lateral_speeds)
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
            if self.controlled.moved:
                # closing anyway: only the pending move had to be consumed
                with contextlib.suppress(api.TraCIException):
                    api.simulationStep()
                self.controlled.moved = False
        finally:
            try:
                if self.gui:
                    gui_window.close(api, self.gui)
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
        self.controlled.moved = False
        t = float(api.simulation.getTime())
        arrived = api.simulation.getArrivedIDList()
        for vid in arrived:
            self.bands.forget(vid)
            self._dims.pop(vid, None)
        teleported = set(api.simulation.getStartingTeleportIDList())
        self.reader.left(arrived, untracked=bool(teleported))
        for vid in sorted(teleported):
            self.events.append(TrafficEvent(t, "teleport", vid, "SUMO teleported it"))
        self.reader.cached = None  # read on demand: snapshot() or snapshot_near()
        self.bands.keep(api)
        self.controlled.check(t, teleported)
        for hook in self._hooks:
            hook(self)

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

    def add_traffic(
        self, vehicle_id: str, lane: int, x: float, quantile: float, speed: float | None = None
    ) -> None:
        """Insert a TV with its centre at global x in `lane`, desired speed from the band.

        It is inserted in the next step at `speed` (default: its desired speed),
        reduced by SUMO if that is unsafe behind its leader.
        """
        if not 0 <= lane < self.highway.n_lanes:
            raise InputError("traffic", "lane", lane, f"0 .. {self.highway.n_lanes - 1}")
        desired = self.bands.speed(lane, quantile)
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
        self.bands.add(vehicle_id, lane, quantile)
        self._dims[vehicle_id] = (TV_LENGTH, TV_WIDTH)

    def add_driven(
        self, vehicle_id: str, lane: int, x: float, speed: float, desired_speed: float,
        length: float, width: float, *, own_lane_changes: bool = True,
    ) -> None:
        """A vehicle SUMO will drive itself (the SV of the 'sumo' baseline): centre at
        global x in `lane`, its own size, no driver imperfection, desired speed in m/s.

        It is placed like a controlled vehicle (exactly there, whatever the gaps:
        SUMO's own insertion may refuse or delay a car in dense traffic) and handed
        to SUMO by `controlled.release` after the step that inserts it. own_lane_changes False:
        SUMO makes no lane change of its own (lane-change mode 512: only
        `change_lane` requests, still with SUMO's safety checks).
        """
        type_id = f"driven_{vehicle_id}"
        self._ensure_type(type_id, length, width, traffic=False)
        self.api.vehicletype.setImperfection(type_id, 0.0)
        self._dims[f"type:{type_id}"] = (length, width)
        self.add_controlled(vehicle_id, x, self._road.lane_center(lane), 0.0, speed, length,
                            width, lane, vtype=type_id)
        self.controlled.release_modes[vehicle_id] = (float(desired_speed),
                                                     1621 if own_lane_changes else 512)

    def follow_in_gui(self, vehicle_id: str) -> None:
        """sumo-gui only: keep the main view centred on a vehicle (no-op without GUI)."""
        if self.gui:
            gui_window.follow(self.api, vehicle_id, self.gui)

    def change_lane(self, vehicle_id: str, lane: int, duration: float = 30.0) -> None:
        """Ask SUMO to move a vehicle it drives to `lane` (keeps trying for `duration` s)."""
        self.api.vehicle.changeLane(vehicle_id, lane, duration)

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
        self.controlled.add(vehicle_id, x, y, heading, speed, length, width, lane, type_id)
        self._dims[vehicle_id] = (length, width)

    def move(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
             accel: float | None = None) -> None:
        """Write a controlled vehicle's centre pose (takes effect in the next step); see
        ControlledVehicles.move."""
        self.controlled.move(vehicle_id, x, y, heading, speed, accel)

    def set_blinker(self, vehicle_id: str, direction: int) -> None:
        """Blinker of a controlled vehicle: -1 right, +1 left, 0 off (what V2V reads)."""
        self.controlled.set_blinker(vehicle_id, direction)

    # aliases for the scripted-TV code (same operation as for the SV)
    add_vehicle = add_controlled
    move_vehicle = move

    def remove(self, vehicle_id: str) -> None:
        """Take a vehicle off the network (controlled or not)."""
        self.api.vehicle.remove(vehicle_id)
        self.reader.untracked()
        self.controlled.vehicles.pop(vehicle_id, None)
        self.bands.forget(vehicle_id)

    # ------------------------------------------------------------------ reading
    @property
    def reader(self) -> SnapshotReader:
        if self._reader is None or self._api is None:
            raise SimulationError(0.0, "SUMO is not running (use SumoSim as a context manager)")
        return self._reader

    def snapshot(self, exclude: Iterable[str] = ()) -> TrafficSnapshot:
        """Every vehicle now (except `exclude`), centre poses, in one pass."""
        return self.reader.snapshot(exclude)

    def snapshot_near(self, center_id: str, radius: float, *, full: bool = True
                      ) -> TrafficSnapshot:
        """Vehicles within `radius` m of vehicle `center_id` (itself included); see
        SnapshotReader.snapshot_near."""
        return self.reader.snapshot_near(center_id, radius, full=full)

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


class ControlledVehicles:
    """The vehicles SUMO does not drive (the SV, scripted TVs): added at a centre pose,
    moved with moveToXY each step, their blinkers held, and caught when SUMO drops
    one off the network."""

    def __init__(self, sim: SumoSim) -> None:
        self.sim = sim
        self.vehicles: dict[str, _Controlled] = {}
        self.moved = False  # a moveToXY is pending (must be flushed before close)
        self.release_modes: dict[str, tuple[float, int]] = {}  # add_driven: (desired m/s, lc mode)

    def add(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
            length: float, width: float, lane: int, type_id: str) -> None:
        """Insert it (in the next step) with speed mode 0 and lane-change mode 0 (out of
        SUMO's control), at its pose."""
        api = self.sim.api
        front = x - self.sim.highway.x_start + 0.5 * length
        api.vehicle.add(
            vehicle_id,
            ROUTE_ID,
            typeID=type_id,
            departLane=str(lane),
            departPos=repr(float(min(max(front, length), self.sim.highway.length))),
            departSpeed=repr(float(max(speed, 0.0))),
        )
        api.vehicle.setSpeedMode(vehicle_id, 0)
        api.vehicle.setLaneChangeMode(vehicle_id, 0)
        self.vehicles[vehicle_id] = _Controlled(length, width, (x, y, heading))
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
        ctl = self.vehicles.get(vehicle_id)
        if ctl is None:
            raise SimulationError(self.sim.time, f"{vehicle_id} is not a controlled vehicle")
        xf, yf = front_from_centre(x, y, heading, ctl.length)
        lane = self.sim.road().lane_of(yf)
        vehicle = self.sim.api.vehicle
        vehicle.moveToXY(
            vehicle_id, self.sim.highway.edge_id, lane, xf, yf, sumo_angle(heading), keepRoute=2
        )
        if ctl.inserted:
            if accel is None:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0))
            else:
                vehicle.setPreviousSpeed(vehicle_id, max(float(speed), 0.0), float(accel))
        t = self.sim.time
        if t > ctl.t_write:  # a new step: the previous write becomes the reference
            ctl.y_before, t_before = ctl.last[1], ctl.t_write
            ctl.lateral_speed = 0.0 if t_before < 0 else (y - ctl.y_before) / (t - t_before)
        elif ctl.y_before is not None:  # written twice in one step: the latest counts
            ctl.lateral_speed = (y - ctl.y_before) / self.sim.step_length
        ctl.t_write = t
        ctl.last = (float(x), float(y), float(heading))
        if ctl.signals >= 0:  # SUMO resets the signals of a moved vehicle: hold them
            vehicle.setSignals(vehicle_id, ctl.signals)
        self.moved = True

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

    def lateral_speeds(self) -> dict[str, float]:
        """m/s, dy/dt of the poses written to each controlled vehicle."""
        return {vid: ctl.lateral_speed for vid, ctl in self.vehicles.items()}
