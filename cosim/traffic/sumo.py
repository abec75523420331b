"""The SUMO adapter: the only module (with its parts below) that imports libsumo / traci.

`SumoSim` starts SUMO on a route's road (cosim.road.road.Road: SUMO's route is its
edges, the SV's lanes the tracks of its first edge, cosim.traffic.route_lanes), steps
it, reads every traffic vehicle (TV) in one pass into a `TrafficSnapshot`, and lets the
co-simulation drive vehicles it controls itself (the SV and scripted TVs) with
`vehicle.moveToXY(..., keepRoute=2)`.
It is put together from parts named for what they are:

- `cosim.traffic.process.SumoProcess`: the SUMO command line, starting and closing
  SUMO, the warnings it wrote;
- `cosim.traffic.traffic_vehicles`: TVs inserted where asked, each keeping the speed
  band of its lane (Section 5);
- `cosim.traffic.controlled`: the vehicles SUMO does not drive, written with moveToXY,
  their blinkers held, caught when SUMO drops one (conventions of the SUMO boundary:
  front bumper vs body centre, navigational degrees vs radians);
- `cosim.traffic.snapshot.SnapshotReader`: the reading side.

A pending moveToXY is flushed by one step before close (it would leak into the next
simulation in the process), and one that takes a controlled vehicle off the network
(SUMO drops it silently) raises SimulationError.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from types import ModuleType, TracebackType

from cosim.errors import InputError, SimulationError
from cosim.params import RoadParams
from cosim.road.road import Road
from cosim.traffic import gui as gui_window
from cosim.traffic.controlled import (  # noqa: F401  (re-exported)
    CONTROLLED_MAX_SPEED,
    ControlledVehicles,
    TrafficEvent,
    front_from_centre,
    sumo_angle,
)
from cosim.traffic.gui import GuiSettings
from cosim.traffic.process import BASE_TYPE, SumoOptions, SumoProcess, process
from cosim.traffic.route_lanes import RouteLanes, load_route_road, road_params
from cosim.traffic.snapshot import (  # noqa: F401  (TrafficSnapshot: re-exported)
    INVALID,
    SIGNAL_BLINKER_LEFT,
    SIGNAL_BLINKER_RIGHT,
    SnapshotReader,
    TrafficSnapshot,
    centre_from_front,
    heading_from_angle,
)
from cosim.traffic.traffic_vehicles import (  # noqa: F401  (re-exported)
    TV_LENGTH,
    TV_SIGMA,
    TV_TYPE,
    TV_WIDTH,
    SpeedBands,
    TrafficVehicles,
)


class SumoSim:
    """One SUMO simulation of a route's road, as a context manager (`route`: the edges,
    None on a one-edge network; `route_road`: the Road already built of them).

    `options`: how SUMO runs (cosim.traffic.process.SumoOptions, its defaults if None:
    continuous or sublane lane changes, the GUI, traci, extra options, floating-car
    data, the user's own demand). `speed_bands` (m/s per SV lane, or per through track:
    cosim.traffic.route_lanes.expand_bands) set each TV's desired speed on the track it is
    on. `strict`: a controlled vehicle leaving the network, or SUMO teleporting or
    removing the SUMO-driven SV, raises SimulationError (else it is only recorded in
    `events`).
    """

    def __init__(
        self, network: Path, step: float, seed: int, options: SumoOptions | None = None, *,
        speed_bands: tuple[tuple[float, float], ...] | None = None, strict: bool = True,
        route: Sequence[str] | None = None, route_road: Road | None = None,
    ) -> None:
        options = options if options is not None else SumoOptions()
        if step <= 0:
            raise InputError("SumoSim", "step", step, "a positive step length in s")
        if options.lanechange_duration < 0:
            raise InputError("SumoSim", "lanechange_duration", options.lanechange_duration,
                             ">= 0 s")
        # the route's road (cosim.road): SUMO's route is its edges, the SV's lanes its
        # first edge's tracks (cosim.traffic.route_lanes); `route_road` if the caller has
        # built it
        self.lanes = RouteLanes(route_road if route_road is not None
                                else load_route_road(network, route))
        self.process: SumoProcess = process(self.lanes.route_road.route.path, step, seed,
                                            options)
        self.strict = bool(strict)
        base = RoadParams() if speed_bands is None else RoadParams(speed_bands=speed_bands)
        self._road = road_params(self.lanes.route_road, base, str(network))
        n = len(self.lanes.sv)
        if self._road.n_lanes != n:
            raise InputError(str(network), "speed_bands", speed_bands,
                             f"{n} (min, max) pairs (one per lane of the route)")
        self.events: list[TrafficEvent] = []
        self.controlled = ControlledVehicles(self)
        self.bands = SpeedBands(self._road.speed_bands, self.lanes.edge_lanes,
                                self.lanes.band_index)
        self.traffic = TrafficVehicles(self, self.bands)
        self.dims: dict[str, tuple[float, float]] = {}  # vehicle id -> (length, width)
        self._hooks: list[Callable[[SumoSim], None]] = []
        self._types: set[str] = set()
        self._reader: SnapshotReader | None = None  # the reading side, while running
        # vehicles SUMO drives that must stay until the run ends (the SUMO-driven SV):
        # a teleport or a removal of one is a SimulationError (`step`), never silent
        self.kept: set[str] = set()

    # ------------------------------------------------------------------ lifecycle
    @property
    def step_length(self) -> float:
        """s, SUMO's step."""
        return self.process.step_length

    @property
    def gui(self) -> GuiSettings | None:
        """How sumo-gui shows the run (None: no GUI)."""
        return self.process.gui

    @property
    def use_traci(self) -> bool:
        """SUMO runs behind traci's socket (the GUI, or asked for), not in libsumo."""
        return self.process.use_traci

    def command(self) -> list[str]:
        """The SUMO command line this simulation starts with (SumoProcess.command)."""
        return self.process.command()

    def start(self) -> SumoSim:
        api = self.process.start()
        self.kept.clear()
        if self.gui:
            self.add_hook(gui_window.Pacer(self.gui.speed))
        self._reader = SnapshotReader(api, self.dims, self.controlled.lateral_speeds,
                                      self.lanes.sv_lane)
        self.lanes.forget_routes()
        self.lanes.route_id(api, 0)  # the whole route
        self._ensure_type(TV_TYPE, TV_LENGTH, TV_WIDTH, traffic=True)
        return self

    def close(self) -> None:
        """Close SUMO; flush a pending moveToXY first (it would leak into the next run)."""
        api = self.process.api
        if api is None:
            return
        try:
            if self.controlled.moved:
                # closing anyway: only the pending move had to be consumed
                with contextlib.suppress(api.TraCIException):
                    api.simulationStep()
                self.controlled.moved = False
        finally:
            self.process.close()

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
        api = self.process.api
        if api is None:
            raise SimulationError(0.0, "SUMO is not running (use SumoSim as a context manager)")
        return api

    def warnings(self) -> list[str]:
        """SUMO's warnings and errors (SumoProcess.warnings: complete once closed)."""
        return self.process.warnings()

    # ------------------------------------------------------------------ stepping
    @property
    def time(self) -> float:
        """s, simulation time."""
        return float(self.api.simulation.getTime())

    def road(self) -> RoadParams:
        """The planner's road in (s, d) (cosim.traffic.route_lanes.road_params: the lanes'
        width, y_right 0) with the speed bands."""
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
            self.dims.pop(vid, None)
        teleported = set(api.simulation.getStartingTeleportIDList())
        self.reader.left(arrived, untracked=bool(teleported))
        for vid in sorted(teleported):
            self.events.append(TrafficEvent(t, "teleport", vid, "SUMO teleported it"))
        if self.kept:
            self._check_kept(t, teleported, arrived)
        self.reader.cached = None  # read on demand: snapshot() or snapshot_near()
        self.bands.keep(api)
        self.controlled.check(t, teleported)
        for hook in self._hooks:
            hook(self)

    def _check_kept(self, t: float, teleported: set[str], arrived: Sequence[str]) -> None:
        """SimulationError (if `strict`) when SUMO teleported, removed or lost a vehicle of
        `kept` in the last step (an event is recorded either way)."""
        gone = set(arrived)
        for vid in sorted(self.kept):
            if vid in teleported:
                detail = (f"SUMO teleported {vid} (blocked too long; it must never be moved "
                          "off its lane by SUMO)")
            elif vid in gone:
                detail = (f"SUMO removed {vid}: it arrived (the end of its route, or a "
                          "lane it could not leave) before the run's end")
            else:
                try:  # one call: is it still there (an unknown id raises)
                    self.api.vehicle.getLaneID(vid)
                    continue
                except self.api.TraCIException:
                    detail = f"{vid} is no longer in SUMO (removed) before the run's end"
            self.kept.discard(vid)
            self.events.append(TrafficEvent(t, "lost", vid, detail))
            if self.strict:
                raise SimulationError(t, detail)

    # ------------------------------------------------------------------ traffic
    def _ensure_type(self, type_id: str, length: float, width: float, traffic: bool) -> None:
        if type_id in self._types:
            return
        vt = self.api.vehicletype
        vt.copy(BASE_TYPE, type_id)  # SUMO's defaults, whatever their demand defines
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
        self, vehicle_id: str, track: int, s: float, quantile: float, speed: float | None = None
    ) -> None:
        """Insert a TV with its centre at arc length `s` (m) on `track`
        (TrafficVehicles.add)."""
        self.traffic.add(vehicle_id, track, s, quantile, speed)

    def add_driven(
        self, vehicle_id: str, track: int, pose: tuple[float, float, float], speed: float,
        desired_speed: float, length: float, width: float, *, own_lane_changes: bool = True,
    ) -> None:
        """A vehicle SUMO will drive itself (the SV of the 'sumo' baseline): centre `pose`
        (x m, y m, heading rad) on `track`, its own size, no driver imperfection, desired
        speed in m/s.

        It is placed like a controlled vehicle (exactly there, whatever the gaps:
        SUMO's own insertion may refuse or delay a car in dense traffic) and handed
        to SUMO by `controlled.release` after the step that inserts it. own_lane_changes False:
        SUMO makes no lane change of its own (lane-change mode 512: only
        `change_lane` requests, still with SUMO's safety checks).
        """
        type_id = f"driven_{vehicle_id}"
        self._ensure_type(type_id, length, width, traffic=False)
        self.api.vehicletype.setImperfection(type_id, 0.0)
        self.dims[f"type:{type_id}"] = (length, width)
        x, y, heading = pose
        self.add_controlled(vehicle_id, x, y, heading, speed, (length, width), track,
                            vtype=type_id)
        self.controlled.release_modes[vehicle_id] = (float(desired_speed),
                                                     1621 if own_lane_changes else 512)

    def centre_pose(self, track: int, s: float) -> tuple[float, float, float]:
        """(x m, y m, heading rad): the centre of `track`'s lane at arc length `s` (m)."""
        frame = self.lanes.route_road.frame
        x, y, heading = frame.to_cartesian(s, float(self.lanes.table(track).centre(s)))
        return float(x), float(y), float(heading)

    def follow_in_gui(self, vehicle_id: str) -> None:
        """sumo-gui only: keep the main view centred on a vehicle (no-op without GUI)."""
        if self.gui:
            gui_window.follow(self.api, vehicle_id, self.gui)

    def change_lane(self, vehicle_id: str, lane: int, duration: float = 30.0) -> None:
        """Ask SUMO to move a vehicle it drives to track `lane` (an SV lane k is track k;
        keeps trying for `duration` s). SUMO takes the lane index on the vehicle's current
        edge (a junction's lane too) and shifts the request itself wherever the index of
        the vehicle's lane changes on its way (MSVehicle::Influencer::adaptLaneTimeLine),
        so the request follows the track (tests/traffic/test_route_lanes.py)."""
        api = self.api
        piece = self.lanes.table(lane).track.piece_on(str(api.vehicle.getRoadID(vehicle_id)))
        api.vehicle.changeLane(vehicle_id, lane if piece is None else piece.index, duration)

    # ------------------------------------------------------------------ controlled vehicles
    def add_controlled(
        self,
        vehicle_id: str,
        x: float,
        y: float,
        heading: float,
        speed: float,
        size: tuple[float, float],
        lane: int,
        vtype: str = "sv",
    ) -> None:
        """Add a vehicle SUMO does not drive (SV, scripted TV): centre pose, its own size
        (length, width) m, on track `lane` (an SV lane k is track k; ControlledVehicles.add).

        Speed mode 0 and lane-change mode 0 take it out of SUMO's control; the
        pose is written with moveToXY and holds from the next step on.
        """
        length, width = size
        if length <= 0 or width <= 0:
            raise InputError("vehicle", "length/width", (length, width), "positive sizes in m")
        type_id = vtype
        if type_id in self._types and self.dims.get(f"type:{type_id}") != (length, width):
            type_id = f"{vtype}_{vehicle_id}"  # another size: a type of its own
        if type_id not in self._types:
            self._ensure_type(type_id, length, width, traffic=False)
            self.dims[f"type:{type_id}"] = (length, width)
        self.controlled.add(vehicle_id, x, y, heading, speed, size, lane, type_id)
        self.dims[vehicle_id] = (length, width)

    def move(self, vehicle_id: str, x: float, y: float, heading: float, speed: float,
             accel: float | None = None,
             road_pose: tuple[float, float, float] | None = None) -> None:
        """Write a controlled vehicle's centre pose (takes effect in the next step); see
        ControlledVehicles.move (`road_pose`: the pose's s, d, heading to the road)."""
        self.controlled.move(vehicle_id, x, y, heading, speed, accel, road_pose)

    def take_over(self, vehicle_id: str, size: tuple[float, float]) -> tuple[float, float, float]:
        """Take a vehicle SUMO inserted out of its control (ControlledVehicles.take), its
        body now `size` (length, width) m; returns its Cartesian centre pose (x m, y m,
        heading rad) now."""
        x, y, heading = self.reader.pose(vehicle_id)
        length, width = size
        vehicle = self.api.vehicle
        if (vehicle.getLength(vehicle_id), vehicle.getWidth(vehicle_id)) != (length, width):
            vehicle.setLength(vehicle_id, length)
            vehicle.setWidth(vehicle_id, width)
            self.reader.untracked()  # its size changed (the reader's sizes are cached)
        self.dims[vehicle_id] = (length, width)
        self.bands.forget(vehicle_id)  # its speed is ours now, not its lane's band
        self.controlled.take(vehicle_id, x, y, heading, size)
        return x, y, heading

    def hand_back(self, vehicle_id: str) -> None:
        """SUMO drives a vehicle taken over again (ControlledVehicles.hand_back)."""
        self.controlled.hand_back(vehicle_id)

    def set_blinker(self, vehicle_id: str, direction: int) -> None:
        """Blinker of a controlled vehicle: -1 right, +1 left, 0 off (what V2V reads)."""
        self.controlled.set_blinker(vehicle_id, direction)

    def remove(self, vehicle_id: str) -> None:
        """Take a vehicle off the network (controlled or not)."""
        self.api.vehicle.remove(vehicle_id)
        self.kept.discard(vehicle_id)  # asked for: no loss
        self.reader.untracked()
        self.controlled.vehicles.pop(vehicle_id, None)
        self.bands.forget(vehicle_id)

    # ------------------------------------------------------------------ reading
    @property
    def reader(self) -> SnapshotReader:
        if self._reader is None or self.process.api is None:
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
