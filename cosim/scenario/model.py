"""What a scenario is, in SI units: the frozen dataclasses, each attribute declared once
with its file key (unit in the name), range, default and meaning (`declare`).

Tables whose parameters live in cosim.params (vehicle, planner, controller, road) are
declared in cosim.scenario.keys; everything else is declared here, beside its attribute.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.output import NAME_PATTERN  # a folder name: no "", ".", "..", "/"
from cosim.params import ControllerGains, PlannerConfig, RoadParams, VehicleParams
from cosim.traffic.own_demand import OwnDemand
from cosim.validation import REQUIRED, Field, declare, parse_tables, table_to_dict

KMH = 3.6  # si_divisor of a km/h field
MAX_SPEED_KMH = 250.0  # km/h, the highest speed any scenario may name
MAX_LANE = 7  # highest lane index a file may name (8 lanes)
EDGE_PATTERN = r"[^\x00-\x1f]{1,200}"  # a SUMO edge id: any printable text
MAX_ROUTE_EDGES = 1000  # edges in a route


LEAST_TIME_S = 0.001  # s, the shortest scenario.step_s: a time other than 0 is no shorter
LEAST_SPEED_KMH = 0.01  # km/h (2.8 mm/s), the least speed other than 0 that is one
LEAST = {"s": LEAST_TIME_S, "km/h": LEAST_SPEED_KMH}  # by unit: Field.least


def number_key(key: str, unit: str, lo: float | None, hi: float | None, default: Any,
               doc: str, **field: Any) -> Field:
    """A float key, range-checked in the file's unit, a time or speed other than 0 at
    least LEAST of its unit; `field`: more of Field's own settings (lo_open, hi_open,
    si_divisor, override, default_doc)."""
    return Field(key, float, unit=unit, lo=lo, hi=hi, default=default, doc=doc,
                 least=LEAST.get(unit), **field)


def speed_key(key: str, default: Any, doc: str, *, lo_open: bool = True, override: str = "",
          default_doc: str = "") -> Field:
    """A speed key in km/h (SI inside: m/s)."""
    return number_key(key, "km/h", 0.0, MAX_SPEED_KMH, default, doc, lo_open=lo_open,
                  si_divisor=KMH, override=override, default_doc=default_doc)


def parse_paths(source: str, key: str, value: Any, most: int) -> tuple[str, ...]:
    """A list of 1 to `most` file paths (strings), as written."""
    if (not isinstance(value, list) or not 1 <= len(value) <= most
            or not all(isinstance(v, str) and v.strip() and "\x00" not in v and len(v) <= 4096
                       for v in value)):
        raise InputError(source, key, value, f"a list of 1 to {most} file paths (strings)")
    return tuple(value)


def lane_key(key: str, doc: str, override: str = "") -> Field:
    return Field(key, int, lo=0, hi=MAX_LANE, default=REQUIRED, doc=doc, override=override)


@dataclass(frozen=True)
class LaneChangeCommand:
    """A scripted lane-change request for the SV."""

    at: float = declare(number_key("at_s", "s", 0.0, 3600.0, REQUIRED,
                                   "simulation time of the request"))
    # after loading always set, and `direction` None: it is turned into the lane it names
    target_lane: int = declare(Field(
        "target_lane", int, lo=0, hi=MAX_LANE, default=None,
        doc="lane to change to, next to the SV's lane then (or `direction`)",
        default_doc="from `direction`"))
    direction: str | None = declare(Field(
        "direction", str, choices=("left", "right"), default=None,
        doc="the lane left or right of the SV's lane then, instead of `target_lane`",
        default_doc="`target_lane`"), default=None)


@dataclass(frozen=True)
class TVLaneChange:
    """A scripted lane change of a traffic vehicle."""

    start: float = declare(number_key(
        "start_s", "s", -60.0, 3600.0, REQUIRED,
        "time the change starts (negative: already under way at t = 0)"))
    target_lane: int = declare(lane_key("target_lane", "lane it changes to, next to its own"))
    tau: float = declare(number_key("tau_s", "s", 0.0, 60.0, REQUIRED, "duration of the change",
                                lo_open=True))
    target_speed: float | None = declare(speed_key(
        "target_speed_kmh", None, "speed at the end of the change",
        default_doc="the band rule"))
    broadcast: str = declare(Field(
        "broadcast", str, choices=("reference", "intention", "none"), default="reference",
        doc="what it tells the SV: its reference (C3), its intention (C2), nothing (C1)"))


@dataclass(frozen=True)
class TVBrake:
    """A scripted braking event of a traffic vehicle in its lane."""

    at: float = declare(number_key("at_s", "s", 0.0, 3600.0, REQUIRED, "time the braking starts"))
    decel: float = declare(number_key("decel_mps2", "m/s^2", 0.0, 15.0, REQUIRED,
                                  "deceleration, held until it stands still", lo_open=True))
    hold: float | None = declare(number_key(
        "hold_s", "s", 0.0, 3600.0, None, "time at rest before driving off again",
        default_doc="none: it stays stopped"), None)
    restart_accel: float | None = declare(number_key(
        "restart_accel_mps2", "m/s^2", 0.0, 10.0, None, "acceleration when driving off",
        lo_open=True, default_doc="`1.5`"), None)
    restart_speed: float | None = declare(speed_key(
        "restart_speed_kmh", None, "speed it drives off to",
        default_doc="its `speed_kmh`"), None)


def _export_nested(cls: type) -> Any:
    def export(value: Any) -> Any:
        if value is None:
            return None
        if isinstance(value, tuple):
            return [table_to_dict(cls, v) for v in value]
        return table_to_dict(cls, value)

    return export


def _sub_table(cls: type, key: str, describe: str, doc: str, *, many: int = 0) -> Field:
    """A key holding a table (or, `many` > 0, a list of at most `many` tables) of `cls`."""

    def parse(source: str, dotted: str, value: Any) -> Any:
        return parse_tables(source, dotted, value, cls, many)

    return Field(key, list if many else dict, default=() if many else None, parse=parse,
                 describe=describe, doc=doc, export=_export_nested(cls),
                 default_doc="`[]`" if many else "")


VEHICLE = VehicleParams()


@dataclass(frozen=True)
class SVSpec:
    """The subject vehicle at t = 0 and what it is asked to do."""

    lane: int = declare(lane_key("lane", "SUMO lane index at t = 0 on `sv.edge` (0 = "
                                 "rightmost, slowest)", override="sv_lane"))
    edge: str | None = declare(Field(
        "edge", str, pattern=EDGE_PATTERN, default=None,
        describe="a SUMO edge id (1 to 200 printable characters)",
        doc="SUMO edge of `road.route` the SV starts on", default_doc="the route's first edge"))
    position: float = declare(number_key(
        "position_m", "m", 0.0, 1e6, REQUIRED,
        "lane position of the SV's centre on `sv.edge` at t = 0 (on a one-edge road: its "
        "distance from the start of the road)",
        override="sv_position"))
    speed: float = declare(speed_key("speed_kmh", REQUIRED, "speed at t = 0", override="sv_speed"))
    occupant: float = declare(number_key(
        "occupant", "", 0.0, 1.0, 0.5,
        "occupant type p (0 most conservative, 1 most aggressive)", override="occupant"))
    plant: str = declare(Field("plant", str, choices=("twotrack", "bicycle"), default="twotrack",
                               doc="vehicle model", override="plant"))
    controller: str = declare(Field(
        "controller", str, choices=("mimo", "siso", "sumo"), default="mimo",
        doc="mimo / siso: our planner and controller; sumo: SUMO drives the SV",
        override="controller"))
    lane_changes: tuple[LaneChangeCommand, ...] = declare(_sub_table(
        LaneChangeCommand, "lane_changes", "a list of {at_s, target_lane} tables",
        "scripted lane-change requests, in time order", many=64))
    decision: bool = declare(Field(
        "decision", bool, default=False, override="decision",
        doc="change lanes by the traffic rule (leader slower, faster lane free)"))
    desired_speed: float | None = declare(speed_key(
        "desired_speed_kmh", None, "speed the SV wants in traffic", override="desired_speed",
        default_doc="its lane's maximum"))
    curve_lat_accel: float = declare(number_key(
        "curve_lat_accel_mps2", "m/s^2", 0.0, 10.0, 2.0,
        "comfortable lateral acceleration in curves: the SV drives a curved route at most at "
        "sqrt(a / kappa) of its tightest curve (at most half the road's friction; "
        "cosim.driving.curve_speed)", lo_open=True, override="curve_lat_accel"))


@dataclass(frozen=True)
class TVSpec:
    """A scripted traffic vehicle, placed relative to the SV."""

    id: str = declare(Field("id", str, pattern=r"[A-Za-z0-9_.\-]{1,40}", default=REQUIRED,
                            doc="SUMO vehicle id (not 'sv'; not tv<number> with random traffic)"))
    lane: int = declare(lane_key("lane", "SUMO lane index (before any lane change)"))
    gap: float = declare(number_key("gap_m", "m", -1e5, 1e5, REQUIRED,
                                "centre-to-centre distance along the road, + ahead of the SV, "
                                "at t = 0"))
    speed: float = declare(speed_key("speed_kmh", REQUIRED, "speed (before any lane change)",
                                 lo_open=False))
    accel: float = declare(number_key("accel_mps2", "m/s^2", -10.0, 10.0, 0.0, "acceleration"))
    length: float = declare(number_key("length_m", "m", 1.0, 30.0, VEHICLE.length, "body length"))
    width: float = declare(number_key("width_m", "m", 0.5, 4.0, VEHICLE.width, "body width"))
    lane_change: TVLaneChange | None = declare(_sub_table(
        TVLaneChange, "lane_change", "a table {start_s, target_lane, tau_s, ...}",
        "its scripted lane change"))
    brake: TVBrake | None = declare(_sub_table(
        TVBrake, "brake", "a table {at_s, decel_mps2}", "its scripted hard braking"), None)


@dataclass(frozen=True)
class TrafficSpec:
    """Random SUMO traffic around the scripted vehicles."""

    density: float = declare(number_key(
        "density_veh_per_km_lane", "veh/km/lane", 0.0, 150.0, 0.0,
        "random traffic (0: none)", override="density"))
    lanechange_duration: float = declare(number_key(
        "lanechange_duration_s", "s", 0.0, 20.0, None,
        "SUMO --lanechange.duration of the traffic (0: instant)",
        override="lanechange_duration", default_doc="`3.0` (`0` with sublane)"))
    sublane: bool = declare(Field("sublane", bool, default=False, override="sublane",
                                  doc="SUMO's sublane model (--lateral-resolution) instead"))
    length: float = declare(number_key(
        "length_m", "m", 0.0, 1e5, 1000.0,
        "stretch of road (from its start) the traffic is placed on at t = 0, "
        "at most the network's length", lo_open=True, override="traffic_length"))
    courtesy: bool = declare(Field(
        "courtesy", bool, default=True, override="courtesy",
        doc="target-lane TVs make room for the signalling SV of the gap policy, as SUMO's "
            "traffic does for its own lane changers (cosim.traffic.cooperation)"), True)
    ramp_flow: float = declare(number_key(
        "ramp_flow_veh_per_h", "veh/h", 0.0, 3600.0, 0.0,
        "SUMO-driven traffic from each on-ramp of the route (an edge off it feeding a lane "
        "that begins or ends on it: an acceleration lane), then along the rest of the route "
        "(0: none; cosim.traffic.demand.RampFlow)", override="ramp_flow"), 0.0)
    # the user's own SUMO demand (cosim.traffic.own_demand): absolute paths
    # once loaded (cosim.scenario.load), as the file wrote them before
    routes: tuple[str, ...] | None = declare(Field(
        "routes", list, default=None, parse=lambda src, key, v: parse_paths(src, key, v, 64),
        export=list, describe="a list of 1 to 64 paths of SUMO route files (.rou.xml)",
        default_doc="none: cosim's random traffic only",
        doc="SUMO route / flow / vType files, their demand used as it is (docs/roads.md, "
            "\"Running cosim in your own SUMO scenario\"), relative to the file, then the "
            "project root; with them density_veh_per_km_lane must be 0 (their traffic only)"), None)
    warmup: float | None = declare(number_key(
        "warmup_s", "s", 0.0, 3600.0, None,
        "SUMO runs the user's demand (`routes`, `road.sumocfg`) alone this long before the "
        "SV enters; the run's t = 0 is the SV's entry", default_doc="`0`"), None)


@dataclass(frozen=True)
class V2VSpec:
    """How TV messages reach the SV."""

    range: float = declare(number_key("range_m", "m", 0.0, 1e4, 300.0,
                                  "radius within which messages arrive", override="v2v_range"))
    latency: float = declare(number_key("latency_s", "s", 0.0, 10.0, 0.0, "delay of every message",
                                    override="latency"))
    loss: float = declare(number_key("loss", "", 0.0, 1.0, 0.0,
                                 "probability that a message is lost", override="loss"))
    mode: str = declare(Field("mode", str, choices=("v2v", "perception"), default="v2v",
                              doc="messages (v2v) or measured states (perception)",
                              override="v2v_mode"))
    noise_position: float = declare(number_key(
        "noise_position_m", "m", 0.0, 10.0, 0.2, "perception: sd of measured x and y"), 0.2)
    noise_heading: float = declare(number_key(
        "noise_heading_rad", "rad", 0.0, 1.0, 0.01, "perception: sd of measured heading"), 0.01)
    noise_speed: float = declare(number_key(
        "noise_speed_mps", "m/s", 0.0, 10.0, 0.2, "perception: sd of measured speed"), 0.2)
    noise_accel: float = declare(number_key(
        "noise_accel_mps2", "m/s^2", 0.0, 10.0, 0.3,
        "perception: sd of measured acceleration"), 0.3)
    noise_lateral_speed: float = declare(number_key(
        "noise_lateral_speed_mps", "m/s", 0.0, 10.0, 0.1,
        "perception: sd of measured lateral speed"), 0.1)
    # cooperative V2V (gap policy; cosim.traffic.cooperation): the SV asks a TV to yield
    cooperation: bool = declare(Field(
        "cooperation", bool, default=False, override="cooperation",
        doc="the SV sends gap requests to target-lane TVs (gap policy)"), False)
    cooperation_compliance: float = declare(number_key(
        "cooperation_compliance", "", 0.0, 1.0, 1.0,
        "probability that a TV honours a gap request", override="cooperation_compliance"), 1.0)
    cooperation_latency: float = declare(number_key(
        "cooperation_latency_s", "s", 0.0, 10.0, 0.1,
        "from a gap request to the TV's reaction", override="cooperation_latency"), 0.1)


MAX_DETECTOR_POSITIONS = 1000  # [detectors] positions_m
# [detectors] areas: one lane-area detector per SUMO lane, or per stretch between loops
AREAS = ("none", "lanes", "stretches")


def _parse_positions(source: str, key: str, value: Any) -> tuple[float, ...]:
    """A list of positions along the route (m, s from the route's start), as written;
    the route's extent is checked with the network (cosim.scenario.load)."""
    if (not isinstance(value, list) or len(value) > MAX_DETECTOR_POSITIONS
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                       and math.isfinite(v) and v >= 0 for v in value)):
        raise InputError(source, key, value,
                         f"a list of at most {MAX_DETECTOR_POSITIONS} positions along the "
                         "route in m (finite numbers >= 0)")
    return tuple(float(v) for v in value)


