"""Study files: a grid of runs over a base scenario (TOML, like scenarios).

```toml
[study]
name = "density"
description = "lane change success over traffic density"
scenario = "traffic_medium.toml"      # base scenario, relative to this file
densities_veh_per_km_lane = [5, 10, 15, 20, 25]
seeds = [1, 2, 3]                     # or seed_count = 10 (seeds 1..10)
occupants = [0.5]                     # p; absent: the base scenario's
mu = [0.8, 0.5]                       # absent: the base scenario's
shares = [0, 0.1, 0.2, 0.4]           # [fleet] share; absent: the base scenario's
fleet_drivers = ["cosim", "acc"]      # [fleet] driver; absent: the base scenario's
drivers = ["mimo", "siso", "sumo"]    # SV driver (by its controller); absent: the base's
plants = ["twotrack"]                 # absent: the base scenario's
duration_s = 30.0                     # absent: the base scenario's
traces = false                        # keep each run's trace files

[study.variants]                      # optional: named sets of scenario overrides,
paper = { replanning = false }        # one more grid dimension for our drivers
replan = { replanning = true, latency = 0.1, loss = 0.1 }
```

`load_study` validates the whole file (one-line InputError on the first
problem) before anything is written; `Study.with_flags` lets command-line
flags replace any list. A variant may not change a grid dimension (`GRID`).
`check_study` then applies every grid value, every variant and every combination of
them (the seed aside) to the base scenario, each validated like a file; an error names
the study file's key or the flag the value came from. Sizes are bounded before anything
is expanded (MAX_SEEDS, MAX_RUNS, MAX_CELLS).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.scenario import (
    FLEET_FIELDS,
    NAME_PATTERN,
    ROAD_FIELDS,
    SCENARIO_FIELDS,
    SV_FIELDS,
    TRAFFIC_FIELDS,
    Scenario,
    apply_overrides,
    load_scenario,
    override_target,
    read_toml,
)
from cosim.study.run_table import Driver
from cosim.validation import (
    MISSING,
    Field,
    check_known_tables,
    check_table,
    not_a_file,
    validate_table,
)

MAX_RUNS = 100_000  # runs in one study: a bigger grid is refused before it is expanded
MAX_SEEDS = 100_000  # seeds in one study (seed_count, or a flag's range A-B)
MAX_CELLS = 10_000  # combinations of grid values besides the seed (each checked up front)


def _scenario_field(fields: tuple[Field, ...], key: str) -> Field:
    return next(f for f in fields if f.key == key)


# One element of each grid list, checked with the scenario files' own rules.
DENSITY = _scenario_field(TRAFFIC_FIELDS, "density_veh_per_km_lane")
SEED = _scenario_field(SCENARIO_FIELDS, "seed")
OCCUPANT = _scenario_field(SV_FIELDS, "occupant")
MU = _scenario_field(ROAD_FIELDS, "mu")
SHARE = _scenario_field(FLEET_FIELDS, "share")  # the automated vehicles' ([fleet])
FLEET_DRIVER = _scenario_field(FLEET_FIELDS, "driver")  # who drives them
# A *driver* is a controller with a lane-change policy: mimo / siso fly the base scenario's
# policy (and each variant's), sumo is SUMO's own models for both (it runs no variant):
# the grid's `drivers` are named by their controller.
DRIVER = _scenario_field(SV_FIELDS, "controller")
PLANT = _scenario_field(SV_FIELDS, "plant")
DURATION = _scenario_field(SCENARIO_FIELDS, "duration_s")


def _list_of(element: Field) -> Any:
    """A `parse` for a non-empty list of distinct values, each checked by `element`."""

    def parse(source: str, key: str, value: Any) -> tuple[Any, ...]:
        allowed = f"a non-empty list of distinct values, each {element.allowed()}"
        if not isinstance(value, list) or not value:
            raise InputError(source, key, value, allowed)
        out = tuple(element.convert(source, f"{key}[{i}]", v) for i, v in enumerate(value))
        if len(set(out)) != len(out):
            raise InputError(source, key, value, allowed)
        return out

    return parse


# Grid dimensions: study attribute -> (override name, file key, flag). A variant may not
# change one of them (its rows would be labelled with the grid's value, not the run's).
GRID = {
    "densities": ("density", "densities_veh_per_km_lane", "--densities"),
    "seeds": ("seed", "seeds", "--seeds"),
    "occupants": ("occupant", "occupants", "--occupants"),
    "mus": ("mu", "mu", "--mu"),
    "shares": ("share", "shares", "--shares"),
    "fleet_drivers": ("fleet_driver", "fleet_drivers", "--fleet-drivers"),
    "drivers": ("controller", "drivers", "--drivers"),
    "plants": ("plant", "plants", "--plants"),
    "duration": ("duration", "duration_s", "--duration"),
}
_GRID_KEYS = {override_target(o)[:2]: o for o, _, _ in GRID.values()}
FLAG_SOURCE = "command line"


def _parse_variants(source: str, key: str, value: Any) -> dict[str, dict[str, Any]]:
    """name -> {override name: value}; the names must be scenario overrides that are not
    grid dimensions; the values are checked against the base scenario by `check_study`."""
    allowed = ("a table of variants, each name = {override = value, ...} "
               "(names of cosim.scenario.OVERRIDES or dotted file keys)")
    if not isinstance(value, dict) or not value:
        raise InputError(source, key, value, allowed)
    out: dict[str, dict[str, Any]] = {}
    for name, overrides in value.items():
        if not re.fullmatch(r"[A-Za-z0-9_.-]{1,40}", name) or not isinstance(overrides, dict):
            raise InputError(source, f"{key}.{name}", overrides, allowed)
        for k, v in overrides.items():
            if not isinstance(v, (bool, int, float, str)):
                raise InputError(source, f"{key}.{name}.{k}", v, "a number, string or boolean")
            try:
                target = override_target(k)[:2]
            except KeyError:
                continue  # an unknown name: check_study says so, with a suggestion
            if target in _GRID_KEYS:
                raise InputError(
                    source, f"{key}.{name}.{k}", v,
                    f"an override of something other than a grid dimension ({k} is the "
                    f"grid's {_GRID_KEYS[target]}: list its values in [study] instead)",
                )
        out[name] = dict(overrides)
    return out


def _describe(element: Field) -> str:
    return f"a non-empty list of distinct values, each {element.allowed()}"


STUDY_FIELDS = (
    Field("name", str, pattern=NAME_PATTERN, default="study"),
    Field("description", str, default=""),
    Field("scenario", str),
    Field("densities_veh_per_km_lane", list, name="densities", parse=_list_of(DENSITY),
          describe=_describe(DENSITY)),
    Field("seeds", list, parse=_list_of(SEED), describe=_describe(SEED), default=None),
    Field("seed_count", int, lo=1, hi=MAX_SEEDS, default=None),
    Field("occupants", list, parse=_list_of(OCCUPANT), describe=_describe(OCCUPANT), default=None),
    Field("mu", list, name="mus", parse=_list_of(MU), describe=_describe(MU), default=None),
    Field("shares", list, parse=_list_of(SHARE), describe=_describe(SHARE), default=None),
    Field("fleet_drivers", list, parse=_list_of(FLEET_DRIVER), describe=_describe(FLEET_DRIVER),
          default=None),
    Field("drivers", list, parse=_list_of(DRIVER), describe=_describe(DRIVER), default=None),
    Field("plants", list, parse=_list_of(PLANT), describe=_describe(PLANT), default=None),
    replace(DURATION, name="duration", default=None),
    Field("traces", bool, default=False),
    Field("variants", dict, parse=_parse_variants, default=None,
          describe="a table of named scenario-override sets"),
)


@dataclass(frozen=True)
class Study:
    """A grid of runs. `None` lists take the base scenario's single value."""

    path: Path | None  # the study file (None: built from flags)
    name: str
    description: str
    scenario: Path  # base scenario file
    densities: tuple[float, ...]  # veh per km per lane
    seeds: tuple[int, ...]
    occupants: tuple[float, ...] | None  # -, p
    mus: tuple[float, ...] | None  # -, road friction
    drivers: tuple[str, ...] | None  # SV drivers, named by their controller (below)
    plants: tuple[str, ...] | None
    duration: float | None  # s, simulated time of every run (None: the scenario's)
    traces: bool  # keep each run's trace files
    shares: tuple[float, ...] | None = None  # -, [fleet] share (automated vehicles)
    fleet_drivers: tuple[str, ...] | None = None  # [fleet] driver
    variants: dict[str, dict[str, Any]] | None = None  # name -> scenario overrides
    # attribute -> (source, key) that set it: error messages name the file key or the flag
    origins: dict[str, tuple[str, str]] = field(default_factory=dict, compare=False)

    def with_flags(self, **changes: Any) -> Study:
        """The study with the given fields replaced (None values are ignored); the values
        are the command line's from now on (`--name` is checked here)."""
        given = {k: v for k, v in changes.items() if v is not None}
        if "name" in given and not re.fullmatch(NAME_PATTERN, str(given["name"])):
            raise InputError(FLAG_SOURCE, "--name", given["name"],
                             f"a folder name matching {NAME_PATTERN}")
        origins = dict(self.origins)
        for k in given:
            if k in GRID:
                origins[k] = (FLAG_SOURCE, GRID[k][2])
        return replace(self, **given, origins=origins)

    @property
    def size(self) -> int:
        n = len(self.densities) * len(self.seeds)
        for values in (self.occupants, self.mus, self.shares, self.fleet_drivers,
                       self.drivers, self.plants, self.variants):
            n *= len(values) if values else 1
        return n


