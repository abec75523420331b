"""Every key of a scenario file, declared once: the tables, their `Field`s, and what is
derived from them (the short override names of batch studies, `OVERRIDES`).

Keys of the tables the spec dataclasses hold are declared on their attributes
(cosim.scenario.model); the tables whose values are cosim.params dataclasses are
declared here, their defaults taken from those dataclasses.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from typing import Any

from cosim.driving.registry import PLANNED  # the registry owns the policies' names
from cosim.errors import InputError
from cosim.params import (
    VEHICLE_PRESETS,
    ControllerGains,
    PlannerConfig,
    RoadParams,
    VehicleParams,
)
from cosim.planning.collision import COLLISION_TESTS  # the planner owns its option names
from cosim.planning.envelope import ENVELOPES
from cosim.scenario.model import (
    EDGE_PATTERN,
    KMH,
    MAX_ROUTE_EDGES,
    MAX_SPEED_KMH,
    DetectorSpec,
    FleetSpec,
    LaneChangeCommand,
    Scenario,
    SsmSpec,
    SVSpec,
    TrafficSpec,
    TVBrake,
    TVLaneChange,
    TVSpec,
    V2VSpec,
    number_key,
)
from cosim.validation import Field, declared_fields

DEFAULT_NETWORK = "networks/highway.net.xml"  # relative to the project root
_VEH = VehicleParams()
_PLAN = PlannerConfig()
_GAINS = ControllerGains()
_ROAD = RoadParams()


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


def _export_bands(bands: tuple[tuple[float, float], ...]) -> list[list[float]]:
    return [[round(lo * KMH, 9), round(hi * KMH, 9)] for lo, hi in bands]


def _parse_network(source: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip() or "\x00" in value or len(value) > 4096:
        raise InputError(source, key, value, "the path of a SUMO .net.xml file")
    return value


def _parse_sumocfg(source: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip() or "\x00" in value or len(value) > 4096:
        raise InputError(source, key, value, "the path of a SUMO .sumocfg file")
    return value


def _parse_route(source: str, key: str, value: Any) -> tuple[str, ...]:
    """A list of SUMO edge ids (the network check is cosim.road.route.make_route's)."""
    allowed = (f"a list of 1 to {MAX_ROUTE_EDGES} SUMO edge ids (strings), in driving order")
    if (not isinstance(value, list) or not 1 <= len(value) <= MAX_ROUTE_EDGES
            or not all(isinstance(e, str) and re.fullmatch(EDGE_PATTERN, e) for e in value)):
        raise InputError(source, key, value, allowed)
    return tuple(value)


SCENARIO_FIELDS = declared_fields(Scenario)

ROAD_FIELDS = (
    replace(number_key("lane_width_m", "m", 2.0, 6.0, None,
                   "lane width; the network's, so it may only repeat it",
                   override="lane_width", default_doc="the network's"), name="lane_width"),
    Field("lane_speeds_kmh", list, name="speed_bands", default=_ROAD.speed_bands,
          parse=_parse_bands, describe="a list of [min, max] km/h per lane",
          export=_export_bands, default_doc="`[[60, 90], [90, 110], [110, 120]]`",
          doc="speed band of each lane from lane 0 up (the method's assumption); "
              "one per lane of the network"),
    number_key("mu", "", 0.1, 1.2, _ROAD.mu, "road friction coefficient", override="mu"),
    Field("network", str, default=DEFAULT_NETWORK, parse=_parse_network, export=str,
          describe="the path of a SUMO .net.xml file", override="network",
          default_doc=f"`{DEFAULT_NETWORK}`",
          doc="SUMO network (a motorway: docs/roads.md says what is driven); relative to "
              "the file, then the project root"),
    Field("sumocfg", str, default=None, parse=_parse_sumocfg, export=str,
          describe="the path of a SUMO .sumocfg file",
          default_doc="none", doc="a SUMO configuration instead of `network`: its net-file is "
          "the network, its route-files (and the vTypes, routes and flows of its "
          "additional-files) the traffic, relative to it; every other option is ignored "
          "(docs/roads.md, \"Running cosim in your own SUMO scenario\"); relative to the file, "
          "then the project root"),
    Field("route", list, default=None, parse=_parse_route, export=list,
          describe=f"a list of 1 to {MAX_ROUTE_EDGES} SUMO edge ids",
          default_doc="the network's only edge",
          doc="the SUMO edges the SV drives, in order, each connected to the next "
              "(docs/roads.md); optional on a one-edge network"),
)

SV_FIELDS = declared_fields(SVSpec)
LANE_CHANGE_FIELDS = declared_fields(LaneChangeCommand)

PLANNER_FIELDS = (
    number_key("tau_max_s", "s", 0.0, 60.0, _PLAN.tau_max, "longest lane change considered",
           lo_open=True, override="tau_max"),
    number_key("tau_step_s", "s", 0.0, 1.0, _PLAN.tau_step, "spacing of the tau grid",
           lo_open=True, override="tau_step"),
    Field("envelope", str, choices=ENVELOPES, default=_PLAN.envelope, override="envelope",
          doc="stability envelope of the tau set (paper_maps: the paper's eq. 31-34)"),
    number_key("safety_factor", "", 0.0, 1.0, _PLAN.safety_factor,
           "f of the envelope |Omega_z| <= f sqrt((mu g)^2 - Ax^2) / Vx", lo_open=True,
           override="safety_factor"),
    Field("collision_test", str, choices=COLLISION_TESTS, default=_PLAN.collision_test,
          override="collision_test",
          doc="exact (separating axes) or col (the paper's, Appendix 9.2)"),
    number_key("safety_margin_m", "m", 0.0, 5.0, _PLAN.safety_margin,
           "added around every rectangle by the exact test", override="safety_margin"),
    number_key("horizon_extra_s", "s", 0.0, 60.0, _PLAN.horizon_extra,
           "collision horizon past the end of the manoeuvre", override="horizon_extra"),
    number_key("tau_min_floor_s", "s", 0.0, 60.0, _PLAN.tau_min_floor,
           "shortest tau ever put on the grid", lo_open=True),
    Field("replanning", bool, default=_PLAN.replanning, override="replanning",
          doc="re-check the rest of the plan while it is flown"),
    number_key("recheck_interval_s", "s", 0.0, 10.0, _PLAN.recheck_interval,
           "time between two re-checks", lo_open=True, override="recheck_interval"),
    Field("uncertainty_margin", bool, default=_PLAN.uncertainty_margin,
          override="uncertainty_margin",
          doc="widen safety_margin by V2V latency, loss and noise"),
    Field("policy", str, choices=PLANNED, default=_PLAN.policy, override="policy",  # type: ignore[arg-type]
          doc="lane-change policy, by its registered name (cosim.driving.registry): paper (the "
              "paper's method) or gap (choose a gap, reach it)"),
)
# attribute names: the key without its unit suffix
PLANNER_FIELDS = tuple(
    replace(f, name=f.key.removesuffix("_s").removesuffix("_m")) for f in PLANNER_FIELDS
)

VEHICLE_FIELDS = (
    Field("preset", str, choices=tuple(VEHICLE_PRESETS), default=_VEH.preset,
          doc="a known car (cosim.params.VEHICLE_PRESETS: the paper's Table 1 or CommonRoad's "
              "vehicle1/2/3); the keys below that the file gives override it"),
) + tuple(
    replace(number_key(key, unit, lo, hi, getattr(_VEH, attr), doc), name=attr)
    for key, attr, unit, lo, hi, doc in (
        ("mass_kg", "mass", "kg", 100.0, 1e5, "mass M"),
        ("yaw_inertia_kg_m2", "yaw_inertia", "kg m^2", 10.0, 1e6, "yaw inertia Iz"),
        ("lf_m", "lf", "m", 0.1, 10.0, "CG to front axle"),
        ("lr_m", "lr", "m", 0.1, 10.0, "CG to rear axle"),
        ("half_track_m", "half_track", "m", 0.1, 2.0, "half track ls"),
        ("drag_n_s2_per_m2", "drag", "N s^2/m^2", 0.0, 10.0, "aerodynamic drag Ca"),
        ("cf_n_per_rad", "cf", "N/rad", 1e3, 1e7, "front axle cornering stiffness Cf"),
        ("cr_n_per_rad", "cr", "N/rad", 1e3, 1e7, "rear axle cornering stiffness Cr"),
        ("length_m", "length", "m", 1.0, 30.0, "body length (collision rectangle)"),
        ("width_m", "width", "m", 0.5, 4.0, "body width (collision rectangle)"),
    )
)

_GAINS_DOC = {
    "ky0": ("1/s^2", "lateral-offset gain (eq. 22-25)"),
    "kphi0": ("1/s^2", "heading gain (eq. 22-25)"),
    "kyI": ("1/s^3", "lateral-offset integral gain (eq. 25: below ky0 * ky1)"),
    "kphiI": ("1/s^3", "heading integral gain (eq. 25: below kphi0 * kphi1)"),
    "ky1": ("1/s", "lateral-offset derivative gain (eq. 22-25)"),
    "kphi1": ("1/s", "heading derivative gain (eq. 22-25)"),
    "kx1": ("1/s", "longitudinal speed-error gain (eq. 28)"),
}
CONTROLLER_FIELDS = tuple(
    number_key(name, unit, 0.0, 1e6, getattr(_GAINS, name), doc, lo_open=True)
    for name, (unit, doc) in _GAINS_DOC.items()
) + (number_key("allocation_eps", "", 0.0, 1.0, _GAINS.allocation_eps,
            "eps of the least-squares allocation (eq. 30)", lo_open=True),)

TV_FIELDS = declared_fields(TVSpec)
TV_LANE_CHANGE_FIELDS = declared_fields(TVLaneChange)
TV_BRAKE_FIELDS = declared_fields(TVBrake)
TRAFFIC_FIELDS = declared_fields(TrafficSpec)
V2V_FIELDS = declared_fields(V2VSpec)
DETECTOR_FIELDS = declared_fields(DetectorSpec)
FLEET_FIELDS = declared_fields(FleetSpec)
SSM_FIELDS = declared_fields(SsmSpec)

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
    "detectors": DETECTOR_FIELDS,
    "fleet": FLEET_FIELDS,
    "ssm": SSM_FIELDS,
}
REQUIRED_TABLES = ("scenario", "sv")
# Sub-tables, as the key reference lists them.
NESTED: dict[str, tuple[Field, ...]] = {
    "sv.lane_changes[]": LANE_CHANGE_FIELDS,
    "tv.lane_change": TV_LANE_CHANGE_FIELDS,
    "tv.brake": TV_BRAKE_FIELDS,
}

# Short names a batch study may vary -> (table, field); SI values, converted by the field.
OVERRIDES: dict[str, tuple[str, Field]] = {
    f.override: (table, f) for table, specs in TABLES.items() for f in specs if f.override
}
