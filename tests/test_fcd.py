"""`cosim run --fcd`: SUMO's own floating-car data (--fcd-output) lands in the run folder
with the run's other outputs, and is SUMO's record of the very run in trace.csv."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.cli import main

pytestmark = pytest.mark.sumo

SCENARIO = """
[scenario]
name = "fcd"
duration_s = 2.0
seed = 3

[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0

[traffic]
density_veh_per_km_lane = 6.0
length_m = 500.0
"""


def test_fcd_is_written_into_the_run_folder_and_matches_the_trace(tmp_path: Path) -> None:
    path = tmp_path / "fcd.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-figures", "--fcd"]) == 0
    root = ET.parse(out / "fcd.xml").getroot()
    assert root.tag == "fcd-export"
    steps = root.findall("timestep")
    assert len(steps) >= 40  # 2 s at 0.05 s
    sv = {float(ts.get("time")): v for ts in steps for v in ts.findall("vehicle")
          if v.get("id") == "sv"}
    assert len(sv) >= 40 and any(len(ts.findall("vehicle")) > 1 for ts in steps)
    # SUMO's front bumper (2 decimals) is the trace's centre half a length ahead, each step
    trace = pd.read_csv(out / "trace.csv")
    assert len(trace) == len(sv) and sorted(sv) == pytest.approx(trace["t_s"].tolist())
    for row in trace.itertuples():
        v = sv[min(sv, key=lambda t: abs(t - row.t_s))]
        heading = math.radians(90.0 - float(v.get("angle")))
        assert float(v.get("x")) - 0.5 * 4.32 * math.cos(heading) == pytest.approx(
            row.x_m, abs=0.006)
        assert float(v.get("y")) - 0.5 * 4.32 * math.sin(heading) == pytest.approx(
            row.y_m, abs=0.006)
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # nothing staged left


def test_without_fcd_no_fcd_file(tmp_path: Path) -> None:
    path = tmp_path / "fcd.toml"
    path.write_text(SCENARIO.replace("duration_s = 2.0", "duration_s = 0.5"), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-figures"]) == 0
    assert not (out / "fcd.xml").exists()
    assert np.isfinite(pd.read_csv(out / "trace.csv")["x_m"]).all()
