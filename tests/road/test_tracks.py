"""Tracks keep a physical lane's identity where SUMO's per-edge index changes."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.road.route import make_route
from cosim.road.tracks import follow_tracks, reference_track
from cosim.traffic.network import NETWORK_DIR

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import netconvert  # noqa: E402

CURVED = NETWORK_DIR / "curved_motorway.net.xml"
ROUTE = ("e1", "e2", "e3", "e4")


def _lanes(track) -> list[tuple[str, int]]:
    return [(p.lane, p.index) for p in track.pieces]


def test_a_lane_added_on_the_right_renumbers_sumo_but_not_the_track() -> None:
    tracks = follow_tracks(make_route(CURVED, ROUTE))
    assert [t.id for t in tracks] == [0, 1, 2, 3]
    t1 = tracks[1]
    # SUMO's index of this one physical lane: 1 on e1, e2; 2 on e3 (a lane added on its
    # right at j2); 1 again on e4 (that lane ended at j3); through the junction lanes
    assert _lanes(t1) == [("e1_1", 1), (":j1_0_1", 1), ("e2_1", 1), (":j2_0_1", 1),
                          ("e3_2", 2), (":j3_0_1", 1), ("e4_1", 1)]
    assert [t.piece_on("e3").index for t in tracks[:3]] == [1, 2, 3]
    assert [t.piece_on("e4").index for t in tracks[:3]] == [0, 1, 2]


def test_the_added_lane_is_a_track_of_its_own_that_ends_where_its_lane_does() -> None:
    tracks = follow_tracks(make_route(CURVED, ROUTE))
    added = tracks[3]
    assert added.name == "e3_0"
    assert _lanes(added) == [("e3_0", 0)]  # no connection onward at j3: an acceleration lane
    assert (added.first_edge, added.last_edge) == (2, 2)


def test_the_reference_is_the_rightmost_track_through_the_whole_route() -> None:
    route = make_route(CURVED, ROUTE)
    tracks = follow_tracks(route)
    assert reference_track(route, tracks).id == 0
    # a route ending on e3: the added lane still is not through (it starts on e3)
    short = make_route(CURVED, ("e2", "e3"))
    tr = follow_tracks(short)
    assert reference_track(short, tr).name == "e2_0"
    assert [t.name for t in tr] == ["e2_0", "e2_1", "e2_2", "e3_0"]


def test_one_edge_track_ids_are_sumo_indices() -> None:
    tracks = follow_tracks(make_route(NETWORK_DIR / "highway.net.xml"))
    assert [(t.id, t.name) for t in tracks] == [(0, "highway_0"), (1, "highway_1"),
                                                (2, "highway_2")]


def test_the_road_knows_its_edges_and_which_track_a_lane_belongs_to() -> None:
    from cosim.road.road import load_road

    road = load_road(CURVED, ROUTE)
    assert road.track_ids["e3_2"] == 1 and road.track_ids[":j2_0_1"] == 1
    assert road.track_ids["e3_0"] == 3 and road.track_of_lane("e4_0").id == 0
    assert road.on_route(["e1", ":j2_0", "bridge", "e4"]).tolist() == [True, True, False, True]


def _exit(tmp: Path) -> Path:
    """A -> B two lanes; B -> C three, a deceleration lane added on the right; at C the
    mainline C -> D (two lanes) and the off-ramp C -> E (the deceleration lane's)."""
    return netconvert(
        tmp, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="C" x="1300" y="0"/><node id="D" x="2300" y="0"/>'
        '<node id="E" x="2290" y="-100"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="2" speed="33.3"/>'
        '<edge id="BC" from="B" to="C" numLanes="3" speed="33.3"/>'
        '<edge id="CD" from="C" to="D" numLanes="2" speed="33.3"/>'
        '<edge id="CE" from="C" to="E" numLanes="1" speed="33.3"/></edges>', name="exit")


def _refusal(network: Path, edges: tuple[str, ...]) -> str:
    route = make_route(network, edges)
    with pytest.raises(InputError) as err:
        reference_track(route, follow_tracks(route), "s.toml")
    assert err.value.key == "route" and "\n" not in str(err.value)
    return str(err.value)


def test_a_route_leaving_over_an_off_ramp_is_refused_as_an_exit(tmp_path: Path) -> None:
    net = _exit(tmp_path)
    text = _refusal(net, ("AB", "BC", "CE"))
    assert text.endswith(
        "(no lane of it does; its lanes on BC go on to CD, and the route leaves them there "
        "for CE: a route leaving the mainline over an off-ramp is not supported yet: end the "
        "route before the diverge (on BC at the latest))"), text
    assert "on-ramp" not in text
    # the mainline past the exit, and the route ended before the diverge, are roads
    for edges in (("AB", "BC", "CD"), ("AB", "BC")):
        route = make_route(net, edges)
        assert reference_track(route, follow_tracks(route)).name == "AB_0"


def test_a_scenario_leaving_over_an_off_ramp_is_refused_in_one_line_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from cosim.cli import main

    scenario = tmp_path / "s.toml"
    scenario.write_text(
        f'[scenario]\nname = "exit"\nduration_s = 5.0\n[road]\nnetwork = "{_exit(tmp_path)}"'
        '\nroute = ["AB", "BC", "CE"]\n[sv]\nlane = 0\nposition_m = 50.0\nspeed_kmh = 100.0\n',
        encoding="utf-8")
    assert main(["run", str(scenario), "--no-figures", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"cosim run: error: {scenario}: road.route = ['AB', 'BC', 'CE']: "
                          "a route along which at least one lane runs"), err
    assert "\n" not in err and err.endswith("(on BC at the latest))"), err


def test_a_route_starting_on_an_on_ramp_keeps_the_on_ramp_message() -> None:
    text = _refusal(NETWORK_DIR / "onramp.net.xml", ("ramp", "acc", "main1"))
    assert text.endswith(
        "(no lane of it does; a route starting on an on-ramp before its lane runs beside the "
        "mainline is not supported: start it on the edge that carries the acceleration "
        "lane)"), text
    assert "off-ramp" not in text
