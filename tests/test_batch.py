"""Batch studies (cosim/batch.py, cosim/study.py, cosim/commands/batch.py).

The study tests run the real co-simulation (libsumo) on a short scenario
(tests/data/batch_base.toml: 5 s simulated, 400 m of traffic) over the grid of
tests/data/study_small.toml (2 densities x 2 seeds x 2 drivers). The local
study is run once and is the reference of the Dask, resume and failure tests.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

from cosim.batch import (
    STATUS_FAILED,
    STATUS_OK,
    expand,
    is_timing_column,
    mean_ci,
    read_record,
    summarize,
    wilson,
    write_record,
)
from cosim.cli import main
from cosim.errors import InputError
from cosim.study import load_study

DATA = Path(__file__).parent / "data"
STUDY = DATA / "study_small.toml"
BASE = DATA / "batch_base.toml"
N_RUNS = 8  # 2 densities x 2 seeds x 2 drivers


def reproducible(path: Path) -> pd.DataFrame:
    """runs.csv without its wall-clock columns (the rest must not depend on how it ran)."""
    frame = pd.read_csv(path)
    return frame[[c for c in frame.columns if not is_timing_column(c)]]


# --------------------------------------------------------------------------- no SUMO


def test_run_ids_depend_on_parameters_and_base_scenario_only(tmp_path: Path) -> None:
    grid = dict(densities=[5, 20], seeds=[1, 2], occupants=[0.5], mus=[0.8],
                drivers=["mimo", "sumo"], plants=["twotrack"])
    a = expand(BASE, **grid)
    b = expand(BASE, **{**grid, "densities": [5.0, 20.0]}, traces=True)
    assert len({s.run_id for s in a}) == N_RUNS
    assert {s.run_id for s in a} == {s.run_id for s in b}  # 5 == 5.0; traces change nothing
    other = tmp_path / "base.toml"
    other.write_text(BASE.read_text() + "\n# edited\n")
    assert not {s.run_id for s in a} & {s.run_id for s in expand(other, **grid)}
    c = expand(BASE, **grid, duration=3.0)
    assert not {s.run_id for s in a} & {s.run_id for s in c}


def test_wilson_interval_matches_published_values() -> None:
    # Wilson score 95 % intervals (Newcombe 1998, table I: 0/10 and 5/10; 81/263).
    low, high = wilson(0, 10)
    assert low == 0.0 and high == pytest.approx(0.2775, abs=1e-4)
    low, high = wilson(5, 10)
    assert (low, high) == (pytest.approx(0.2366, abs=1e-4), pytest.approx(0.7634, abs=1e-4))
    low, high = wilson(81, 263)
    assert (low, high) == (pytest.approx(0.2553, abs=1e-4), pytest.approx(0.3662, abs=1e-4))
    assert all(math.isnan(v) for v in wilson(0, 0))


def test_mean_interval_is_student_t_and_ignores_nan() -> None:
    mean, low, high = mean_ci(pd.Series([1.0, 2.0, 3.0, float("nan")]).to_numpy())
    # mean 2, s = 1, n = 3: half width t(0.975, 2) / sqrt(3) = 4.3027 / 1.7321
    assert mean == 2.0
    assert high - mean == pytest.approx(4.302653 / 3**0.5, rel=1e-6)
    assert mean - low == pytest.approx(high - mean)
    assert math.isnan(mean_ci(pd.Series([1.0]).to_numpy())[1])


def test_summary_counts_failed_runs_apart_from_rates() -> None:
    runs = pd.DataFrame({
        "driver": ["mimo"] * 4, "plant": ["twotrack"] * 4, "occupant": [0.5] * 4,
        "mu": [0.8] * 4, "density": [10.0] * 4, "seed": [1, 2, 3, 4],
        "status": [STATUS_OK, STATUS_OK, STATUS_OK, STATUS_FAILED],
        "lane_change_completed": [True, True, False, None],
        "collision": [False, True, False, None],
        "lane_change_duration_s": [4.0, 6.0, float("nan"), None],
        "min_ttc_s": [3.0, 1.0, 2.0, None],
    })
    row = summarize(runs).iloc[0]
    assert (row["runs"], row["ok"], row["failed"]) == (4, 3, 1)
    assert row["success_rate"] == pytest.approx(2 / 3)
    assert row["collision_rate"] == pytest.approx(1 / 3)
    assert row["lc_duration_s_n"] == 2 and row["lc_duration_s_mean"] == 5.0
    assert row["min_ttc_s_p50"] == 2.0


def test_records_are_written_whole(tmp_path: Path) -> None:
    record = {"run_id": "abc", "status": STATUS_OK, "x": float("nan")}
    write_record(tmp_path, record)
    assert math.isnan(read_record(tmp_path, "abc")["x"])
    assert [p.name for p in (tmp_path / "runs").iterdir()] == ["abc.json"]  # no temp left


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("densities_veh_per_km_lane = [5, 500]", "densities_veh_per_km_lane[1]"),
        ("densities_veh_per_km_lane = []", "densities_veh_per_km_lane"),
        ("densities_veh_per_km_lane = [5, 5]", "densities_veh_per_km_lane"),
        ("drivers = ['mimo', 'sumo-native']", "drivers[1]"),
        ("occupants = [1.5]", "occupants[0]"),
        ("seeds = [1.5]", "seeds[0]"),
        ("densitys = [5]", "densitys"),
    ],
)
def test_bad_study_file_is_one_line_error_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, key: str
) -> None:
    lines = [ln for ln in STUDY.read_text().splitlines()
             if not ln.startswith(text.split(" ")[0] + " ")]
    study = tmp_path / "bad.toml"
    study.write_text("\n".join(lines + [text]).replace("batch_base.toml", str(BASE)) + "\n")
    with pytest.raises(InputError) as info:
        load_study(study)
    assert f"study.{key}" in str(info.value)
    out = tmp_path / "out"
    assert main(["batch", str(study), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cosim batch: error:")
    assert not out.exists()


def test_bad_flags_are_input_errors(tmp_path: Path) -> None:
    out = tmp_path / "out"
    for flags in (["--densities", "5,x"], ["--seeds", "3-1"], ["--drivers", "mpc"],
                  ["--mu", "0.05"], ["--workers", "0"]):
        assert main(["batch", str(STUDY), "-o", str(out), *flags]) == 2, flags
    assert main(["batch", "--scenario", str(BASE), "-o", str(out)]) == 2  # no densities
    assert not out.exists()


def test_flags_replace_study_lists() -> None:
    from cosim.cli import build_parser
    from cosim.commands.batch import study_from_args

    args = build_parser().parse_args(
        ["batch", str(STUDY), "--seeds", "3-5,9", "--mu", "0.4,0.8"])
    study = study_from_args(args)
    assert study.seeds == (3, 4, 5, 9) and study.mus == (0.4, 0.8)
    assert study.densities == (5.0, 20.0) and study.size == 2 * 4 * 2 * 2
