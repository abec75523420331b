"""Scenario files (TOML): load, validate, override, export.

`load_scenario(path)` reads a scenario file and returns a `Scenario` in SI
units, or raises `InputError` (file, key, value, what is allowed; one line)
before anything runs. Keys in the file carry their unit (`speed_kmh`,
`gap_m`, `duration_s`); lanes are SUMO indices (0 = rightmost, slowest; the
paper's Lane 1/2/3 are SUMO lanes 0/1/2).

Tables: [scenario] [road] [sv] [planner] [vehicle] [controller] [[tv]]
(with an optional [tv.lane_change]) [traffic] [v2v]. Each key is declared once
as a `Field` (cosim.validation); cross-field rules (lanes that exist, adjacent
target lanes, duration a multiple of the step, the SV's speed inside its lane's
band when the method requires it, a network file that is a SUMO net and long
enough) are checked after the tables.

`with_overrides(scenario, **changes)` re-validates the scenario's own document
with some keys changed (batch studies); `scenario_to_dict(scenario)` gives the
complete, validated scenario as a JSON-able dict shaped like the file.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.params import (
    VEHICLE_PRESETS,
    ControllerGains,
    PlannerConfig,
    RoadParams,
    VehicleParams,
    vehicle_from_table,
)
from cosim.planning.collision import COLLISION_TESTS  # the planner owns its option names
from cosim.planning.envelope import ENVELOPES
from cosim.validation import (
    MISSING,
    REQUIRED,
    Field,
    check_known_tables,
    check_table,
    suggest,
    validate_table,
)

__all__ = [
    "Field",
    "LaneChangeCommand",
    "SVSpec",
    "Scenario",
    "TVBrake",
    "TVLaneChange",
    "TVSpec",
    "TrafficSpec",
    "V2VSpec",
    "load_scenario",
    "project_root",
    "scenario_from_dict",
    "scenario_to_dict",
    "validate_table",
    "with_overrides",
]

KMH = 3.6  # si_divisor of a km/h field
MAX_SPEED_KMH = 250.0  # km/h, the highest speed any scenario may name
DEFAULT_NETWORK = "networks/highway.net.xml"  # relative to the project root
DEFAULT_STEP = 0.05  # s, SUMO step
DEFAULT_SUBSTEPS = 10  # plant/controller substeps per SUMO step
# s, continuous TV lane changes (SUMO_NOTES: the default instant change is a 3.5 m jump)
DEFAULT_LANECHANGE_DURATION = 3.0
STEP_TOLERANCE = 1e-9  # relative, "duration is a multiple of the step"
_VEH = VehicleParams()
_PLAN = PlannerConfig()
_GAINS = ControllerGains()
_ROAD = RoadParams()


# ---------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class LaneChangeCommand:
    """A scripted lane-change request for the SV."""

    at: float  # s, simulation time of the request
    target_lane: int  # SUMO index, adjacent to the lane the SV is in at that time


@dataclass(frozen=True)
class SVSpec:
    """The subject vehicle at t = 0 and what it is asked to do."""

    lane: int  # SUMO index, 0 = rightmost/slowest
    position: float  # m, along-road position of its centre at t = 0
    speed: float  # m/s at t = 0
    occupant: float  # -, p in [0, 1] (0 most conservative, 1 most aggressive)
    plant: str  # "twotrack" | "bicycle"
    controller: str  # "mimo" | "siso" | "sumo"
    lane_changes: tuple[LaneChangeCommand, ...]  # scripted requests, in time order
    decision: bool  # use the traffic decision rule (leader slower, faster lane free)
    desired_speed: float | None  # m/s the SV wants in traffic (None: its lane's max)


@dataclass(frozen=True)
class TVLaneChange:
    """A scripted lane change of a traffic vehicle."""

    start: float  # s, sim time it starts (negative: already under way at t = 0)
    target_lane: int  # SUMO index, adjacent to the TV's lane
    tau: float  # s, its duration
    target_speed: float | None  # m/s (None: the band rule, RoadParams.target_speed)
    broadcast: str  # "reference" (C3 once moving; C2 before) | "intention" (C2) | "none" (C1)


@dataclass(frozen=True)
class TVBrake:
    """A scripted braking event of a traffic vehicle in its lane."""

    at: float  # s, sim time the braking starts
    decel: float  # m/s^2, > 0, held until the TV stands still


@dataclass(frozen=True)
class TVSpec:
    """A scripted traffic vehicle, placed relative to the SV."""

    id: str
    lane: int  # SUMO index
    gap: float  # m, centre-to-centre along the road, + ahead of the SV, at t = 0
    speed: float  # m/s (before any lane change)
    accel: float  # m/s^2
    length: float  # m
    width: float  # m
    lane_change: TVLaneChange | None
    brake: TVBrake | None = None  # scripted hard braking (beyond the paper)


@dataclass(frozen=True)
class TrafficSpec:
    """Random SUMO traffic around the scripted vehicles."""

    density: float  # veh per km per lane (0: no random traffic)
    # s, SUMO --lanechange.duration (0: instant lane changes); default 3 s, 0 with sublane
    lanechange_duration: float
    sublane: bool  # use SUMO's --lateral-resolution instead
    length: float  # m, stretch of road the traffic is placed on at start


@dataclass(frozen=True)
class V2VSpec:
    """How TV messages reach the SV."""

    range: float  # m, radius within which messages arrive
    latency: float  # s, delay of every message
    loss: float  # -, probability in [0, 1] that a message is lost
    mode: str  # "v2v" | "perception"
    noise_position: float = 0.2  # m, perception: sd of measured x and y
    noise_heading: float = 0.01  # rad, perception: sd of measured heading
    noise_speed: float = 0.2  # m/s, perception: sd of measured speed
    noise_accel: float = 0.3  # m/s^2, perception: sd of measured acceleration
    noise_lateral_speed: float = 0.1  # m/s, perception: sd of measured lateral speed


@dataclass(frozen=True)
class Scenario:
    """A validated scenario, SI units throughout."""

    path: Path  # the scenario file (absolute)
    name: str
    description: str
    duration: float  # s, simulated time
    step: float  # s, SUMO step
    substeps: int  # plant/controller substeps per SUMO step
    seed: int
    road: RoadParams
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

    @property
    def n_steps(self) -> int:
        """Number of SUMO steps in `duration`."""
        return int(round(self.duration / self.step))


# ---------------------------------------------------------------- field specs


def _f(
    key: str,
    name: str,
    unit: str,
    lo: float | None,
    hi: float | None,
    default: Any,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    si_divisor: float = 1.0,
) -> Field:
    return Field(
        key,
        float,
        name=name,
        unit=unit,
        lo=lo,
        hi=hi,
        default=default,
        lo_open=lo_open,
        hi_open=hi_open,
        si_divisor=si_divisor,
    )


def _speed(key: str, name: str, default: Any, lo: float = 0.0, lo_open: bool = True) -> Field:
    return _f(key, name, "km/h", lo, MAX_SPEED_KMH, default, lo_open=lo_open, si_divisor=KMH)


def _parse_bands(source: str, key: str, value: Any) -> tuple[tuple[float, float], ...]:
    allowed = (
        "a list of 1 to 8 [min, max] speed bands in km/h, one per lane from lane 0 up, "
        f"0 <= min < max <= {MAX_SPEED_KMH:g}, mins not decreasing"
    )
    if not isinstance(value, list) or not 1 <= len(value) <= 8:
        raise InputError(source, key, value, allowed)
    bands: list[tuple[float, float]] = []
    for k, band in enumerate(value):
        ok = (
            isinstance(band, list)
            and len(band) == 2
            and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in band
            )
        )
        if not ok or not 0 <= band[0] < band[1] <= MAX_SPEED_KMH:
            raise InputError(source, f"{key}[{k}]", band, allowed)
        if bands and band[0] * 1.0 / KMH < bands[-1][0]:
            raise InputError(source, f"{key}[{k}]", band, allowed)
        bands.append((band[0] / KMH, band[1] / KMH))
    return tuple(bands)


def _parse_network(source: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip() or "\x00" in value or len(value) > 4096:
        raise InputError(source, key, value, "the path of a SUMO .net.xml file")
    return value


SCENARIO_FIELDS = (
    Field("name", str, default=None, pattern=r"[A-Za-z0-9_.\-]{1,80}"),
    Field("description", str, default=""),
    _f("duration_s", "duration", "s", 0.0, 3600.0, REQUIRED, lo_open=True),
    _f("step_s", "step", "s", 0.001, 1.0, DEFAULT_STEP),
    Field("substeps", int, lo=1, hi=1000, default=DEFAULT_SUBSTEPS),
    Field("seed", int, lo=0, hi=2**31 - 1, default=0),
)

ROAD_FIELDS = (
    _f("lane_width_m", "lane_width", "m", 2.0, 6.0, _ROAD.lane_width),
    Field(
        "lane_speeds_kmh",
        list,
        name="speed_bands",
        default=_ROAD.speed_bands,
        parse=_parse_bands,
        describe="a list of [min, max] km/h per lane",
    ),
    _f("mu", "mu", "", 0.1, 1.2, _ROAD.mu),
    Field(
        "network",
        str,
        default=DEFAULT_NETWORK,
        parse=_parse_network,
        describe="the path of a SUMO .net.xml file",
    ),
)

SV_FIELDS = (
    Field("lane", int, lo=0, hi=7, default=REQUIRED),
    _f("position_m", "position", "m", -1e6, 1e6, REQUIRED),
    _speed("speed_kmh", "speed", REQUIRED),
    _f("occupant", "occupant", "", 0.0, 1.0, 0.5),
    Field("plant", str, choices=("twotrack", "bicycle"), default="twotrack"),
    Field("controller", str, choices=("mimo", "siso", "sumo"), default="mimo"),
    Field("decision", bool, default=False),
    _speed("desired_speed_kmh", "desired_speed", None),
    Field(
        "lane_changes",
        list,
        default=(),
        describe="a list of {at_s, target_lane} tables",
        parse=lambda s, k, v: _parse_table_list(s, k, v, LANE_CHANGE_FIELDS, 64),
    ),
)

LANE_CHANGE_FIELDS = (
    _f("at_s", "at", "s", 0.0, 3600.0, REQUIRED),
    Field("target_lane", int, lo=0, hi=7, default=REQUIRED),
)

PLANNER_FIELDS = (
    _f("tau_max_s", "tau_max", "s", 0.0, 60.0, _PLAN.tau_max, lo_open=True),
    _f("tau_step_s", "tau_step", "s", 0.0, 1.0, _PLAN.tau_step, lo_open=True),
    Field("envelope", str, choices=ENVELOPES, default=_PLAN.envelope),
    _f("safety_factor", "safety_factor", "", 0.0, 1.0, _PLAN.safety_factor, lo_open=True),
    Field("collision_test", str, choices=COLLISION_TESTS, default=_PLAN.collision_test),
    _f("safety_margin_m", "safety_margin", "m", 0.0, 5.0, _PLAN.safety_margin),
    _f("horizon_extra_s", "horizon_extra", "s", 0.0, 60.0, _PLAN.horizon_extra),
    _f("tau_min_floor_s", "tau_min_floor", "s", 0.0, 60.0, _PLAN.tau_min_floor, lo_open=True),
    Field("replanning", bool, default=_PLAN.replanning),
    _f("recheck_interval_s", "recheck_interval", "s", 0.0, 10.0, _PLAN.recheck_interval,
       lo_open=True),
    Field("uncertainty_margin", bool, default=_PLAN.uncertainty_margin),
)

VEHICLE_FIELDS = (
    # a known car (cosim.params.VEHICLE_PRESETS); the keys below the file gives override it
    Field("preset", str, choices=tuple(VEHICLE_PRESETS), default="table1"),
    _f("mass_kg", "mass", "kg", 100.0, 1e5, _VEH.mass),
    _f("yaw_inertia_kg_m2", "yaw_inertia", "kg m^2", 10.0, 1e6, _VEH.yaw_inertia),
    _f("lf_m", "lf", "m", 0.1, 10.0, _VEH.lf),
    _f("lr_m", "lr", "m", 0.1, 10.0, _VEH.lr),
    _f("half_track_m", "half_track", "m", 0.1, 2.0, _VEH.half_track),
    _f("drag_n_s2_per_m2", "drag", "N s^2/m^2", 0.0, 10.0, _VEH.drag),
    _f("cf_n_per_rad", "cf", "N/rad", 1e3, 1e7, _VEH.cf),
    _f("cr_n_per_rad", "cr", "N/rad", 1e3, 1e7, _VEH.cr),
    _f("length_m", "length", "m", 1.0, 30.0, _VEH.length),
    _f("width_m", "width", "m", 0.5, 4.0, _VEH.width),
)

_GAIN_UNITS = {
    "ky0": "1/s^2",
    "kphi0": "1/s^2",
    "kyI": "1/s^3",
    "kphiI": "1/s^3",
    "ky1": "1/s",
    "kphi1": "1/s",
    "kx1": "1/s",
}
CONTROLLER_FIELDS = tuple(
    _f(name, name, unit, 0.0, 1e6, getattr(_GAINS, name), lo_open=True)
    for name, unit in _GAIN_UNITS.items()
) + (_f("allocation_eps", "allocation_eps", "", 0.0, 1.0, _GAINS.allocation_eps, lo_open=True),)

TV_FIELDS = (
    Field("id", str, pattern=r"[A-Za-z0-9_.\-]{1,40}", default=REQUIRED),
    Field("lane", int, lo=0, hi=7, default=REQUIRED),
    _f("gap_m", "gap", "m", -1e5, 1e5, REQUIRED),
    _speed("speed_kmh", "speed", REQUIRED, lo_open=False),
    _f("accel_mps2", "accel", "m/s^2", -10.0, 10.0, 0.0),
    _f("length_m", "length", "m", 1.0, 30.0, _VEH.length),
    _f("width_m", "width", "m", 0.5, 4.0, _VEH.width),
    Field(
        "lane_change",
        dict,
        default=None,
        describe="a table {start_s, target_lane, tau_s, ...}",
        parse=lambda s, k, v: validate_table(s, k, v, TV_LANE_CHANGE_FIELDS),
    ),
    Field(
        "brake",
        dict,
        default=None,
        describe="a table {at_s, decel_mps2}",
        parse=lambda s, k, v: validate_table(s, k, v, TV_BRAKE_FIELDS),
    ),
)

TV_BRAKE_FIELDS = (
    _f("at_s", "at", "s", 0.0, 3600.0, REQUIRED),
    _f("decel_mps2", "decel", "m/s^2", 0.0, 15.0, REQUIRED, lo_open=True),
)

TV_LANE_CHANGE_FIELDS = (
    _f("start_s", "start", "s", -60.0, 3600.0, REQUIRED),
    Field("target_lane", int, lo=0, hi=7, default=REQUIRED),
    _f("tau_s", "tau", "s", 0.0, 60.0, REQUIRED, lo_open=True),
    _speed("target_speed_kmh", "target_speed", None),
    Field("broadcast", str, choices=("reference", "intention", "none"), default="reference"),
)

TRAFFIC_FIELDS = (
    _f("density_veh_per_km_lane", "density", "veh/km/lane", 0.0, 150.0, 0.0),
    _f("lanechange_duration_s", "lanechange_duration", "s", 0.0, 20.0, None),
    Field("sublane", bool, default=False),
    _f("length_m", "length", "m", 0.0, 1e5, 1000.0, lo_open=True),
)

V2V_FIELDS = (
    _f("range_m", "range", "m", 0.0, 1e4, 300.0),
    _f("latency_s", "latency", "s", 0.0, 10.0, 0.0),
    _f("loss", "loss", "", 0.0, 1.0, 0.0),
    Field("mode", str, choices=("v2v", "perception"), default="v2v"),
    # perception mode: standard deviations of the measured TV state
    _f("noise_position_m", "noise_position", "m", 0.0, 10.0, 0.2),
    _f("noise_heading_rad", "noise_heading", "rad", 0.0, 1.0, 0.01),
    _f("noise_speed_mps", "noise_speed", "m/s", 0.0, 10.0, 0.2),
    _f("noise_accel_mps2", "noise_accel", "m/s^2", 0.0, 10.0, 0.3),
    _f("noise_lateral_speed_mps", "noise_lateral_speed", "m/s", 0.0, 10.0, 0.1),
)

TABLES: dict[str, tuple[Field, ...]] = {
    "scenario": SCENARIO_FIELDS,
    "road": ROAD_FIELDS,
    "sv": SV_FIELDS,
    "planner": PLANNER_FIELDS,
    "vehicle": VEHICLE_FIELDS,
    "controller": CONTROLLER_FIELDS,
    "tv": TV_FIELDS,  # an array of tables
    "traffic": TRAFFIC_FIELDS,
    "v2v": V2V_FIELDS,
}
REQUIRED_TABLES = ("scenario", "sv")


def _parse_table_list(
    source: str, key: str, value: Any, specs: tuple[Field, ...], max_len: int
) -> tuple[dict[str, Any], ...]:
    if not isinstance(value, list) or len(value) > max_len:
        raise InputError(source, key, value, f"a list of at most {max_len} tables")
    return tuple(validate_table(source, f"{key}[{i}]", item, specs) for i, item in enumerate(value))


# ---------------------------------------------------------------- paths


def project_root() -> Path:
    """The directory holding pyproject.toml above the package (else the working directory)."""
    here = Path(__file__).resolve().parent
    for candidate in (here, *here.parents):
        if (candidate / "pyproject.toml").is_file():
            return candidate
    return Path.cwd()


def _exists(p: Path, want_file: bool = False) -> bool:
    """Path.exists / is_file that say False for names the OS refuses (too long, ...)."""
    try:
        return p.is_file() if want_file else p.exists()
    except (OSError, ValueError):
        return False


def _resolve(base_dir: Path, name: str) -> Path:
    """A path from a scenario file: absolute, else relative to the file's directory,
    else relative to the project root."""
    p = Path(name).expanduser()
    if p.is_absolute():
        return p
    first = base_dir / p
    if _exists(first):
        return first.resolve()
    second = project_root() / p
    return second.resolve() if _exists(second) else first


@dataclass(frozen=True)
class _NetInfo:
    lane_counts: tuple[int, ...]  # lanes of each normal edge
    lane_widths: tuple[float, ...]  # m, widths of the lanes of the widest edge
    x_range: tuple[float, float] | None  # m, x extent of the road when it is one edge


def _read_network(source: str, key: str, path: Path) -> _NetInfo:
    """Check that `path` is a SUMO network and read what validation needs."""
    if not _exists(path, want_file=True):
        raise InputError(source, key, str(path), "an existing SUMO .net.xml file")
    try:
        st = path.stat()
    except OSError as exc:
        raise InputError(source, key, str(path), f"a readable file ({exc.strerror})") from None
    info = _net_info(str(path), st.st_mtime_ns, st.st_size)
    if isinstance(info, str):
        raise InputError(source, key, str(path), info)
    return info


@functools.lru_cache(maxsize=16)
def _net_info(path: str, mtime_ns: int, size: int) -> _NetInfo | str:
    """What validation needs from a network, or what is wrong with it.

    Cached on (path, mtime, size): a batch validates the same network once per run.
    """
    del mtime_ns, size  # part of the cache key only
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError, ValueError) as exc:
        return f"a readable SUMO .net.xml file ({exc})"
    if root.tag != "net":
        return f"a SUMO network (root <net>, found <{root.tag}>)"
    edges = [e for e in root.iter("edge") if e.get("function", "normal") == "normal"]
    if not edges:
        return "a SUMO network with at least one edge"
    counts = tuple(len(e.findall("lane")) for e in edges)
    widest = max(edges, key=lambda e: len(e.findall("lane")))
    try:
        widths = tuple(float(lane.get("width", "3.2")) for lane in widest.findall("lane"))
        x_range = None
        if len(edges) == 1:
            xs = [
                float(pt.split(",")[0])
                for lane in widest.findall("lane")
                for pt in lane.get("shape", "").split()
            ]
            if xs:
                x_range = (min(xs), max(xs))
    except ValueError as exc:
        return f"a well-formed SUMO network ({exc})"
    return _NetInfo(counts, widths, x_range)


# ---------------------------------------------------------------- loading


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; raise InputError (one line) if anything is wrong."""
    p = Path(path)
    source = str(p)
    if not _exists(p, want_file=True):
        raise InputError(source, "file", source, "an existing scenario file (.toml)")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(source, "file", source, f"a readable file ({exc.strerror})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(source, "file", f"byte {exc.start}", "UTF-8 text (TOML)") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, "file", str(exc), "valid TOML") from None
    except (RecursionError, ValueError) as exc:  # pathological nesting
        what = "nesting too deep" if isinstance(exc, RecursionError) else str(exc)
        raise InputError(source, "file", what, "valid TOML") from None
    return scenario_from_dict(doc, path=p.resolve(), source=source)


def scenario_from_dict(
    doc: Mapping[str, Any], path: str | Path = "<scenario>", source: str | None = None
) -> Scenario:
    """Validate a scenario document (the parsed TOML, file units) into a Scenario.

    Relative paths in it are resolved against `path`'s directory, then the project root.
    """
    p = Path(path)
    src = source if source is not None else str(p)
    check_table(src, "", doc)
    if "study" in doc:
        raise InputError(src, "study", "[study]", "a scenario file (this is a study: cosim batch)")
    check_known_tables(src, doc, list(TABLES))
    for name in REQUIRED_TABLES:
        if name not in doc:
            raise InputError(src, f"[{name}]", MISSING, "required table")
    tables = {
        name: validate_table(src, name, doc.get(name, {}), specs)
        for name, specs in TABLES.items()
        if name != "tv"
    }
    raw_tvs = doc.get("tv", [])
    if not isinstance(raw_tvs, list) or len(raw_tvs) > 100:
        raise InputError(src, "tv", raw_tvs, "an array of at most 100 [[tv]] tables")
    tv_tables = [validate_table(src, f"tv[{i}]", t, TV_FIELDS) for i, t in enumerate(raw_tvs)]

    sc, rd, svt = tables["scenario"], tables["road"], tables["sv"]
    base_dir = p.parent if p.is_absolute() else Path.cwd() / p.parent
    road = RoadParams(lane_width=rd["lane_width"], speed_bands=rd["speed_bands"], mu=rd["mu"])
    network = _resolve(base_dir, rd["network"])
    sv = SVSpec(
        lane=svt["lane"],
        position=svt["position"],
        speed=svt["speed"],
        occupant=svt["occupant"],
        plant=svt["plant"],
        controller=svt["controller"],
        lane_changes=tuple(LaneChangeCommand(**c) for c in svt["lane_changes"]),
        decision=svt["decision"],
        desired_speed=svt["desired_speed"],
    )
    tvs = tuple(
        TVSpec(**{**t, "lane_change": _tv_lane_change(t["lane_change"]),
                  "brake": TVBrake(**t["brake"]) if t["brake"] is not None else None})
        for t in tv_tables
    )
    scenario = Scenario(
        path=p,
        name=sc["name"] if sc["name"] is not None else (p.stem or "scenario"),
        description=sc["description"],
        duration=sc["duration"],
        step=sc["step"],
        substeps=sc["substeps"],
        seed=sc["seed"],
        road=road,
        network=network,
        vehicle=vehicle_from_table(tables["vehicle"], {
            f.attr for f in VEHICLE_FIELDS if f.key in doc.get("vehicle", {})}),
        gains=ControllerGains(**tables["controller"]),
        planner=PlannerConfig(**tables["planner"]),
        sv=sv,
        tvs=tvs,
        traffic=_traffic(src, tables["traffic"]),
        v2v=V2VSpec(**tables["v2v"]),
        document=copy.deepcopy(dict(doc)),
    )
    _check_cross(src, scenario, network_key="road.network")
    return scenario


# ---------------------------------------------------------------- cross-field rules


def _traffic(src: str, values: dict[str, Any]) -> TrafficSpec:
    """SUMO cannot combine --lanechange.duration with the sublane model."""
    duration = values["lanechange_duration"]
    if values["sublane"] and duration not in (None, 0.0):
        raise InputError(
            src,
            "traffic.lanechange_duration_s",
            duration,
            "0 or absent with traffic.sublane = true (SUMO uses one or the other)",
        )
    if duration is None:
        duration = 0.0 if values["sublane"] else DEFAULT_LANECHANGE_DURATION
    return TrafficSpec(**{**values, "lanechange_duration": duration})


def _tv_lane_change(values: Mapping[str, Any] | None) -> TVLaneChange | None:
    return TVLaneChange(**values) if values is not None else None


def _check_cross(src: str, s: Scenario, network_key: str) -> None:
    n = s.road.n_lanes
    lanes_allowed = f"a lane index 0..{n - 1} (road.lane_speeds_kmh has {n} lanes)"
    net = _check_network(src, s, network_key)

    # Time grid.
    ratio = s.duration / s.step
    if abs(ratio - round(ratio)) > STEP_TOLERANCE * max(1.0, ratio):
        raise InputError(
            src,
            "scenario.duration_s",
            s.duration,
            f"a whole multiple of scenario.step_s = {s.step:g} s",
        )

    # Planner.
    if s.planner.tau_step >= s.planner.tau_max:
        raise InputError(
            src,
            "planner.tau_step_s",
            s.planner.tau_step,
            f"smaller than planner.tau_max_s = {s.planner.tau_max:g} s",
        )
    if s.planner.tau_min_floor > s.planner.tau_max:
        raise InputError(
            src,
            "planner.tau_min_floor_s",
            s.planner.tau_min_floor,
            f"at most planner.tau_max_s = {s.planner.tau_max:g} s",
        )

    # Vehicle geometry: the body (centred on the CG) holds both axles and both tracks.
    v = s.vehicle
    if v.length < v.lf + v.lr:
        raise InputError(
            src,
            "vehicle.length_m",
            v.length,
            f"at least the wheelbase lf_m + lr_m = {v.lf + v.lr:g} m",
        )
    if v.width < 2.0 * v.half_track:
        raise InputError(
            src,
            "vehicle.width_m",
            v.width,
            f"at least the track 2 half_track_m = {2 * v.half_track:g} m",
        )

    # Controller stability, eq. 25: kz0 > 0, kzI > 0, kz0 kz1 > kzI for z in {y, phi}.
    g = s.gains
    for z0, z1, zI in (("ky0", "ky1", "kyI"), ("kphi0", "kphi1", "kphiI")):
        a, b, c = getattr(g, z0), getattr(g, z1), getattr(g, zI)
        if a * b <= c:
            raise InputError(
                src, f"controller.{zI}", c, f"below {z0} * {z1} = {a * b:g} (stability, eq. 25)"
            )

    # SV: lane, speed band, scripted lane changes one lane at a time.
    sv = s.sv
    if sv.lane >= n:
        raise InputError(src, "sv.lane", sv.lane, lanes_allowed)
    lo, hi = s.road.speed_bands[sv.lane]
    eps = 1e-9
    if not sv.decision and not lo - eps <= sv.speed <= hi + eps:
        raise InputError(
            src,
            "sv.speed_kmh",
            round(sv.speed * KMH, 6),
            f"within lane {sv.lane}'s band [{lo * KMH:g}, {hi * KMH:g}] km/h "
            "(the method's assumption; set sv.decision = true for free traffic)",
        )
    lane, last_at = sv.lane, -1.0
    for i, cmd in enumerate(sv.lane_changes):
        key = f"sv.lane_changes[{i}]"
        if cmd.at >= s.duration:
            raise InputError(
                src, f"{key}.at_s", cmd.at, f"before scenario.duration_s = {s.duration:g} s"
            )
        if cmd.at <= last_at:
            raise InputError(
                src, f"{key}.at_s", cmd.at, f"after the previous request's at_s = {last_at:g} s"
            )
        if cmd.target_lane >= n:
            raise InputError(src, f"{key}.target_lane", cmd.target_lane, lanes_allowed)
        if abs(cmd.target_lane - lane) != 1:
            raise InputError(
                src,
                f"{key}.target_lane",
                cmd.target_lane,
                f"a lane next to lane {lane} (one lane at a time)",
            )
        lane, last_at = cmd.target_lane, cmd.at

    # TVs: ids unique, lanes exist, lane changes to an adjacent lane, no overlap at t = 0.
    seen: dict[str, int] = {}
    for i, tv in enumerate(s.tvs):
        key = f"tv[{i}]"
        if tv.id in seen:
            raise InputError(src, f"{key}.id", tv.id, f"unique (tv[{seen[tv.id]}] has it)")
        seen[tv.id] = i
        if tv.lane >= n:
            raise InputError(src, f"{key}.lane", tv.lane, lanes_allowed)
        lc = tv.lane_change
        if tv.brake is not None and lc is not None:
            raise InputError(src, f"{key}.brake", "[tv.brake]",
                             "a TV without [tv.lane_change] (braking is scripted in its lane)")
        if lc is not None:
            if lc.target_lane >= n:
                raise InputError(
                    src, f"{key}.lane_change.target_lane", lc.target_lane, lanes_allowed
                )
            if abs(lc.target_lane - tv.lane) != 1:
                raise InputError(
                    src,
                    f"{key}.lane_change.target_lane",
                    lc.target_lane,
                    f"a lane next to the TV's lane {tv.lane}",
                )
            if lc.start <= -lc.tau:
                raise InputError(
                    src,
                    f"{key}.lane_change.start_s",
                    lc.start,
                    f"after -tau_s = {-lc.tau:g} s (a finished change: put the TV "
                    "in its target lane)",
                )
            if lc.start >= s.duration:
                raise InputError(
                    src,
                    f"{key}.lane_change.start_s",
                    lc.start,
                    f"before scenario.duration_s = {s.duration:g} s",
                )
    _check_no_overlap(src, s)
    _check_positions(src, s, net)


def _settled_lane(tv: TVSpec) -> int | None:
    """The TV's lane at t = 0, or None while it is between lanes."""
    if tv.lane_change is not None and tv.lane_change.start < 0:
        return None
    return tv.lane


def _check_no_overlap(src: str, s: Scenario) -> None:
    """No two vehicles settled in the same lane may overlap at t = 0."""
    bodies = [("the SV", s.sv.lane, 0.0, s.vehicle.length)]
    for tv in s.tvs:
        bodies.append((f"TV {tv.id!r}", _settled_lane(tv), tv.gap, tv.length))
    for i in range(1, len(bodies)):
        _, lane, gap, length = bodies[i]
        if lane is None:
            continue
        for other, olane, ogap, olength in bodies[:i]:
            if olane == lane and abs(gap - ogap) < 0.5 * (length + olength):
                raise InputError(
                    src,
                    f"tv[{i - 1}].gap_m",
                    gap,
                    f"a gap that keeps it clear of {other} in lane {lane} at t = 0 "
                    f"(|gap - {ogap:g}| >= {0.5 * (length + olength):g} m)",
                )


def _check_network(src: str, s: Scenario, key: str) -> _NetInfo:
    """The network exists, is a SUMO net, and has the scenario's lanes (count and width)."""
    if not _exists(s.network, want_file=True):
        road = s.document.get("road", {})
        written = road.get("network", DEFAULT_NETWORK) if isinstance(road, Mapping) else ""
        looked = (
            s.network
            if Path(written).is_absolute()
            else (f"{s.path.parent / written} or {project_root() / written}")
        )
        raise InputError(src, key, written, f"an existing SUMO .net.xml file (not found: {looked})")
    net = _read_network(src, key, s.network)
    n = s.road.n_lanes
    if n not in net.lane_counts:
        raise InputError(
            src,
            key,
            str(s.network),
            f"a network with a {n}-lane edge to match road.lane_speeds_kmh "
            f"(its edges have {sorted(set(net.lane_counts))} lanes)",
        )
    if any(abs(w - s.road.lane_width) > 1e-3 for w in net.lane_widths):
        raise InputError(
            src,
            "road.lane_width_m",
            s.road.lane_width,
            f"the network's lane width {net.lane_widths[0]:g} m",
        )
    return net


def _check_positions(src: str, s: Scenario, net: _NetInfo) -> None:
    """Every vehicle starts on the road, and the SV cannot run off its end in `duration`."""
    if net.x_range is None:
        return
    x0, x1 = net.x_range
    half = 0.5 * s.vehicle.length
    if not x0 + half <= s.sv.position <= x1 - half:
        raise InputError(
            src, "sv.position_m", s.sv.position, f"on the road: in [{x0 + half:g}, {x1 - half:g}] m"
        )
    for i, tv in enumerate(s.tvs):
        x = s.sv.position + tv.gap
        if not x0 + 0.5 * tv.length <= x <= x1 - 0.5 * tv.length:
            raise InputError(
                src,
                f"tv[{i}].gap_m",
                tv.gap,
                f"a gap that puts the TV on the road (x = {x:g} m is outside [{x0:g}, {x1:g}] m)",
            )
    # The SV must not run off the end of the road: SUMO would silently drop it.
    lanes = {s.sv.lane} | {c.target_lane for c in s.sv.lane_changes}
    if s.sv.decision:
        lanes = set(range(s.road.n_lanes))
    fastest = max(
        [s.sv.speed, s.sv.desired_speed or 0.0] + [s.road.speed_bands[k][1] for k in lanes]
    )
    end = s.sv.position + fastest * s.duration + half
    if end > x1:
        raise InputError(
            src,
            "scenario.duration_s",
            s.duration,
            f"short enough for the SV to stay on the {x1 - x0:g} m road "
            f"(at {fastest * KMH:g} km/h from x = {s.sv.position:g} m it reaches "
            f"{end:g} m)",
        )


# ---------------------------------------------------------------- overrides & export

# Short names a batch study may vary -> (table, key, SI -> file unit factor).
OVERRIDES: dict[str, tuple[str, str, float]] = {
    "name": ("scenario", "name", 1.0),
    "description": ("scenario", "description", 1.0),
    "duration": ("scenario", "duration_s", 1.0),
    "step": ("scenario", "step_s", 1.0),
    "substeps": ("scenario", "substeps", 1.0),
    "seed": ("scenario", "seed", 1.0),
    "mu": ("road", "mu", 1.0),
    "lane_width": ("road", "lane_width_m", 1.0),
    "network": ("road", "network", 1.0),
    "occupant": ("sv", "occupant", 1.0),
    "plant": ("sv", "plant", 1.0),
    "controller": ("sv", "controller", 1.0),
    "decision": ("sv", "decision", 1.0),
    "sv_lane": ("sv", "lane", 1.0),
    "sv_position": ("sv", "position_m", 1.0),
    "sv_speed": ("sv", "speed_kmh", KMH),
    "desired_speed": ("sv", "desired_speed_kmh", KMH),
    "density": ("traffic", "density_veh_per_km_lane", 1.0),
    "lanechange_duration": ("traffic", "lanechange_duration_s", 1.0),
    "sublane": ("traffic", "sublane", 1.0),
    "traffic_length": ("traffic", "length_m", 1.0),
    "v2v_range": ("v2v", "range_m", 1.0),
    "latency": ("v2v", "latency_s", 1.0),
    "loss": ("v2v", "loss", 1.0),
    "v2v_mode": ("v2v", "mode", 1.0),
    "tau_max": ("planner", "tau_max_s", 1.0),
    "tau_step": ("planner", "tau_step_s", 1.0),
    "envelope": ("planner", "envelope", 1.0),
    "safety_factor": ("planner", "safety_factor", 1.0),
    "collision_test": ("planner", "collision_test", 1.0),
    "safety_margin": ("planner", "safety_margin_m", 1.0),
    "horizon_extra": ("planner", "horizon_extra_s", 1.0),
    "replanning": ("planner", "replanning", 1.0),
    "recheck_interval": ("planner", "recheck_interval_s", 1.0),
    "uncertainty_margin": ("planner", "uncertainty_margin", 1.0),
}


def with_overrides(scenario: Scenario, **changes: Any) -> Scenario:
    """The scenario with some values changed, validated exactly like a file.

    Names are the short SI names of `OVERRIDES` (`density=20`, `mu=0.4`,
    `sv_speed=25.0` in m/s, `controller="siso"`) or dotted file keys
    (`**{"sv.speed_kmh": 90}`, `**{"vehicle.mass_kg": 1500}`). A value of None
    removes the key (back to its default).
    """
    doc = copy.deepcopy(dict(scenario.document))
    source = f"{scenario.path} (overrides)"
    for name, value in changes.items():
        if name in OVERRIDES:
            table, key, factor = OVERRIDES[name]
            if factor != 1.0 and isinstance(value, (int, float)) and not isinstance(value, bool):
                value = value * factor
        elif "." in name and name.split(".", 1)[0] in TABLES and name.split(".", 1)[0] != "tv":
            table, key = name.split(".", 1)
        else:
            raise InputError(
                source,
                name,
                value,
                f"an override name{suggest(name, list(OVERRIDES))} or a dotted "
                "file key such as sv.speed_kmh",
            )
        sub = doc.get(table, {})
        sub = dict(sub) if isinstance(sub, Mapping) else {}
        if value is None:
            sub.pop(key, None)
        else:
            sub[key] = value
        doc[table] = sub
    return scenario_from_dict(doc, path=scenario.path, source=source)


def _table_to_dict(specs: tuple[Field, ...], values: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in specs:
        value = values[f.attr]
        if value is None:
            continue  # absent optional key (TOML has no null)
        out[f.key] = f.to_file_units(value)
    return out


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """The complete, validated scenario in file units (km/h, s, m), as plain JSON-able data.

    Shaped like the scenario file, with every default filled in and the network as
    an absolute path; `scenario_from_dict` of it gives the same scenario (up to
    km/h <-> m/s rounding).
    """
    s = scenario
    sv_values = {f.name: getattr(s.sv, f.name) for f in fields(s.sv)}
    sv_dict = _table_to_dict(SV_FIELDS[:-1], sv_values)
    sv_dict["lane_changes"] = [
        {"at_s": c.at, "target_lane": c.target_lane} for c in s.sv.lane_changes
    ]
    tvs = []
    for tv in s.tvs:
        values = {f.name: getattr(tv, f.name) for f in fields(tv)}
        t = _table_to_dict(TV_FIELDS[:-2], values)
        if tv.lane_change is not None:
            lc = {f.name: getattr(tv.lane_change, f.name) for f in fields(tv.lane_change)}
            t["lane_change"] = _table_to_dict(TV_LANE_CHANGE_FIELDS, lc)
        if tv.brake is not None:
            br = {f.name: getattr(tv.brake, f.name) for f in fields(tv.brake)}
            t["brake"] = _table_to_dict(TV_BRAKE_FIELDS, br)
        tvs.append(t)

    def obj(specs: tuple[Field, ...], o: Any) -> dict[str, Any]:
        return _table_to_dict(specs, {f.attr: getattr(o, f.attr) for f in specs})

    road = {
        "lane_width_m": s.road.lane_width,
        "lane_speeds_kmh": [
            [round(lo * KMH, 9), round(hi * KMH, 9)] for lo, hi in s.road.speed_bands
        ],
        "mu": s.road.mu,
        "network": str(s.network),
    }
    return {
        "scenario": obj(SCENARIO_FIELDS, s),
        "road": road,
        "sv": sv_dict,
        "planner": obj(PLANNER_FIELDS, s.planner),
        "vehicle": obj(VEHICLE_FIELDS, s.vehicle),
        "controller": obj(CONTROLLER_FIELDS, s.gains),
        "tv": tvs,
        "traffic": obj(TRAFFIC_FIELDS, s.traffic),
        "v2v": obj(V2V_FIELDS, s.v2v),
    }


_DEFAULT_NOTES = {
    "scenario.name": "the file's stem",
    "road.lane_speeds_kmh": "`[[60, 90], [90, 110], [110, 120]]`",
    "road.network": f"`{DEFAULT_NETWORK}`",
    "sv.desired_speed_kmh": "its lane's maximum",
    "sv.lane_changes": "`[]`",
    "traffic.lanechange_duration_s": f"`{DEFAULT_LANECHANGE_DURATION}` (`0` with sublane)",
    "tv.lane_change.target_speed_kmh": "the band rule",
}


def schema_markdown() -> str:
    """Every key of a scenario file as a Markdown table (what, allowed, default), from
    the same `Field`s that validate it, so the documentation cannot drift."""
    rows = ["| key | allowed | default |", "|---|---|---|"]
    nested = {"sv.lane_changes[]": LANE_CHANGE_FIELDS, "tv.lane_change": TV_LANE_CHANGE_FIELDS,
              "tv.brake": TV_BRAKE_FIELDS}
    groups = [
        (("[[tv]]" if name == "tv" else f"[{name}]"), name, specs) for name, specs in TABLES.items()
    ]
    groups += [(name, name, specs) for name, specs in nested.items()]
    for title, prefix, specs in groups:
        rows.append(f"| **{title}** | | |")
        for f in specs:
            allowed = f.allowed().removeprefix("required: ")
            if f.default is REQUIRED:
                default = "required"
            elif f"{prefix}.{f.key}" in _DEFAULT_NOTES:
                default = _DEFAULT_NOTES[f"{prefix}.{f.key}"]
            elif f.default is None:
                default = "-"
            else:
                default = f"`{json.dumps(f.to_file_units(f.default))}`"
            rows.append(f"| `{prefix}.{f.key}` | {allowed.replace('|', '/')} | {default} |")
    return "\n".join(rows) + "\n"
