"""`cosim bench fleet`'s parts on a short run: a run counts the AVs it drove, and the
part split times the fleet's four methods."""

from __future__ import annotations

import argparse

import pytest

from cosim.bench.fleet import PARTS, _shares, part_split
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
    assert _shares("0,0.1,0.4") == (0.0, 0.1, 0.4)
    for bad in ("", "0,x", "1.5", "-0.1"):
        with pytest.raises(argparse.ArgumentTypeError, match="in \\[0, 1\\]"):
            _shares(bad)
