"""Tracks keep a physical lane's identity where SUMO's per-edge index changes."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.road.route import make_route
from cosim.road.tracks import (
    carriageway,
    follow_tracks,
    ramp_lanes,
    reference_track,
    reference_tracks,
)
from cosim.traffic.network import NETWORK_DIR

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import netconvert  # noqa: E402
from ramps import build as build_ramps  # noqa: E402
from ramps import build_dropped  # noqa: E402

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
        reference_tracks(route, follow_tracks(route), "s.toml")
    assert err.value.key == "route" and "\n" not in str(err.value)
    return str(err.value)


@pytest.fixture(scope="module")
def ramps(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_ramps(tmp_path_factory.mktemp("ramps"))


def test_a_route_leaving_over_an_off_ramp_runs_beside_the_deceleration_lane(
        tmp_path: Path) -> None:
    """AB BC CE: none of AB's lanes reaches CE, but BC's deceleration lane, which runs on
    onto the off-ramp, begins beside them: BC is the carriageway edge, its lanes the SV's
    (numbered by SUMO's index there), the deceleration lane the reference, led in along
    AB's right lane one lane width to its right."""
    net = _exit(tmp_path)
    route = make_route(net, ("AB", "BC", "CE"))
    tracks = follow_tracks(route)
    assert carriageway(route, tracks) == 1
    assert [(t.id, _lanes(t)[0][0], t.exits) for t in tracks] == [
        (0, "BC_0", False), (1, "AB_0", True), (2, "AB_1", True)]
    ref, lead = reference_tracks(route, tracks)
    assert ref.id == 0 and lead is not None and lead.track.id == 1 and lead.edge == 1
    assert lead.shift == pytest.approx(-3.2)  # netconvert's default width, to the right
    assert [p.edge for p in lead.pieces()] == ["AB", ":B_0"]
    # the mainline past the exit, and the route ended before the diverge: as before
    for edges in (("AB", "BC", "CD"), ("AB", "BC")):
        route = make_route(net, edges)
        tracks = follow_tracks(route)
        assert carriageway(route, tracks) == 0
        assert reference_tracks(route, tracks)[0].name == "AB_0"
        assert reference_tracks(route, tracks)[1] is None


def test_a_route_from_an_on_ramp_runs_beside_the_mainline_where_it_begins(
        ramps: Path) -> None:
    """onramp acc b: the ramp's lane runs on as the acceleration lane acc_0, where the
    mainline's lanes begin (on this route): acc is the carriageway edge; the mainline's
    right lane the reference, led in along the ramp one lane width to its left."""
    route = make_route(ramps, ("onramp", "acc", "b"))
    tracks = follow_tracks(route)
    assert carriageway(route, tracks) == 1
    assert [(t.id, _lanes(t)) for t in tracks] == [
        (0, [("onramp_0", 0), (":g1_0_0", 0), ("acc_0", 0)]),
        (1, [("acc_1", 1), (":e1_0_0", 0), ("b_0", 0)]),
        (2, [("acc_2", 2), (":e1_0_1", 1), ("b_1", 1)])]
    ref, lead = reference_tracks(route, tracks)
    assert ref.id == 1 and lead is not None and lead.track.id == 0
    assert lead.shift == pytest.approx(3.75)


def test_a_ramp_lane_that_ends_before_the_acceleration_lane_is_an_sv_lane_on_its_right(
        tmp_path: Path) -> None:
    """onramp ramp2 acc b: the ramp's one lane runs on as ramp2's right lane, which ends;
    ramp2's left lane begins there and runs on as the acceleration lane acc_0. The
    reference (the mainline's right lane on acc) is led in along ramp2's left lane one
    lane to its left, and that along the ramp's lane two lanes to its left; the ramp's
    lane is the SV's lane 0, right of the acceleration lane (1) and the mainline (2, 3)."""
    from cosim.road.road import load_road
    from cosim.traffic.route_lanes import check_lanes, road_params, sv_tracks

    network = build_dropped(tmp_path)
    route = make_route(network, ("onramp", "ramp2", "acc", "b"))
    raw = follow_tracks(route)
    assert carriageway(route, raw) == 2
    assert [(t.id, _lanes(t)) for t in raw] == [
        (0, [("onramp_0", 0), (":r1_0_0", 0), ("ramp2_0", 0)]),
        (1, [("ramp2_1", 1), (":g1_2_0", 0), ("acc_0", 0)]),
        (2, [("acc_1", 1), (":e1_0_0", 0), ("b_0", 0)]),
        (3, [("acc_2", 2), (":e1_0_1", 1), ("b_1", 1)])]
    assert ramp_lanes(route, raw, 2) == {0: -1}
    ref, lead = reference_tracks(route, raw)
    assert ref.id == 2 and lead is not None
    assert [(li.track.id, li.edge, li.shift) for li in lead.chain()] == [
        (1, 2, pytest.approx(3.75)), (0, 1, pytest.approx(7.5))]
    road = load_road(network, ["onramp", "ramp2", "acc", "b"])
    assert road.ramp_lanes == {0} and road.max_deviation < 0.05
    assert [t.id for t in sv_tracks(road)] == [0, 1, 2, 3]
    check_lanes(road, "s.toml", "onramp", 0)
    params = road_params(road)
    assert params.y_right == pytest.approx(-7.5)  # two lanes right of the reference's
    ramp, acc = road.lane(0), road.lane(1)
    assert params.lane_ends[0] == pytest.approx(ramp.end)  # ramp2's end
    assert acc.begin < ramp.end < acc.end == pytest.approx(params.lane_ends[1])
    assert params.lane_begins[:2] == (-math.inf, pytest.approx(acc.begin))
    assert ramp.centre(ramp.begin) == pytest.approx(-5.625)  # d = 0: the mainline's border


def test_a_route_from_an_on_ramp_over_an_off_ramp_joins_the_ramp_lane_to_the_exit_lane(
        ramps: Path) -> None:
    """onramp acc b dec offramp: the ramp's lane runs on as the acceleration lane, which
    ends; further on the deceleration lane begins where it would run on and leads onto the
    off-ramp. The carriageway edge is dec (its lanes the SV's, the deceleration lane the
    reference, led in along the mainline's right lane and that along the ramp); the ramp's
    lane, whose SV lane is the deceleration lane's, joins it: one SV lane 0, the ramp's
    lane up to the acceleration lane's end, the deceleration lane from its begin."""
    from cosim.road.road import load_road
    from cosim.traffic.route_lanes import (
        check_lanes,
        road_params,
        sv_start,
        sv_tracks,
        through_tracks,
    )

    edges = ("onramp", "acc", "b", "dec", "offramp")
    route = make_route(ramps, edges)
    raw = follow_tracks(route)
    assert carriageway(route, raw) == 3
    assert [(t.id, _lanes(t)[0][0], t.exits, t.joins) for t in raw] == [
        (0, "dec_0", False, -1), (1, "acc_1", True, -1), (2, "acc_2", True, -1),
        (3, "onramp_0", False, 0)]
    road = load_road(ramps, edges)
    assert road.reference.id == 0 and road.ramp_lanes == frozenset()
    assert list(road.joined) == [0] and road.max_deviation < 0.05
    ramp, dec = road.joined[0], road.lane(0)
    lanes = sv_tracks(road)
    assert [t.id for t in lanes] == [0, 1, 2]
    assert [p.lane for p in lanes[0].track.pieces if not p.internal] == [
        "onramp_0", "acc_0", "dec_0", "offramp_0"]
    assert [t.id for t in through_tracks(road)] == [0] and through_tracks(road)[0] is dec
    assert lanes[0].centre(ramp.begin + 10.0) == pytest.approx(1.875)  # d = 0 its border
    assert lanes[0].centre(dec.begin + 10.0) == pytest.approx(1.875)
    check_lanes(road, "s.toml", "onramp", 0)
    assert sv_start(road, "onramp", 0, 50.0)[0] == 0
    params = road_params(road)
    mainline = road.lane(1)
    assert params.y_right == 0.0
    assert params.lane_ends == (ramp.end, mainline.end, road.lane(2).end)
    assert params.lane_begins == (dec.begin, mainline.begin, road.lane(2).begin)
    assert mainline.begin < ramp.end < dec.begin < mainline.end  # never both at one s
    assert params.lane_end(0) == ramp.end and params.lane_end(0, ramp.end) == math.inf
    assert params.lane_end(1, ramp.end) == mainline.end
    assert params.split_ends() == (ramp.end,)
    assert road_params(load_road(ramps, ("onramp", "acc", "b"))).split_ends() == ()
