"""Tracks keep a physical lane's identity where SUMO's per-edge index changes."""

from __future__ import annotations

from cosim.road.route import make_route
from cosim.road.tracks import follow_tracks, reference_track
from cosim.traffic.network import NETWORK_DIR

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
