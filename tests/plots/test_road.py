"""cosim/plots/road.py: the road map and curvature figure of a route."""

from __future__ import annotations

from pathlib import Path

from cosim.plots.road import plot_road
from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR


def test_the_curved_motorway_is_drawn(tmp_path: Path) -> None:
    road = load_road(NETWORK_DIR / "curved_motorway.net.xml", ["e1", "e2", "e3", "e4"])
    out = plot_road(road, tmp_path / "road.png")
    assert out.stat().st_size > 20_000
    straight = plot_road(load_road(NETWORK_DIR / "highway.net.xml"), tmp_path / "h.png")
    assert straight.stat().st_size > 10_000
