"""Traffic figures are written as PNGs from band samples and a snapshot."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cosim.params import RoadParams
from cosim.plots.traffic import plot_lane_speeds, plot_snapshot
from cosim.traffic.demand import LaneSpeeds
from cosim.traffic.sumo import TrafficSnapshot

PNG = b"\x89PNG"


def test_lane_speed_figure_and_band_fractions(tmp_path: Path) -> None:
    road = RoadParams()
    rng = np.random.default_rng(0)
    speeds = tuple(rng.uniform(lo, hi, 300) for lo, hi in road.speed_bands)
    speeds = (np.concatenate([speeds[0], [10.0] * 100]), speeds[1], speeds[2])  # 25 % too slow
    samples = LaneSpeeds(speeds, road.speed_bands, 16.0, 60.0, 12)
    assert samples.inside() == (0.75, 1.0, 1.0)
    out = plot_lane_speeds(samples, tmp_path / "speeds.png")
    assert out.read_bytes()[:4] == PNG


def test_snapshot_figure(tmp_path: Path) -> None:
    road = RoadParams()
    snap = TrafficSnapshot(
        time=1.0, ids=("a", "sv"), x=np.array([10.0, 30.0]), y=np.array([1.875, 6.0]),
        heading=np.array([0.0, 0.05]), speed=np.array([20.0, 27.0]), accel=np.zeros(2),
        lane=np.array([0, 1]), lateral_speed=np.array([0.0, 1.25]), length=np.full(2, 4.32),
        width=np.full(2, 1.8), signals=np.array([0, 2]),
    )  # fmt: skip
    out = plot_snapshot(snap, road, tmp_path / "snap.png", (0.0, 60.0), highlight=("sv",))
    assert out.read_bytes()[:4] == PNG


def test_speed_figure_from_a_short_sumo_run(tmp_path: Path) -> None:
    from cosim.plots.traffic import main

    out = tmp_path / "speeds.png"
    assert main(["--density", "12", "--duration", "4", "--out", str(out)]) == 0
    assert out.read_bytes()[:4] == PNG
