"""What is derived from the declared keys: overrides (batch studies), the scenario as a
dict in file units, and the key reference (docs/scenario_keys.md)."""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from typing import Any

from cosim.errors import InputError
from cosim.scenario.keys import NESTED, OVERRIDES, TABLES
from cosim.scenario.load import scenario_from_dict
from cosim.scenario.model import Scenario
from cosim.validation import REQUIRED, Field, suggest, table_to_dict


def override_target(name: str) -> tuple[str, str, Field | None]:
    """(table, file key, field or None) an override name stands for; KeyError if none.

    Names are the short names of `OVERRIDES` (SI values) or dotted file keys
    (`sv.speed_kmh`, file units)."""
    if name in OVERRIDES:
        table, f = OVERRIDES[name]
        return table, f.key, f
    table, _, key = name.partition(".")
    if key and table in TABLES and table != "tv":
        return table, key, None
    raise KeyError(name)


def apply_overrides(scenario: Scenario, changes: Mapping[str, Any], source: str) -> Scenario:
    """`scenario` with `changes` (override name -> value) applied to its document and the
    whole validated again like a file; errors name `source`."""
    doc = copy.deepcopy(dict(scenario.document))
    for name, value in changes.items():
        try:
            table, key, f = override_target(name)
        except KeyError:
            raise InputError(
                source, name, value,
                f"an override name{suggest(name, list(OVERRIDES))} or a dotted "
                "file key such as sv.speed_kmh",
            ) from None
        if (f is not None and f.si_divisor != 1.0 and isinstance(value, (int, float))
                and not isinstance(value, bool)):
            value = value * f.si_divisor  # SI -> the file's unit, as the field reads it
        sub = doc.get(table, {})
        sub = dict(sub) if isinstance(sub, Mapping) else {}
        if value is None:
            sub.pop(key, None)
        else:
            sub[key] = value
        doc[table] = sub
    return scenario_from_dict(doc, path=scenario.path, source=source)


def with_overrides(scenario: Scenario, **changes: Any) -> Scenario:
    """The scenario with some values changed, validated exactly like a file.

    Names are the short SI names of `OVERRIDES` (`density=20`, `mu=0.4`,
    `sv_speed=25.0` in m/s, `controller="siso"`) or dotted file keys
    (`**{"sv.speed_kmh": 90}`, `**{"vehicle.mass_kg": 1500}`). A value of None
    removes the key (back to its default).
    """
    return apply_overrides(scenario, changes, f"{scenario.path} (overrides)")


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """The complete, validated scenario in file units (km/h, s, m), as plain JSON-able data.

    Shaped like the scenario file, with every default filled in and the network as
    an absolute path; `scenario_from_dict` of it gives the same scenario (up to
    km/h <-> m/s rounding).
    """
    s = scenario
    road = {"lane_width": s.road.lane_width, "speed_bands": s.road.speed_bands,
            "mu": s.road.mu, "network": None if s.sumocfg is not None else s.network,
            "route": s.route, "sumocfg": s.sumocfg}
    objects: dict[str, Any] = {
        "scenario": s, "road": road, "sv": s.sv, "planner": s.planner, "vehicle": s.vehicle,
        "controller": s.gains, "traffic": s.traffic, "v2v": s.v2v,
        "detectors": s.detectors, "fleet": s.fleet, "ssm": s.ssm,
    }
    out = {name: table_to_dict(TABLES[name], obj) for name, obj in objects.items()}
    out["tv"] = [table_to_dict(TABLES["tv"], tv) for tv in s.tvs]
    return {name: out[name] for name in TABLES}


def schema_markdown() -> str:
    """Every key of a scenario file as a Markdown table (meaning, allowed, default), from
    the same `Field`s that validate it, so the documentation cannot drift."""
    rows = ["| key | meaning | allowed | default |", "|---|---|---|---|"]
    groups = [
        (("[[tv]]" if name == "tv" else f"[{name}]"), name, specs) for name, specs in TABLES.items()
    ]
    groups += [(name, name, specs) for name, specs in NESTED.items()]
    for title, prefix, specs in groups:
        rows.append(f"| **{title}** | | | |")
        for f in specs:
            allowed = f.allowed().removeprefix("required: ")
            if f.default is REQUIRED:
                default = "required"
            elif f.default_doc:
                default = f.default_doc
            elif f.default is None:
                default = "-"
            else:
                default = f"`{json.dumps(f.to_file_units(f.default))}`"
            if f.override:
                default += f" (override `{f.override}`)"
            doc = f.doc.replace("|", "\\|")
            rows.append(f"| `{prefix}.{f.key}` | {doc} | {allowed.replace('|', '/')} "
                        f"| {default} |")
    return "\n".join(rows) + "\n"
