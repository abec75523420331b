"""`cosim bench fleet`'s parts on a short run: a run counts the AVs it drove, and the
part split times the fleet's four methods."""

from __future__ import annotations

import argparse

import pytest

from cosim.bench.fleet import (
    PARTS,
    avs_flag,
    fleet_floor,
    fleet_window_run,
    measure_avs,
    part_split,
    shares_flag,
)
from cosim.scenario import load_scenario, project_root, with_overrides


def test_a_short_fleet_run_and_its_part_split() -> None:
    sc = with_overrides(load_scenario(project_root() / "scenarios/fleet_share20.toml"),
                        duration=5.0, density=12.0, traffic_length=1000.0,
                        **{"fleet.share": 1.0})
    parts, (wall, cpu, steps, av_steps, avs) = part_split(sc)
    assert wall > 0 and cpu > 0 and steps == sc.n_steps + 1
    assert avs >= 1 and avs <= av_steps < avs * steps  # each AV: rows from its takeover on
    assert set(parts) == set(PARTS) and all(v > 0 for v in parts.values())
    assert sum(parts.values()) < cpu  # parts of that run (CPU time)


def test_shares_flag() -> None:
    assert shares_flag("0,0.1,0.4") == (0.0, 0.1, 0.4)
    for bad in ("", "0,x", "1.5", "-0.1"):
        with pytest.raises(argparse.ArgumentTypeError, match="in \\[0, 1\\]"):
            shares_flag(bad)


def test_fixed_numbers_of_avs_beside_their_floor() -> None:
    """Two cases (1 and 2 AVs at once: share 1 capped by max_vehicles) on light short
    traffic: each measured over its window once N drive, never more than N, and its
    floor replays the same AVs (all found at their takeover steps)."""
    sc = with_overrides(load_scenario(project_root() / "scenarios/fleet_share20.toml"),
                        density=12.0, traffic_length=1000.0)
    window = 10  # steps
    clock, parts, result = fleet_window_run(with_overrides(
        sc, duration=30.0, **{"fleet.share": 1.0, "fleet.max_vehicles": 2}), 2, window)
    first, last = clock.span()
    assert clock.first >= 0 and last - first == window  # 2 AVs reached, window rows on
    assert max(clock.avs) == 2 and clock.avs[first] == 2  # the cap holds
    assert result.trace["t_s"][-1] == pytest.approx(last * sc.step)  # stopped there
    assert set(parts) == set(PARTS) and parts["advance"] > 0
    cpu, wall, missing = fleet_floor(sc, result, (first, last))
    assert missing == 0 and cpu > 0 and wall > 0
    out = measure_avs(sc, (1, 2), 0.25, 1)
    assert [r["case"] for r in out["rows"]] == ["N = 1", "N = 2"]
    assert all(r["floor_cpu_ms_per_step"] > 0 for r in out["rows"])
    assert "marginal CPU per AV and step (us)" in out["ratios"]


def test_avs_flag() -> None:
    assert avs_flag("1,10,100") == (1, 10, 100)
    for bad in ("", "0", "1,x", "2.5"):
        with pytest.raises(argparse.ArgumentTypeError, match="in \\[1, 1000\\]"):
            avs_flag(bad)
