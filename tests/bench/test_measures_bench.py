"""`cosim bench measures`: every case runs the same dense scenario, changed only by its
measures' keys, in turn within each repeat; the table and the ratios come out of it."""

from __future__ import annotations

import argparse

from cosim.bench import report
from cosim.bench.measures import (
    CASES,
    DEFAULT_FLEET_SCENARIO,
    FLEET_CASES,
    TARGETS,
    measure,
    repeated,
)
from cosim.scenario import load_scenario, project_root, with_overrides


def test_cases_alternate_and_differ_only_by_their_measures() -> None:
    base = with_overrides(load_scenario(project_root() / "scenarios/traffic_high.toml"),
                          duration=2.0)
    cases = {key: with_overrides(base, **keys) for key, _, keys in CASES}
    order: list[str] = []

    def fake(scenario):  # type: ignore[no-untyped-def]
        key = next(k for k, s in cases.items() if s == scenario) if scenario.duration == 2.0 \
            else "warm-up"
        order.append(key)
        return 1.0, 2.0

    walls, cpus = repeated(cases, 2, run=fake)
    assert order == ["warm-up", *cases, *cases]
    assert all(v == [2.0, 2.0] for v in cpus.values()) and set(walls) == set(cases)
    assert not cases["plain"].detectors.enabled
    assert cases["detectors"].detectors.enabled
    assert cases["detectors"].detectors.areas == "none"
    assert cases["lanes"].detectors.areas == "lanes"
    assert cases["stretches"].detectors.areas == "stretches"
    assert cases["ssm"].ssm.enabled and cases["ssm"].ssm.vehicles == "all"
    assert cases["ssm_sv"].ssm.vehicles == "sv"
    for key in cases:  # nothing else differs
        assert with_overrides(cases[key], **{
            "detectors.enabled": False, "detectors.areas": "none", "ssm.enabled": False,
            "ssm.vehicles": "all"}) == cases["plain"]


def test_the_fleets_cases_differ_only_by_who_carries_the_device() -> None:
    """The fleet's cases: its own demand with [fleet] vtypes, SSM off, on every vehicle, on
    the SV and the AVs; a warm-up run of the fleet too, before the cases alternate."""
    base = load_scenario(project_root() / DEFAULT_FLEET_SCENARIO)
    assert base.fleet.vtypes and base.demand is not None
    cases = {key: with_overrides(base, **keys) for key, _, keys in FLEET_CASES}
    assert not cases["fleet"].ssm.enabled
    assert [cases[k].ssm.vehicles for k in ("fleet_ssm", "fleet_ssm_fleet")] == ["all", "fleet"]
    for key in cases:
        assert with_overrides(cases[key], **{"ssm.enabled": False, "ssm.vehicles": "all"}
                              ) == with_overrides(cases["fleet"], **{"ssm.vehicles": "all"})
    order: list[str] = []
    repeated(cases, 1, run=lambda sc: order.append(sc.duration) or (1.0, 1.0),  # type: ignore[func-returns-value]
             warm=("fleet",))
    assert order == [1.0, 1.0, *(base.duration for _ in cases)]


def test_a_short_measure_gives_a_row_per_case_and_the_ratios() -> None:
    args = argparse.Namespace(scenario=None, duration=0.5, repeats=1, fleet=False)
    result = measure(args)
    assert [r["case"] for r in result["rows"]] == [label for _, label, _ in CASES]
    assert all(r["cpu_s"] > 0 for r in result["rows"])
    assert set(result["targets"]) <= set(result["ratios"])
    assert set(result["targets"]) == {k for k in TARGETS if not k.startswith("fleet")}
    assert "detectors / plain (cpu): " in report(result)
