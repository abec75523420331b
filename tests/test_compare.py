"""`cosim compare`: one scenario and seed under MIMO, SISO and SUMO-native."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from cosim.cli import main

ROOT = Path(__file__).resolve().parents[1]
CASE1 = ROOT / "scenarios" / "paper_case1_overtaking.toml"


def test_compare_writes_one_row_per_driver_and_a_figure(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(CASE1), "--out", str(tmp_path), "--figure-format", "pdf"]) == 0
    table = pd.read_csv(tmp_path / "compare.csv")
    assert list(table["driver"]) == ["mimo", "siso", "mimo_gap", "sumo"]  # the file: paper
    assert list(table["controller"]) == ["mimo", "siso", "mimo", "sumo"]
    assert set(table["seed"]) == {1} and set(table["scenario"]) == {"paper_case1_overtaking"}
    assert (table["lane_changes"] == 1).all()
    # SUMO's own model: a velocity step sideways, far harder than the planned change
    mimo, sumo = table.iloc[0], table.iloc[3]
    assert sumo["max_abs_lat_accel_mps2"] > 5 * mimo["max_abs_lat_accel_mps2"]
    assert (tmp_path / "compare.pdf").read_bytes()[:5] == b"%PDF-"
    assert "mimo" in capsys.readouterr().out


def test_compare_bad_input_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert main(["compare", str(tmp_path / "missing.toml"), "--out", str(out)]) == 2
    assert not out.exists()
