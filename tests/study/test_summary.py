"""A study's summary (cosim/study/summary.py) and its tables (cosim/study/report.py): the
confidence intervals against published values, the rates over the finished runs with
failed and unfinished runs apart, both collision checks, and summary.md and the density
figure showing the same statistics."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.study.intervals import mean_ci, median_ci, wilson
from cosim.study.report import summary_markdown
from cosim.study.run_table import RunStatus
from cosim.study.summary import summarize


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
        "status": [RunStatus.OK, RunStatus.OK, RunStatus.OK, RunStatus.FAILED],
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


def test_median_interval_respects_positive_quantities() -> None:
    """Few, spread durations: the old t interval of the mean went below zero
    ("2.40 (-4.59-9.39)"); the median's interval is made of observed values."""
    low_values = np.array([0.4, 4.4, np.nan])
    assert mean_ci(low_values)[1] < 0  # the problem the median interval avoids
    median, low, high, coverage = median_ci(low_values)
    assert (median, low, high) == (pytest.approx(2.4), 0.4, 4.4)
    assert coverage == pytest.approx(0.5)
    x = np.arange(1.0, 21.0)  # n = 20: (x_(6), x_(15)), coverage 95.9 %
    median, low, high, coverage = median_ci(x)
    assert (median, low, high) == (10.5, 6.0, 15.0)
    assert coverage == pytest.approx(0.9586, abs=1e-4)
    rng = np.random.default_rng(1)
    skewed = rng.lognormal(0.0, 1.5, size=40)
    _, low, high, coverage = median_ci(skewed)
    assert 0 < low < np.median(skewed) < high and coverage >= 0.95
    assert all(math.isnan(v) for v in median_ci(np.array([np.inf])))