@dataclass(frozen=True)
class DetectorSpec:
    """SUMO's own detectors along the SV's route (cosim.traffic.detectors): induction
    loops and lane-area detectors on the SV's lanes, written into detectors.csv."""

    enabled: bool = declare(Field(
        "enabled", bool, default=False,
        doc="place SUMO's induction loops (E1), and lane-area detectors (E2) as `areas` "
            "says, on every SV lane of the route; `cosim run` writes their measures to "
            "detectors.csv (docs/outputs.md)"), False)
    spacing: float = declare(number_key(
        "spacing_m", "m", 10.0, 1e5, 500.0,
        "distance along the route between induction loops (at s = 0, spacing, 2 spacing, "
        "..., and a few metres inside the start and the end of each lane that ends)"),
        500.0)
    areas: str = declare(Field(
        "areas", str, choices=AREAS, default="none",
        doc="lane-area detectors (E2: density and space-mean speed, and metrics.csv's "
            "traffic density and speed): `none`; `lanes`, one over each SUMO lane of an "
            "SV lane from its first loop to its last; `stretches`, one over each stretch "
            "between two loops on one SUMO lane. They cost: on a dense run about 10 % "
            "(`lanes`) and 25-35 % (`stretches`) more CPU, the loops alone 2-8 % "
            "(`cosim bench measures`)"), "none")
    period: float = declare(number_key(
        "period_s", "s", 0.0, 3600.0, 60.0,
        "aggregation period of every detector (a whole multiple of scenario.step_s)",
        lo_open=True), 60.0)
    measure_from: float = declare(number_key(
        "measure_from_s", "s", 0.0, 1e5, 0.0,
        "metrics.csv's traffic columns (flow, density, speed, spread, outflow) count only "
        "the periods that begin at or after this time on the run's clock, leaving out the "
        "start's transient; detectors.csv keeps every period"), 0.0)
    positions: tuple[float, ...] = declare(Field(
        "positions_m", list, default=(), parse=_parse_positions, export=list,
        describe=f"a list of at most {MAX_DETECTOR_POSITIONS} positions along the route in m",
        default_doc="`[]`",
        doc="more induction loops, at these positions s along the route (m from its start, "
            "within the SV lanes' extent), on every SV lane there"), ())


