"""A study's grid as runs: `expand` turns the grid values into `RunSpec`s, one per
combination. A run's id is a hash of its parameters and of the base scenario file's
bytes, so the same grid always gives the same ids and a resumed study knows exactly
which runs are done. `apply_spec` turns a run into its scenario."""

from __future__ import annotations

import hashlib
import json
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.study.run_table import NO_FLEET_DRIVER, NO_PLANT, NO_VARIANT, PARAMETERS, Driver


@dataclass(frozen=True)
class RunSpec:
    """One run of a study: the base scenario and the grid values that replace its own."""

    scenario: str  # path of the base scenario file
    scenario_sha: str  # sha256 of the base scenario file's bytes
    duration: float | None  # s, simulated time (None: the scenario's own)
    driver: str  # SV controller: a `Driver`
    plant: str  # "twotrack" | "bicycle" | NO_PLANT (the SUMO-native driver)
    occupant: float  # -, p in [0, 1]
    mu: float  # -, road friction
    density: float  # veh per km per lane
    seed: int  # SUMO and traffic seed
    traces: bool = False  # keep the run's trace and metrics files
    variant: str = NO_VARIANT  # name of a set of scenario overrides (study `variants`)
    overrides: tuple[tuple[str, Any], ...] = ()  # the variant's (override name, value) pairs
    share: float = 0.0  # -, [fleet] share: the automated vehicles' share of the inserted
    fleet_driver: str = NO_FLEET_DRIVER  # [fleet] driver: who drives them

    @property
    def run_id(self) -> str:
        """12 hex digits of a hash of everything that determines the run's result."""
        key = {
            "scenario_sha": self.scenario_sha,
            "duration": None if self.duration is None else float(self.duration),
            **{name: getattr(self, name) for name in PARAMETERS},
        }
        key["occupant"] = float(key["occupant"])
        key["mu"] = float(key["mu"])
        key["density"] = float(key["density"])
        key["seed"] = int(key["seed"])
        key["share"] = float(key["share"])
        if key["share"] == 0.0:
            del key["share"]  # a run without automated vehicles: the id of before shares
        if key["fleet_driver"] == NO_FLEET_DRIVER:
            del key["fleet_driver"]  # likewise: the ids of studies before fleet drivers
        if self.variant == NO_VARIANT:
            del key["variant"]  # a run without a variant: its id does not name the field
        else:
            key["overrides"] = [list(pair) for pair in self.overrides]
        text = json.dumps(key, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    def parameters(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in PARAMETERS}


@dataclass(frozen=True)
class GridValues:
    """The values of every grid dimension (none left to the base scenario)."""

    densities: Sequence[float]  # veh per km per lane
    seeds: Sequence[int]
    occupants: Sequence[float]  # -, p
    mus: Sequence[float]  # -, road friction
    drivers: Sequence[str]  # `Driver`s
    plants: Sequence[str]  # plants of our drivers (the SUMO-native driver runs NO_PLANT)
    shares: Sequence[float] = (0.0,)  # -, [fleet] share
    fleet_drivers: Sequence[str] = (NO_FLEET_DRIVER,)  # [fleet] driver
    # share 0 draws no vehicle automated (no [fleet] vtypes): one run, labelled with the
    # first fleet driver, stands for every fleet driver's
    zero_share_once: bool = True
    duration: float | None = None  # s, simulated time of every run (None: the scenario's)
    # name -> scenario overrides (`cosim.scenario.with_overrides` names): one more grid
    # dimension for our drivers; the SUMO-native driver runs once, as the base scenario
    variants: Mapping[str, Mapping[str, Any]] | None = None


def file_sha(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def expand(scenario: str | Path, grid: GridValues, *, traces: bool = False) -> list[RunSpec]:
    """The grid as RunSpecs, in a fixed shuffled order (so the time left shown while the
    study runs is not skewed by running all dense cases last). `traces`: every run keeps
    its trace files."""
    sha = file_sha(scenario)
    named = [(name, tuple(sorted(ov.items()))) for name, ov in (grid.variants or {}).items()]
    if not named:
        named = [(NO_VARIANT, ())]
    specs = [
        RunSpec(
            scenario=str(Path(scenario).resolve()), scenario_sha=sha, duration=grid.duration,
            driver=d, plant=pl, occupant=float(p), mu=float(m), density=float(k), seed=int(s),
            traces=traces, variant=v, overrides=ov, share=float(f), fleet_driver=fd,
        )
        for d in grid.drivers for pl in (grid.plants if d != Driver.SUMO else (NO_PLANT,))
        for v, ov in (named if d != Driver.SUMO else [(NO_VARIANT, ())])
        for p in grid.occupants for m in grid.mus for f in grid.shares
        for fd in (grid.fleet_drivers[:1] if f == 0.0 and grid.zero_share_once
                   else grid.fleet_drivers)
        for k in grid.densities for s in grid.seeds
    ]
    ids = [s.run_id for s in specs]
    if len(set(ids)) != len(ids):
        raise InputError(str(scenario), "grid", "repeated values", "each grid value once")
    random.Random(0).shuffle(specs)
    return specs


def apply_spec(spec: RunSpec) -> Any:
    """The base scenario with the run's grid values in place."""
    from cosim.scenario import load_scenario, with_overrides

    # The run id names the base scenario's bytes: a file edited while the study
    # runs would give results under the wrong id, so such a run fails instead.
    if file_sha(spec.scenario) != spec.scenario_sha:
        raise InputError(
            spec.scenario, "file", "(edited)",
            "the base scenario as it was when the study started; run the study again "
            "to run the edited scenario under new run ids",
        )
    scenario = load_scenario(spec.scenario)
    changes: dict[str, Any] = {
        "seed": spec.seed,
        "density": spec.density,
        "occupant": spec.occupant,
        "mu": spec.mu,
        "controller": spec.driver,
        "share": spec.share,
        "fleet_driver": spec.fleet_driver,
    }
    if spec.plant != NO_PLANT:
        changes["plant"] = spec.plant
    changes.update(dict(spec.overrides))
    if spec.duration is not None:
        changes["duration"] = spec.duration
    return with_overrides(scenario, **changes)
