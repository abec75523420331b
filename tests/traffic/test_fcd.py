"""SUMO's floating-car data on the route (cosim.traffic.fcd) and the time-space diagram
drawn from it (cosim.plots.time_space): a run written with its fcd.xml (`cosim run --fcd`)
draws time_space.png; the SV's records lie where trace.csv has it, and every record on an
SV lane at s = its lane position on this one-edge road."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.run.loop import simulate
from cosim.run.outputs import write_outputs
from cosim.scenario import load_scenario
from cosim.traffic.fcd import read_route_records
from cosim.traffic.route_lanes import load_route_road

pytestmark = pytest.mark.sumo

SCENARIO = """
[scenario]
name = "fcd"
duration_s = 3.0
seed = 3

[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0

[traffic]
density_veh_per_km_lane = 10.0
length_m = 600.0
"""


def test_fcd_on_the_route_and_its_time_space_diagram(tmp_path: Path) -> None:
    path = tmp_path / "fcd.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    sc = load_scenario(path)
    out = tmp_path / "out"
    result = simulate(sc, fcd_output=tmp_path / "fcd.xml")
    write_outputs(result, out, extra_files=(tmp_path / "fcd.xml",))
    assert (out / "time_space.png").stat().st_size > 10_000

    road = load_route_road(sc.network, sc.route)
    records = read_route_records(out / "fcd.xml", road)
    trace = pd.read_csv(out / "trace.csv")
    sv = records.of("sv")
    assert sv.sum() == len(trace)
    # SUMO's front bumper (2 decimals) half a length ahead of the trace's centre
    assert records.t[sv] == pytest.approx(trace["t_s"].to_numpy(), abs=1e-9)
    assert records.s[sv] == pytest.approx(trace["s_m"].to_numpy() + 0.5 * 4.32, abs=0.006)
    assert np.array_equal(records.track[sv], trace["track"].to_numpy())
    assert len(records.ids) > 10 and set(records.track) == {0, 1, 2}
    assert (records.speed >= 0).all() and np.isfinite(records.s).all()
    every = read_route_records(out / "fcd.xml", road, every=0.5)
    assert sorted(set(np.round(every.t, 6))) == pytest.approx(np.arange(0.0, 3.01, 0.5))