def load_study(path: str | Path) -> Study:
    """Read and validate a study file; the base scenario path is resolved
    relative to the study file and must exist."""
    path = Path(path)
    return study_from_dict(read_toml(path, "study"), path)  # bounded in size and nesting


def study_from_dict(doc: Any, path: Path) -> Study:
    """Validate a study document (the parsed TOML) read from `path`."""
    source = str(path)
    check_table(source, "", doc)
    if "study" not in doc and {"scenario", "sv"} <= set(doc):
        raise InputError(source, "[study]", MISSING,
                         "a study file (this is a scenario: run a grid on it with "
                         "cosim batch --scenario FILE --densities LIST --seeds LIST)")
    check_known_tables(source, doc, ["study"])
    if "study" not in doc:
        raise InputError(source, "study", None, "required: a [study] table")
    raw = check_table(source, "study", doc["study"])
    values = validate_table(source, "study", raw, STUDY_FIELDS)
    if values["seeds"] is not None and values["seed_count"] is not None:
        raise InputError(source, "study.seed_count", values["seed_count"],
                         "either seeds or seed_count, not both")
    if values["seeds"] is None:
        if values["seed_count"] is None:
            raise InputError(source, "study.seeds", None, "required: seeds or seed_count")
        values["seeds"] = tuple(range(1, values["seed_count"] + 1))
    del values["seed_count"]
    scenario = Path(values.pop("scenario"))
    if not scenario.is_absolute():
        scenario = path.parent / scenario
    problem = not_a_file(scenario)
    if problem is not None:
        raise InputError(source, "study.scenario", str(scenario),
                         "not found (a scenario file, .toml)" if problem == "not found"
                         else f"a scenario file (this is {problem})")
    origins = {attr: (source, f"study.{GRID[attr][1]}") for attr in GRID
               if values.get(attr) is not None}
    if "seed_count" in raw:
        origins["seeds"] = (source, "study.seed_count")
    return Study(path=path, scenario=scenario, origins=origins, **values)


