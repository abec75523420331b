"""The fundamental diagram of a study whose runs had SUMO's detectors
(cosim.study.fundamental, cosim.plots.fundamental): a tiny batch (2 densities x 2 seeds,
4 s, SUMO's driver) writes fundamental.csv, whose medians are runs.csv's, fundamental.md
with the capacity read off them, the traffic medians in summary.csv and
plots/fundamental.png."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.cli import main
from cosim.study.fundamental import ROAD, lane_columns

pytestmark = pytest.mark.sumo

BASE = Path(__file__).parents[1] / "data" / "fundamental_base.toml"


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fd") / "study"
    assert main(["batch", "--scenario", str(BASE), "--densities", "15,90", "--seeds", "1-2",
                 "-o", str(out), "--workers", "2", "--no-progress"]) == 0
    return out


def test_the_medians_are_the_runs(study: Path) -> None:
    runs = pd.read_csv(study / "runs.csv")
    fd = pd.read_csv(study / "fundamental.csv", keep_default_na=False)
    assert (runs.status == "ok").all() and len(runs) == 4
    assert sorted(set(fd.lane.astype(str))) == ["0", "1", "2", ROAD]
    for lane in ("1", ROAD):
        d, q, v = lane_columns(lane if lane == ROAD else int(lane))
        for density, cell in runs.groupby("density"):
            row = fd[(fd.lane.astype(str) == lane) & (fd.density == density)].iloc[0]
            assert row.runs == 2
            assert row.density_veh_per_km_p50 == pytest.approx(np.median(cell[d]))
            assert row.flow_veh_per_h_p50 == pytest.approx(np.median(cell[q]))
            assert row.speed_mps_p50 == pytest.approx(np.median(cell[v]))
    # the measured density is near the one asked for; the denser traffic is slower
    road = fd[fd.lane.astype(str) == ROAD].set_index("density")
    assert road.density_veh_per_km_p50[15.0] == pytest.approx(15.0, rel=0.25)
    assert road.density_veh_per_km_p50[90.0] == pytest.approx(90.0, rel=0.25)
    assert road.speed_mps_p50[90.0] < 0.5 * road.speed_mps_p50[15.0]
    summary = pd.read_csv(study / "summary.csv")
    for _, cell in summary.iterrows():
        mine = runs[runs.density == cell.density]
        assert cell.traffic_flow_veh_per_h_lane_p50 == pytest.approx(
            np.median(mine.traffic_flow_veh_per_h_lane))
        assert "speed_spread_space_lane2_mps_p50" in cell
    assert (study / "plots" / "fundamental.png").stat().st_size > 10_000


def test_capacity_is_the_largest_median_flow(study: Path) -> None:
    fd = pd.read_csv(study / "fundamental.csv", keep_default_na=False)
    table = (study / "fundamental.md").read_text(encoding="utf-8").splitlines()
    rows = [line.split(" | ") for line in table if line.startswith("| sumo")]
    assert len(rows) == 4  # lanes 0, 1, 2 and the road
    for row in rows:
        lane = row[5]
        mine = fd[fd.lane.astype(str) == lane]
        peak = mine.loc[mine.flow_veh_per_h_p50.idxmax()]
        assert float(row[6]) == pytest.approx(peak.flow_veh_per_h_p50, abs=0.5)
        assert float(row[7]) == pytest.approx(peak.density_veh_per_km_p50, abs=0.05)
        assert float(row[9]) == peak.density