MAX_FLEET_VTYPES = 64  # [fleet] vtypes
FLEET_DRIVERS = ("cosim", "sumo", "acc", "cacc")  # [fleet] driver (cosim.run.fleet_watch)
VTYPE_ID_PATTERN = r"[^\s\x00-\x1f]{1,100}"  # a SUMO vType id as a file names it


def _parse_vtypes(source: str, key: str, value: Any) -> tuple[str, ...]:
    """A list of distinct vType ids, as written."""
    import re

    if (not isinstance(value, list) or len(value) > MAX_FLEET_VTYPES
            or not all(isinstance(v, str) and re.fullmatch(VTYPE_ID_PATTERN, v) for v in value)
            or len(set(value)) != len(value)):
        raise InputError(source, key, value,
                         f"a list of at most {MAX_FLEET_VTYPES} distinct vType ids (1 to 100 "
                         "characters, no spaces)")
    return tuple(value)


@dataclass(frozen=True)
class FleetSpec:
    """Automated vehicles besides the SV (cosim.run.fleet): vehicles SUMO inserts during
    the run, taken over by the scenario's driver. None by default."""

    share: float = declare(number_key(
        "share", "", 0.0, 1.0, 0.0,
        "probability that a vehicle SUMO inserts during the run (after t = 0) is automated, "
        "drawn per vehicle in SUMO's insertion order from the run's seed (0: none)",
        override="share"), 0.0)
    vtypes: tuple[str, ...] = declare(Field(
        "vtypes", list, default=(), parse=_parse_vtypes, export=list,
        describe=f"a list of at most {MAX_FLEET_VTYPES} vType ids",
        default_doc="`[]`",
        doc="every vehicle of these vTypes in the user's own demand (`traffic.routes`, "
            "`road.sumocfg`) that SUMO inserts during the run is automated"), ())
    max_vehicles: int | None = declare(Field(
        "max_vehicles", int, lo=1, hi=100000, default=None,
        doc="at most this many automated vehicles at once: one drawn while as many drive "
            "(or wait for their takeover) stays SUMO's (its draw still made: the same seed "
            "draws the same vehicles); with `share = 1` the fleet keeps this many",
        default_doc="none: no limit"), None)
    driver: str = declare(Field(
        "driver", str, choices=FLEET_DRIVERS, default="cosim", override="fleet_driver",
        doc="who drives the vehicles drawn automated: `cosim` (the scenario's driver, "
            "re-checking its lane change under way whatever `planner.replanning` says) or a "
            "baseline at the same share, the same vehicles: `sumo` (SUMO's own driver, "
            "only marked), `acc` / `cacc` (SUMO with its ACC / CACC car-following model: "
            "their vType switched to a copy with it); each measured alike in fleet.csv "
            "(docs/traffic_flow.md)"), "cosim")

    @property
    def enabled(self) -> bool:
        """Some vehicle may be automated."""
        return self.share > 0.0 or bool(self.vtypes)

