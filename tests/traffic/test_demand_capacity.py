"""Random traffic the road cannot take is refused: a density above what a lane holds at
standstill (1000 m over the TVs' length plus minGap) is one line naming the figure, and
nothing runs; at or below it the scenario loads. What SUMO then inserts at t = 0 is in
metrics.csv (vehicles_asked, vehicles_inserted), and a shortfall is said in one line."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from cosim.cli import main
from cosim.scenario import load_scenario
from cosim.traffic.demand import TV_MIN_GAP
from cosim.traffic.traffic_vehicles import TV_LENGTH

BASE = Path(__file__).resolve().parents[1] / "bad_inputs" / "base.toml"
CAPACITY = 1000.0 / (TV_LENGTH + TV_MIN_GAP)  # veh/km/lane at standstill


def _scenario(folder: Path, density: float, duration: float = 10.0) -> Path:
    path = folder / "dense.toml"
    text = BASE.read_text().replace("duration_s = 10.0", f"duration_s = {duration}")
    path.write_text(text + f"\n[traffic]\ndensity_veh_per_km_lane = {density}\n")
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


@pytest.mark.sumo
@pytest.mark.parametrize("density", [40.0, 140.0])
def test_what_sumo_inserted_is_recorded_and_a_shortfall_said(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], density: float) -> None:
    out = tmp_path / "out"
    assert main(["run", str(_scenario(tmp_path, density, duration=2.5)), "--out", str(out),
                 "--no-figures"]) == 0
    row = pd.read_csv(out / "metrics.csv").iloc[0]
    asked, inserted = int(row["vehicles_asked"]), int(row["vehicles_inserted"])
    err = capsys.readouterr().err
    sc = load_scenario(_scenario(tmp_path, density))
    # the SV's zones keep a few places free: at least 90 % of density x length x lanes
    assert asked >= 0.9 * density * sc.traffic.length / 1000.0 * sc.road.n_lanes
    said = [line for line in err.splitlines() if "vehicles asked for" in line]
    if density < 100.0:  # room for everyone (docs/outputs.md: 436 of 436 at 100)
        assert inserted == asked and not said, err
    else:  # no room at SUMO's minimum gap for most
        assert inserted < 0.5 * asked, (asked, inserted)
        assert said == [f"cosim run: bad-input-base: [traffic] density_veh_per_km_lane = "
                        f"{density:g}: SUMO inserted {inserted} of the {asked} vehicles asked "
                        "for at t = 0 (no room at its minimum gap); the run went on with fewer"]
