"""The docs' study scripts (docs/study_merge_table.py, docs/study_comfort_table.py,
docs/study_gap_table.py) on hand-made batch folders: the merge table's cells are
cosim.study.summary.merge_summary's, the gap table's rows follow the study's variants, and a
folder without runs.csv is refused in one line with exit status 2, nothing written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from cosim.scenario import project_root

DOCS = project_root() / "docs"


def script(name: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(DOCS / name), *args], capture_output=True,
                          text=True, check=False, cwd=DOCS.parent)


def test_the_merge_table_reads_each_cell_as_the_batch_summary_does(tmp_path: Path) -> None:
    # ours: 2 of 3 merge (one run has no follower), one collision by SUMO's count only;
    # SUMO's: 3 of 3; a failed run is left out
    pd.DataFrame({
        "driver": ["mimo"] * 4 + ["sumo"] * 3,
        "density": [20.0] * 7,
        "status": ["ok", "ok", "ok", "failed", "ok", "ok", "ok"],
        "merge_success": [1, 1, 0, 1, 1, 1, 1],
        "merge_distance_to_end_m": [100.0, 120.0, None, 1.0, 140.0, 130.0, 150.0],
        "stopped_time_s": [0.0, 2.0, 40.0, 0.0, 0.0, 0.0, 0.0],
        "merge_follower_max_decel_mps2": [0.5, None, None, 9.0, 0.4, 4.5, 0.5],
        "collisions": [0, 0, 0, 1, 0, 0, 0],
        "sumo_collisions": [0, 1, 0, 1, 0, 0, 0],
    }).to_csv(tmp_path / "runs.csv", index=False)
    out = script("study_merge_table.py", str(tmp_path))
    assert out.returncode == 0, out.stderr
    row = out.stdout.splitlines()[2]
    # medians 110.0 / 140.0 m and 2.0 / 0.0 s; p95 of one value 0.5, of (0.4, 0.5, 4.5)
    # 4.1 (numpy's linear interpolation, as summary.csv)
    assert row == ("| 20 | 2/3 / 3/3 | 110.0 / 140.0 | 2.0 / 0.0 | 0.50 / 4.10 "
                   "| 0.50 / 4.50 | 0, 1 / 0, 0 |")


def test_the_gap_table_has_a_row_per_variant_and_a_cell_per_density(tmp_path: Path) -> None:
    # the gap policy: 2 densities x 2 runs, one lane change unfinished, one run without a
    # follower, one never closing on anyone (TTC inf); SUMO's: one run SUMO saw collide;
    # a failed run is left out
    pd.DataFrame({
        "driver": ["mimo"] * 5 + ["sumo"] * 2,
        "variant": ["gap"] * 5 + [None] * 2,
        "plant": ["twotrack"] * 5 + ["none"] * 2, "occupant": [0.5] * 7, "mu": [0.8] * 7,
        "seed": [1, 2, 1, 2, 3, 1, 1],
        "density": [10.0, 10.0, 20.0, 20.0, 20.0, 10.0, 20.0],
        "status": ["ok"] * 4 + ["failed"] + ["ok"] * 2,
        "lane_change_completed": [1, 1, 1, 0, 1, 1, 1],
        "collisions_sv": [0, 0, 1, 0, 0, 0, 0],
        "sumo_collision": [0, 0, 1, 0, 0, 1, 0],
        "follower_max_decel_mps2": [0.5, 1.5, None, 0.4, 9.0, 0.3, 4.5],
        "lane_change_duration_s": [3.0, 4.0, 2.0, None, 1.0, 3.0, 3.0],
        "min_ttc_s": [10.0, float("inf"), 5.0, 7.0, 1.0, 30.0, 8.0],
    }).to_csv(tmp_path / "runs.csv", index=False)
    out = script("study_gap_table.py", str(tmp_path))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert "at 10 / 20 veh/km/lane" in lines[0] and len(lines) == 4
    # the per-density cells are summary.csv's: p95 of (0.5, 1.5) is 1.45 (numpy's linear
    # interpolation), at 20 one value, 0.4; the minimum TTC's median over the finite
    # values, 10.0 at 10 (a median with the inf run read inf there: not summary.md's)
    assert lines[2] == ("| gap (courtesy), perfect V2V | 2 / 1 | 1 / 1 | 1.45 / 0.40 | 3.00 "
                        "| 10.0 / 6.0 |")
    assert lines[3] == "| SUMO-native | 1 / 1 | 0 / 1 | 0.30 / 4.50 | 3.00 | 30.0 / 8.0 |"


@pytest.mark.parametrize("name", ["study_merge_table.py", "study_comfort_table.py",
                                  "study_gap_table.py", "study_entry_table.py"])
def test_a_folder_without_runs_is_refused_in_one_line(name: str, tmp_path: Path) -> None:
    figure = tmp_path / "fig.png"
    out = script(name, str(tmp_path / "none"), "--figure", str(figure))
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.splitlines()[-1].endswith(
        "none: no runs.csv in it (a cosim batch output folder is expected)")
    assert not figure.exists()