SSM_VEHICLES = ("all", "sv", "fleet")  # [ssm] vehicles: who carries SUMO's SSM device


@dataclass(frozen=True)
class SsmSpec:
    """SUMO's surrogate safety measures device (cosim.traffic.ssm): TTC, DRAC and PET of
    every encounter, written into conflicts.csv, counted in metrics.csv."""

    enabled: bool = declare(Field(
        "enabled", bool, default=False,
        doc="SUMO's SSM device logs each conflict (an encounter passing a threshold "
            "below); `cosim run` writes them to conflicts.csv and counts them in "
            "metrics.csv (docs/outputs.md)"), False)
    ttc: float = declare(number_key(
        "ttc_s", "s", 0.0, 60.0, 1.5,
        "a conflict when the time-to-collision falls below this", lo_open=True), 1.5)
    pet: float = declare(number_key(
        "pet_s", "s", 0.0, 60.0, 1.0,
        "a conflict when the post-encroachment time falls below this (where paths "
        "cross or merge)", lo_open=True), 1.0)
    drac: float = declare(number_key(
        "drac_mps2", "m/s^2", 0.0, 100.0, 3.35,
        "a conflict when the deceleration to avoid the crash rises above this",
        lo_open=True), 3.35)
    vehicles: str = declare(Field(
        "vehicles", str, choices=SSM_VEHICLES, default="all",
        doc="who carries the device: `all` (every vehicle's encounters), `sv` (the SV "
            "alone: its encounters with every vehicle within `range_m`, its neighbours) or "
            "`fleet` (the SV and every vehicle of `fleet.vtypes`, the automated vehicles: "
            "their encounters with their neighbours; needs `fleet.vtypes`: SUMO builds a "
            "vehicle's device with the vehicle, before a `fleet.share` draw); on every "
            "vehicle the device multiplies a dense run's CPU by 1.8-2.6, on the SV alone "
            "or on the SV and the fleet it costs nothing measurable: `cosim bench "
            "measures`)"), "all")
    range: float = declare(number_key(
        "range_m", "m", 1.0, 1000.0, 50.0,
        "how far from a device's vehicle SUMO looks for encounters (SUMO's "
        "device.ssm.range)"), 50.0)

