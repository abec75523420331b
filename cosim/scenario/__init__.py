"""Scenario files (TOML): load, validate, override, export.

`load_scenario(path)` reads a scenario file and returns a `Scenario` in SI
units, or raises `InputError` (file, key, value, what is allowed; one line)
before anything runs. Keys in the file carry their unit (`speed_kmh`,
`gap_m`, `duration_s`); lanes are SUMO indices (0 = rightmost, slowest; the
paper's Lane 1/2/3 are SUMO lanes 0/1/2).

Tables: [scenario] [road] [sv] [planner] [vehicle] [controller] [[tv]]
(with an optional [tv.lane_change] or [tv.brake]) [traffic] [v2v] [detectors]
[fleet] [ssm].

The package, one job per module:
- `model`: the dataclasses, each attribute declared once with its key (`declare`);
- `keys`: the tables of keys, and what derives from them (`OVERRIDES`);
- `load`: the file (size-bounded), its tables, its network (read once, by
  cosim.traffic.network, which says what networks are supported);
- `rules`: the cross-field rules, everything SUMO would otherwise find at run time;
- `export`: overrides, `scenario_to_dict`, the key reference `schema_markdown`.
"""

from cosim.scenario.export import (
    apply_overrides,
    override_target,
    scenario_to_dict,
    schema_markdown,
    with_overrides,
)
from cosim.scenario.keys import (
    CONTROLLER_FIELDS,
    DEFAULT_NETWORK,
    DETECTOR_FIELDS,
    FLEET_FIELDS,
    LANE_CHANGE_FIELDS,
    NESTED,
    OVERRIDES,
    PLANNER_FIELDS,
    REQUIRED_TABLES,
    ROAD_FIELDS,
    SCENARIO_FIELDS,
    SV_FIELDS,
    TABLES,
    TRAFFIC_FIELDS,
    TV_BRAKE_FIELDS,
    TV_FIELDS,
    TV_LANE_CHANGE_FIELDS,
    V2V_FIELDS,
    VEHICLE_FIELDS,
)
from cosim.scenario.load import (
    DEFAULT_LANECHANGE_DURATION,
    MAX_FILE_BYTES,
    load_scenario,
    project_root,
    read_toml,
    scenario_from_dict,
)
from cosim.scenario.model import (
    DEFAULT_STEP,
    DEFAULT_SUBSTEPS,
    KMH,
    MAX_SPEED_KMH,
    NAME_PATTERN,
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
)
from cosim.validation import Field, table_to_dict, validate_table

__all__ = [
    "CONTROLLER_FIELDS", "DEFAULT_LANECHANGE_DURATION", "DEFAULT_NETWORK", "DEFAULT_STEP",
    "DEFAULT_SUBSTEPS", "DETECTOR_FIELDS", "DetectorSpec", "FLEET_FIELDS", "FleetSpec", "KMH",
    "LANE_CHANGE_FIELDS", "MAX_FILE_BYTES", "MAX_SPEED_KMH",
    "NAME_PATTERN", "NESTED", "OVERRIDES", "PLANNER_FIELDS", "REQUIRED_TABLES", "ROAD_FIELDS",
    "SCENARIO_FIELDS", "SV_FIELDS", "TABLES", "TRAFFIC_FIELDS", "TV_BRAKE_FIELDS", "TV_FIELDS",
    "TV_LANE_CHANGE_FIELDS", "V2V_FIELDS", "VEHICLE_FIELDS", "Field", "LaneChangeCommand",
    "SVSpec", "Scenario", "SsmSpec", "TVBrake", "TVLaneChange", "TVSpec", "TrafficSpec", "V2VSpec",
    "apply_overrides", "load_scenario", "override_target", "project_root", "read_toml",
    "scenario_from_dict", "scenario_to_dict", "schema_markdown", "table_to_dict",
    "validate_table", "with_overrides",
]
