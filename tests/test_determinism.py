"""Runs are reproducible: the same scenario and seed give byte-identical outputs
(every file but timing.csv, which holds wall-clock times), in one process and in
another; a second simulation in the same process is not disturbed by the first;
another seed gives other traffic.

The scenario has everything random or stateful at once: random SUMO traffic, a
scripted TV changing lanes, V2V with latency and seeded message loss, and a
scripted SV lane change.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.run.loop import run_scenario
from cosim.scenario import load_scenario, with_overrides

pytestmark = pytest.mark.sumo

SCENARIO = """
[scenario]
name = "determinism"
duration_s = 3.0
seed = 3

[road]
mu = 0.8

[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0
lane_changes = [{at_s = 0.5, target_lane = 1}]

[[tv]]
id = "merger"
lane = 2
gap_m = 30.0
speed_kmh = 110.0
[tv.lane_change]
start_s = 0.2
target_lane = 1
tau_s = 3.0

[traffic]
density_veh_per_km_lane = 12.0
length_m = 400.0

[v2v]
loss = 0.3
latency_s = 0.1
"""
NOT_REPRODUCIBLE = {"timing.csv"}  # wall-clock times


def _files(folder: Path) -> dict[str, bytes]:
    return {
        p.name: p.read_bytes()
        for p in sorted(folder.iterdir())
        if p.is_file() and p.name not in NOT_REPRODUCIBLE
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Seed 3, then seed 4, then seed 3 again, all in this process."""
    root = tmp_path_factory.mktemp("determinism")
    path = root / "determinism.toml"
    path.write_text(SCENARIO)
    scenario = load_scenario(path)
    other = with_overrides(scenario, seed=4)
    out = {"scenario": path}
    for label, sc in (("first", scenario), ("other_seed", other), ("again", scenario)):
        out[label] = root / label
        run_scenario(sc, out[label], write_figures=label != "other_seed")
    return out


def test_same_seed_gives_identical_files_in_one_process(runs: dict[str, Path]) -> None:
    first, again = _files(runs["first"]), _files(runs["again"])
    assert {"trace.csv", "metrics.csv", "plans.csv"} <= set(first)
    assert set(first) == set(again)
    for name in first:
        assert first[name] == again[name], f"{name} differs between two runs of seed 3"


def test_another_seed_gives_other_traffic(runs: dict[str, Path]) -> None:
    first, other = _files(runs["first"]), _files(runs["other_seed"])
    assert first["trace.csv"] != other["trace.csv"]
    assert first["metrics.csv"] != other["metrics.csv"]


def test_same_seed_gives_identical_files_in_another_process(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    out = tmp_path / "subprocess"
    proc = subprocess.run(
        [sys.executable, "-m", "cosim.cli", "run", str(runs["scenario"]), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env={**os.environ, "PYTHONHASHSEED": "12345"},  # not the parent's hash seed
    )
    assert proc.returncode == 0, proc.stderr
    theirs, ours = _files(out), _files(runs["first"])
    assert set(theirs) == set(ours)
    for name in ours:
        assert theirs[name] == ours[name], f"{name} differs in another process"
