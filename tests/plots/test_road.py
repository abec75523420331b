"""cosim/plots/road.py: the road map and curvature figure of a route."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from cosim.plots.road import plot_road
from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR


def test_the_curved_motorway_is_drawn(tmp_path: Path) -> None:
    road = load_road(NETWORK_DIR / "curved_motorway.net.xml", ["e1", "e2", "e3", "e4"])
    out = plot_road(road, tmp_path / "road.png")
    assert out.stat().st_size > 20_000
    straight = plot_road(load_road(NETWORK_DIR / "highway.net.xml"), tmp_path / "h.png")
    assert straight.stat().st_size > 10_000


def test_a_straight_route_is_stretched_across_a_curved_one_is_to_scale(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # to scale, the shipped on-ramp's 2.5 km by 15 m is a line with 1600 m of empty map
    # above and below it; the curved motorway stays an x-y map to scale
    import cosim.plots.road as road_plots
    from cosim.scenario import project_root

    maps: list[Any] = []

    def keep(fig: Any, path: Path) -> Path:
        maps.append(fig.axes[0])
        return path

    monkeypatch.setattr(road_plots, "save_figure", keep)
    plot_road(load_road(project_root() / "networks" / "onramp.net.xml",
                        ["acc", "main1", "main2"]), tmp_path / "ramp.png")
    plot_road(load_road(NETWORK_DIR / "curved_motorway.net.xml", ["e1", "e2", "e3", "e4"]),
              tmp_path / "curved.png")
    ramp, curved = maps
    assert ramp.get_aspect() == "auto" and "stretched" in ramp.get_ylabel()
    assert curved.get_aspect() == 1.0 and curved.get_ylabel() == "y (m)"
    low, high = ramp.get_ylim()
    assert high - low < 50.0  # the lanes fill the map


def test_a_straight_route_along_y_is_stretched_across_x(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the narrow axis is the one stretched, whichever way the road runs (a road running
    # north, stretched along y only, would be drawn to scale, as a line)
    import sys

    import cosim.plots.road as road_plots

    sys.path.insert(0, str(Path(__file__).parents[1] / "road"))
    from handdrawn import netconvert

    net = netconvert(tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="0" y="1000"/>'
                     '<node id="C" x="0" y="2000"/></nodes>',
                     '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
                     '<edge id="BC" from="B" to="C" numLanes="3" speed="33.3"/></edges>')
    maps: list[Any] = []
    monkeypatch.setattr(road_plots, "save_figure", lambda fig, path: maps.append(fig.axes[0]))
    plot_road(load_road(net, ["AB", "BC"]), tmp_path / "north.png")
    (north,) = maps
    assert north.get_aspect() == "auto"
    assert "stretched" in north.get_xlabel() and north.get_ylabel() == "y (m)"
    low, high = north.get_xlim()
    assert high - low < 50.0  # the lanes fill the map across