def check_seed_count(source: str, key: str, value: Any, count: int) -> None:
    """Refuse more than MAX_SEEDS seeds before any list of them is made."""
    if count > MAX_SEEDS:
        raise InputError(source, key, value, f"at most {MAX_SEEDS} seeds ({count} given)")


def check_study(study: Study) -> Scenario:
    """Everything about a study that can be known before it runs; returns the base scenario.

    The grid is bounded (MAX_RUNS) before it is expanded; every grid value and every
    variant is applied to the base scenario and validated like a file, and an error names
    where the value came from: the study file's key or the command-line flag."""
    base = load_scenario(study.scenario)
    where = str(study.path) if study.path is not None else FLAG_SOURCE
    if study.size > MAX_RUNS:
        raise InputError(where, "study", f"{study.size} runs",
                         f"a grid of at most {MAX_RUNS} runs (fewer seeds or values)")

    def apply(changes: dict[str, Any], source: str, key: str, value: Any) -> None:
        try:
            apply_overrides(base, changes, source)
        except InputError as exc:
            if exc.source == source and exc.key in changes:  # an unknown override name
                raise InputError(source, f"{key}.{exc.key}", exc.value, exc.allowed) from None
            raise InputError(source, key, value,
                             f"a value the base scenario {study.scenario} allows (with this one "
                             f"its {exc.key} = {exc.value!r} is refused: {exc.allowed})") from None

    for attr, (override, file_key, _flag) in GRID.items():
        values = getattr(study, attr)
        if values is None:
            continue
        source, key = study.origins.get(attr, (where, f"study.{file_key}"))
        if attr == "duration":
            apply({override: values}, source, key, values)
            continue
        for i, value in enumerate(values):
            apply({override: value}, source, key if key.startswith("--") else f"{key}[{i}]",
                  value)
    for name, overrides in (study.variants or {}).items():
        apply(overrides, where, f"study.variants.{name}", overrides)
    _check_cells(study, base, where)
    return base


def _check_cells(study: Study, base: Scenario, where: str) -> None:
    """Every combination of grid values (the seed aside: no rule depends on it) and variant,
    validated like a file: values fine one by one may clash together (a variant's speed
    and the grid's duration, ...). Bounded by MAX_CELLS."""
    dims: list[list[tuple[str, Any]]] = []
    for attr, (override, _, _) in GRID.items():
        values = getattr(study, attr)
        if attr == "seeds" or values is None:
            continue
        values = (values,) if attr == "duration" else values
        dims.append([(override, v) for v in values])
    variants = list((study.variants or {}).items()) or [("", {})]
    n = len(variants) * math.prod(len(d) for d in dims)
    if n > MAX_CELLS:
        raise InputError(where, "study", f"{n} combinations",
                         f"at most {MAX_CELLS} combinations of grid values besides the seed")
    for variant, overrides in variants:
        for cell in itertools.product(*dims):
            changes = dict(cell)
            if changes.get("controller") != Driver.SUMO:  # the SUMO driver runs no variant
                changes.update(overrides)
            try:
                apply_overrides(base, changes, where)
            except InputError as exc:
                what = {k: v for k, v in cell} | ({"variant": variant} if variant else {})
                raise InputError(
                    where, "study", what,
                    f"grid values that go together: this combination breaks the base scenario "
                    f"{study.scenario} ({exc.key} = {exc.value!r}: {exc.allowed})",
                ) from None
