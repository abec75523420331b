"""Routes: edges of a SUMO network, each connected to the next, or a one-line refusal."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.road.route import make_route
from cosim.traffic.network import NETWORK_DIR
from tests.road.handdrawn import netconvert

CURVED = NETWORK_DIR / "curved_motorway.net.xml"
STRAIGHT = NETWORK_DIR / "highway.net.xml"
ROUTE = ("e1", "e2", "e3", "e4")


def test_a_route_of_connected_edges_is_accepted() -> None:
    route = make_route(CURVED, ROUTE)
    assert route.edges == ROUTE
    assert route.edge(2).getLaneNumber() == 4


def test_on_a_one_edge_network_the_route_is_optional() -> None:
    assert make_route(STRAIGHT).edges == ("highway",)
    assert make_route(STRAIGHT, ["highway"]).edges == ("highway",)


def test_on_a_network_of_several_edges_the_route_is_required() -> None:
    with pytest.raises(InputError, match=r"route = None: a list of edge ids.*has 4 edges"):
        make_route(CURVED)


def test_a_disconnected_route_is_refused_naming_both_edges() -> None:
    with pytest.raises(InputError) as err:
        make_route(CURVED, ["e1", "e3"], source="s.toml", key="road.route")
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("s.toml: road.route = 'e1 -> e3': consecutive edges connected")
    assert "e1 leads to e2" in text


def test_a_missing_edge_is_refused_naming_it() -> None:
    with pytest.raises(InputError, match=r"route = 'e9': an edge of curved_motorway.net.xml"):
        make_route(CURVED, ["e1", "e9"])
    with pytest.raises(InputError, match="non-empty"):
        make_route(CURVED, [])


def test_a_missing_or_broken_network_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="an existing SUMO .net.xml file"):
        make_route(tmp_path / "nothing.net.xml")
    bad = tmp_path / "bad.net.xml"
    bad.write_text("<net><edge", encoding="utf-8")
    with pytest.raises(InputError, match="a readable SUMO .net.xml file"):
        make_route(bad)


def test_the_road_command_describes_a_route_or_refuses_it(
        capsys: pytest.CaptureFixture[str]) -> None:
    from cosim.road.__main__ import main

    assert main([str(CURVED), *ROUTE]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("route e1 e2 e3 e4: ArcFrame")
    assert out[2].endswith("e1_1[1] e2_1[1] e3_2[2] e4_1[1]")  # track 1: SUMO's 1 -> 2 -> 1
    assert main([str(CURVED), "e1", "e3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'e1 -> e3'" in err


def test_a_network_without_a_lane_for_cars_is_refused_naming_its_classes(
        tmp_path: Path) -> None:
    # a race track (SUMO's game/racing allows only vip): the SV is a passenger car
    net = netconvert(tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="500" y="0"/>'
                     "</nodes>", '<edges><edge id="AB" from="A" to="B" numLanes="1" '
                     'allow="vip bus"/></edges>')
    with pytest.raises(InputError) as err:
        make_route(net, ["AB"])
    text = str(err.value)
    assert "\n" not in text
    assert "network = 'no lane allows passenger'" in text
    assert "its edges allow bus, vip; the SV is a passenger car" in text