def test_summary_table_and_plot_show_the_median_without_minus_like_hyphens(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    runs = pd.DataFrame({
        "driver": ["mimo"] * 2, "plant": ["twotrack"] * 2, "occupant": [0.5] * 2,
        "mu": [0.8] * 2, "density": [10.0] * 2, "seed": [1, 2],
        "status": [RunStatus.OK] * 2, "lane_change_completed": [True, True],
        "collision": [False, False], "lane_change_duration_s": [0.4, 4.4],
        "min_ttc_s": [1.0, 61.0], "collisions_sv": [0, 0],
        "follower_max_decel_mps2": [0.5, 1.5],
    })
    summary = summarize(runs)
    row = summary.iloc[0]
    assert row["min_ttc_s_ci_low"] > 0 and row["lc_duration_s_ci_low"] > 0
    text = summary_markdown(summary)
    assert "2.40 [0.40, 4.40] (50 %)" in text and "31.00 [1.00, 61.00] (50 %)" in text
    assert "100 [34, 100]" in text
    assert "| 1.45 / 1.50 |" in text  # the new follower's decel: p95 / max
    data_row = text.splitlines()[2]
    assert "-" not in data_row.replace("| - |", "")  # no hyphen between bounds
    from cosim.plots import batch as batch_plots

    assert [p for p, _ in batch_plots.PANELS] == [
        "success", "collision", "sv_collision", "follower_decel_mps2", "lc_duration_s",
        "min_ttc_s"]
    import matplotlib.axes

    drawn: list[float] = []  # the first point of each panel's line
    real = matplotlib.axes.Axes.errorbar

    def errorbar(self, x, y, **kw):  # type: ignore[no-untyped-def]
        drawn.append(float(y[0]))
        return real(self, x, y, **kw)

    monkeypatch.setattr(matplotlib.axes.Axes, "errorbar", errorbar)
    assert batch_plots.plot_summary(summary, tmp_path) == [tmp_path / "density.png"]
    # rates, p95 and medians as the table
    assert drawn == pytest.approx([100.0, 0.0, 0.0, 1.45, 2.4, 31.0])
    # the format is the caller's (cosim batch --figure-format), not a module setting
    svg = batch_plots.plot_summary(summary, tmp_path, fmt="svg")
    assert svg == [tmp_path / "density.svg"] and "<svg" in svg[0].read_text()
    assert (tmp_path / "density.png").read_bytes()[:4] == b"\x89PNG"


def test_summary_counts_unfinished_apart_and_shows_both_collision_checks() -> None:
    """A lane change the run's end cut short is neither a success nor a failure: the
    success rate is over the finished runs; SUMO's collisions are a rate of their own,
    beside ours, in summary.csv and summary.md."""
    runs = pd.DataFrame({
        "driver": ["sumo"] * 4, "plant": ["none"] * 4, "occupant": [0.5] * 4,
        "mu": [0.8] * 4, "density": [30.0] * 4, "seed": [1, 2, 3, 4],
        "status": [RunStatus.OK] * 4, "lane_change_completed": [1, 0, 0, 1],
        "lane_change_unfinished": [0, 1, 1, 0], "collision": [0, 0, 0, 0],
        "sumo_collision": [0, 1, 0, 0], "collisions_sv": [0, 0, 0, 0],
        "lane_change_duration_s": [3.0, np.nan, np.nan, 3.1], "min_ttc_s": [5.0] * 4,
    })
    summary = summarize(runs)
    row = summary.iloc[0]
    assert row["unfinished"] == 2 and row["success_rate"] == 1.0
    assert (row["success_ci_low"], row["success_ci_high"]) == wilson(2, 2)
    assert row["collision_rate"] == 0.0 and row["sumo_collision_rate"] == 0.25
    text = summary_markdown(summary)
    assert "unfinished" in text.splitlines()[0] and "SUMO's" in text.splitlines()[0]
    cells = [c.strip() for c in text.splitlines()[2].split("|")]
    assert cells[4:7] == ["2", "100 [34, 100]", "0 [0, 49] (25)"]


def test_summary_table_names_the_fleet_driver_where_it_varies() -> None:
    """A penetration study's cells differ by who drives the automated vehicles: without
    that column its rows of one share and density read alike."""
    runs = pd.DataFrame({
        "driver": ["mimo"] * 4, "plant": ["twotrack"] * 4, "occupant": [0.5] * 4,
        "mu": [0.8] * 4, "density": [30.0] * 4, "seed": [1, 2, 1, 2], "share": [0.2] * 4,
        "fleet_driver": ["cosim", "cosim", "acc", "acc"], "status": [RunStatus.OK] * 4,
        "collision": [0, 0, 0, 0], "min_ttc_s": [5.0] * 4,
    })
    lines = summary_markdown(summarize(runs)).splitlines()
    column = [c.strip() for c in lines[0].split("|")].index("fleet_driver")
    assert sorted(line.split("|")[column].strip() for line in lines[2:]) == ["acc", "cosim"]


def test_ssm_counts_get_a_mean_and_its_interval_only_where_measured() -> None:
    """SUMO's SSM counts per run (metrics.csv, [ssm]): per cell their mean over the
    finished runs with its Student-t interval; a study without them gets no such
    columns."""
    runs = pd.DataFrame({
        "driver": ["mimo"] * 4, "plant": ["twotrack"] * 4, "occupant": [0.5] * 4,
        "mu": [0.8] * 4, "density": [10.0] * 4, "seed": [1, 2, 3, 4],
        "status": [RunStatus.OK] * 3 + [RunStatus.FAILED],
        "lane_change_completed": [True] * 3 + [None], "collision": [False] * 3 + [None],
        "ssm_conflicts": [1, 2, 3, None], "ssm_ttc_conflicts": [0, 0, 3, None],
    })
    row = summarize(runs).iloc[0]
    assert row["ssm_conflicts_mean"] == 2.0
    assert row["ssm_conflicts_ci_high"] - 2.0 == pytest.approx(4.302653 / 3**0.5, rel=1e-6)
    assert row["ssm_ttc_conflicts_mean"] == 1.0
    assert "ssm_drac_conflicts_mean" not in row
    assert not [c for c in summarize(runs.drop(columns=["ssm_conflicts",
                                                        "ssm_ttc_conflicts"])).columns
                if c.startswith("ssm_")]
