"""The automated vehicles' share as a grid dimension (cosim.study.spec, grid,
cosim.commands.batch) and its summary (cosim.study.fleet_summary, cosim.study.report's
fleet.md, cosim.plots.share): a tiny real batch over two shares, the flag's errors, and
the per-cell means with their intervals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.cli import main
from cosim.study.fleet_summary import fleet_summary
from cosim.study.grid import GridValues, expand

DATA = Path(__file__).parents[1] / "data"
BASE = DATA / "batch_base.toml"


@pytest.fixture(scope="module")
def batch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Shares 0 and 0.5 at one density and seed, 6 s: the inflow's first vehicles are
    inserted and taken over within the run."""
    out = tmp_path_factory.mktemp("shares") / "out"
    assert main(["batch", "--scenario", str(BASE), "--densities", "20", "--seeds", "1",
                 "--shares", "0,0.5", "--drivers", "mimo", "--duration", "6", "--workers",
                 "1", "--no-progress", "-o", str(out)]) == 0
    return out


def test_a_batch_over_shares_labels_runs_and_summarises_each_share(batch: Path) -> None:
    runs = pd.read_csv(batch / "runs.csv")
    assert sorted(runs["share"]) == [0.0, 0.5] and (runs["status"] == "ok").all()
    fleet = runs.set_index("share")["fleet_vehicles"]
    assert np.isnan(fleet[0.0]) and fleet[0.5] >= 1  # no fleet at share 0; AVs at 0.5
    summary = pd.read_csv(batch / "summary.csv").set_index("share")
    assert summary.loc[0.5, "fleet_vehicles_mean"] == fleet[0.5]
    assert summary.loc[0.5, "fleet_vehicles_n"] == 1
    table = (batch / "fleet.md").read_text().splitlines()
    assert len(table) == 4 and table[0].startswith("| share |")
    assert (batch / "plots" / "share.png").stat().st_size > 0


def test_share_zero_keeps_the_run_ids_of_a_grid_without_shares() -> None:
    grid = GridValues(densities=[10], seeds=[1], occupants=[0.5], mus=[0.8],
                      drivers=["mimo"], plants=["twotrack"])
    (plain,) = expand(BASE, grid)
    (zero,) = expand(BASE, GridValues(**{**grid.__dict__, "shares": [0.0]}))
    (some,) = expand(BASE, GridValues(**{**grid.__dict__, "shares": [0.1]}))
    assert plain.run_id == zero.run_id != some.run_id


@pytest.mark.parametrize("value", ["0,1.5", "x", "0.1,0.1", "-0.1", ""])
def test_bad_shares_are_one_line_input_errors(tmp_path: Path, value: str,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["batch", "--scenario", str(BASE), "--densities", "5", "--seeds", "1",
                 f"--shares={value}", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--shares" in err[0]
    assert not out.exists()


def test_a_share_key_the_scenario_refuses_names_the_study_key(tmp_path: Path) -> None:
    """A share with SUMO's driver for the SV (no driver of ours for the fleet) is refused
    before anything runs, naming the study file's key."""
    study = tmp_path / "s.toml"
    study.write_text(f'[study]\nscenario = "{BASE}"\ndensities_veh_per_km_lane = [5]\n'
                     'seeds = [1]\nshares = [0, 0.2]\ndrivers = ["sumo"]\n')
    assert main(["batch", str(study), "-o", str(tmp_path / "out")]) == 2


def test_fleet_summary_means_ratios_and_intervals() -> None:
    ok = pd.DataFrame({"fleet_vehicles": [4, 6, 0], "fleet_lane_changes": [2, 3, 0],
                       "ssm_conflicts": [3, 5, 4], "vehicle_km": [10.0, 10.0, 20.0]})
    row = fleet_summary(ok)
    assert row["fleet_vehicles_mean"] == pytest.approx(10 / 3)
    # per AV: 0.5 in both runs with AVs (a run with none has no ratio), no spread
    assert row["fleet_lane_changes_per_vehicle_n"] == 2
    assert row["fleet_lane_changes_per_vehicle_mean"] == pytest.approx(0.5)
    assert row["fleet_lane_changes_per_vehicle_ci_low"] == pytest.approx(0.5)
    assert row["ssm_conflicts_per_vehicle_km_mean"] == pytest.approx((0.3 + 0.5 + 0.2) / 3)
    low, high = row["ssm_conflicts_per_vehicle_km_ci_low"], row[
        "ssm_conflicts_per_vehicle_km_ci_high"]
    assert low < 1 / 3 < high
    assert "outflow_veh_per_h_mean" not in row  # runs without detectors: no column