DEFAULT_STEP = 0.05  # s, SUMO step
DEFAULT_SUBSTEPS = 10  # plant/controller substeps per SUMO step
class OnCollision(StrEnum):
    """What a run does at its first collision onset."""

    STOP = "stop"  # a crash ends the ride: the SV never drives on through its leader
    CONTINUE = "continue"  # the run goes on (for cross-checks)


ON_COLLISION = tuple(o.value for o in OnCollision)


@dataclass(frozen=True)
class Scenario:
    """A validated scenario, SI units throughout. The [scenario] table's keys are declared
    on its first attributes; the others hold the other tables."""

    name: str = declare(Field("name", str, default=None, pattern=NAME_PATTERN,
                              describe=f"a folder name matching {NAME_PATTERN} (not '', '.', "
                                       "'..' or a path)",
                              doc="names the output folder results/<name>", override="name",
                              default_doc="the file's stem"))
    description: str = declare(Field("description", str, default="", doc="free text",
                                     override="description"))
    duration: float = declare(number_key("duration_s", "s", 0.0, 3600.0, REQUIRED,
                                     "simulated time", lo_open=True, override="duration"))
    step: float = declare(number_key("step_s", "s", 0.001, 1.0, DEFAULT_STEP, "SUMO step",
                                 override="step"))
    substeps: int = declare(Field("substeps", int, lo=1, hi=1000, default=DEFAULT_SUBSTEPS,
                                  doc="plant/controller substeps per SUMO step",
                                  override="substeps"))
    seed: int = declare(Field("seed", int, lo=0, hi=2**31 - 1, default=0,
                              doc="SUMO and traffic seed", override="seed"))
    on_collision: str = declare(Field(
        "on_collision", str, choices=ON_COLLISION, default="stop",
        doc="at our check's first collision onset: stop the run there (outputs written, "
            "metrics `collision_t_s`, `stopped_by_collision`), or continue to the end",
        override="on_collision"))
    path: Path  # the scenario file (absolute)
    road: RoadParams  # lane width and y from the network, bands and mu from the file
    network: Path  # .net.xml (absolute)
    vehicle: VehicleParams
    gains: ControllerGains
    planner: PlannerConfig
    sv: SVSpec
    tvs: tuple[TVSpec, ...]
    traffic: TrafficSpec
    v2v: V2VSpec
    # The document as read (file units), so overrides re-validate the very same input.
    document: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    # [road] route: the SUMO edges the SV drives, as the file gives them (None: absent,
    # the network's one edge); checked against the network by cosim.scenario.load
    route: tuple[str, ...] | None = None
    # [road] sumocfg (absolute; None: absent), the network being its net-file, and the
    # user's demand SUMO loads with cosim's own (cosim.traffic.own_demand; None: none)
    sumocfg: Path | None = None
    demand: OwnDemand | None = None
    # [detectors]: SUMO's detectors along the route (off by default)
    detectors: DetectorSpec = field(default_factory=DetectorSpec)
    # [fleet]: automated vehicles besides the SV (none by default)
    fleet: FleetSpec = field(default_factory=FleetSpec)

    # [ssm]: SUMO's surrogate safety measures device (off by default)
    ssm: SsmSpec = field(default_factory=SsmSpec)

    @property
    def n_steps(self) -> int:
        """Number of SUMO steps in `duration`."""
        return int(round(self.duration / self.step))

    def in_tracks(self, sv_track: int) -> Scenario:
        """This scenario with its lanes as the run counts them, the route's tracks: [sv]
        lane, its lane_changes' and the scripted TVs' lanes are SUMO's indices on [sv]
        edge, which differ from the track ids by a lane added on the right before that
        edge (`sv_track`: the SV's track there). Itself when they agree, as on every
        one-edge road."""
        shift = sv_track - self.sv.lane
        if shift == 0:
            return self
        changes = tuple(replace(c, target_lane=c.target_lane + shift)
                        for c in self.sv.lane_changes)
        tvs = tuple(replace(tv, lane=tv.lane + shift, lane_change=None
                            if tv.lane_change is None else replace(
                                tv.lane_change, target_lane=tv.lane_change.target_lane + shift))
                    for tv in self.tvs)
        return replace(self, sv=replace(self.sv, lane=sv_track, lane_changes=changes), tvs=tvs)
