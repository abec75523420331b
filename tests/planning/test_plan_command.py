"""`cosim plan`: text, JSON and the figure for the paper's scenario files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cosim.cli import main

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "paper_case1_overtaking.toml"


def test_json_has_the_keys_scripts_need(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    from cosim.planning.planner import _built_tau_min_map

    _built_tau_min_map.cache_clear()  # as in a fresh process: the maps are built here
    assert main(["plan", str(CASE1), "--json", "--no-plot"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("tau_min", "tau_max", "stable", "collision_free", "tau_opt", "omega",
                "planning_time_s", "rejected"):
        assert key in d
    assert d["figure"] is None
    # the one-off map build apart from the plan: the planner's own time is milliseconds
    assert d["map_build_s"] > 0.0 and d["planning_time_s"] < d["map_build_s"]
    assert len(d["collision_free"]) == 1 and d["collision_free"][0][0] == d["tau_min"]
    assert any(r["reason"] == "collision" and r["vehicle_id"] == "pvc" for r in d["rejected"])
    assert not list(tmp_path.iterdir())


def test_text_report_and_figure(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    case3 = ROOT / "scenarios" / "paper_case3_lane_exchange.toml"
    assert main(["plan", str(case3), "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "collision with tv1" in text and "unstable" in text
    png = tmp_path / "paper_case3_lane_exchange_exact.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["plan", str(case3), "--collision-test", "col", "--no-plot"]) == 0
    assert "chosen tau" in capsys.readouterr().out


def test_col_test_keeps_the_exact_figure_and_says_which(tmp_path: Path) -> None:
    """Planning one scenario with both tests keeps both figures, each titled with its test."""
    import matplotlib.image as mpimg

    from cosim.commands.plan import describe_method
    from cosim.params import PlannerConfig

    case3 = ROOT / "scenarios" / "paper_case3_lane_exchange.toml"
    assert main(["plan", str(case3), "--out", str(tmp_path)]) == 0
    exact = tmp_path / "paper_case3_lane_exchange_exact.png"
    before = exact.read_bytes()
    assert main(["plan", str(case3), "--out", str(tmp_path), "--collision-test", "col"]) == 0
    col = tmp_path / "paper_case3_lane_exchange_col.png"
    assert exact.read_bytes() == before and col.is_file()
    assert not (mpimg.imread(exact).shape == mpimg.imread(col).shape
                and (mpimg.imread(exact) == mpimg.imread(col)).all())
    assert "CoL" in describe_method(PlannerConfig(collision_test="col"))
    assert "exact" in describe_method(PlannerConfig())


def test_figure_format_svg(tmp_path: Path) -> None:
    assert main(["plan", str(CASE1), "--out", str(tmp_path), "--figure-format", "svg"]) == 0
    svg = tmp_path / "paper_case1_overtaking_exact.svg"
    assert svg.read_text().lstrip().startswith("<?xml") and "<svg" in svg.read_text()
    assert not list(tmp_path.glob("*.png"))


def test_bad_file_is_one_line_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario]\nduration_s = -1\n")
    assert main(["plan", str(bad), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.toml" in err
