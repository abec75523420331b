"""Random traffic the road cannot take is refused: a density above what a lane holds at
standstill (1000 m over the TVs' length plus minGap) is one line naming the figure, and
nothing runs; at or below it the scenario loads."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.cli import main
from cosim.scenario import load_scenario
from cosim.traffic.demand import TV_MIN_GAP
from cosim.traffic.traffic_vehicles import TV_LENGTH

BASE = Path(__file__).resolve().parents[1] / "bad_inputs" / "base.toml"
CAPACITY = 1000.0 / (TV_LENGTH + TV_MIN_GAP)  # veh/km/lane at standstill


def _scenario(folder: Path, density: float) -> Path:
    path = folder / "dense.toml"
    path.write_text(BASE.read_text() + f"\n[traffic]\ndensity_veh_per_km_lane = {density}\n")
    return path


def test_a_density_above_standstill_is_refused(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    scenario = _scenario(tmp_path, 150.0)
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "traffic.density_veh_per_km_lane = 150.0" in err, err
    assert f"at most {CAPACITY:.1f} veh/km/lane" in err and "at standstill" in err, err
    assert not out.exists()


def test_a_density_the_lanes_hold_loads(tmp_path: Path) -> None:
    assert CAPACITY >= 146.0
    assert load_scenario(_scenario(tmp_path, 146.0)).traffic.density == 146.0
