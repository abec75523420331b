"""The on-ramp network (networks/onramp.*): rebuilt byte for byte from its plain XML;
the SV's lanes on its routes (the tracks of the route's first edge, through or ending),
where each ends, y_right and the speed bands; the routes that are refused."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.road.frame import FrameLimits
from cosim.road.onramp import ACC_LENGTH, NAME, build, main, stale
from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR
from cosim.traffic.route_lanes import RouteLanes, check_lanes, road_params, sv_tracks

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import assert_rebuilt, netconvert  # noqa: E402

NET = NETWORK_DIR / f"{NAME}.net.xml"


def test_the_shipped_network_is_up_to_date(tmp_path: Path) -> None:
    assert_rebuilt(tmp_path, NAME, build, stale, main)
    (tmp_path / f"{NAME}.con.xml").write_text("<connections/>\n", encoding="utf-8")
    assert stale(tmp_path) == [f"{NAME}.con.xml"]


def test_the_acceleration_lane_is_lane_0_and_ends() -> None:
    road = load_road(NET, ["acc", "main1", "main2"])
    check_lanes(road, "s.toml")
    assert [t.id for t in sv_tracks(road)] == [0, 1, 2, 3]
    assert road.reference.id == 1  # the rightmost through lane
    rp = road_params(road)
    assert rp.n_lanes == 4 and rp.lane_width == 3.75
    assert rp.y_right == -3.75  # lane 0 lies right of d = 0
    assert rp.lane_center(0) == pytest.approx(float(road.lane(0).centre(50.0)))
    assert rp.lane_center(2) == pytest.approx(float(road.lane(2).centre(1000.0)))
    # acc_0 is ACC_LENGTH minus the junctions' share long; the others run on
    assert ACC_LENGTH - 10.0 < rp.lane_end(0) < ACC_LENGTH
    assert rp.lane_end(0) == pytest.approx(road.lane(0).end)
    assert [rp.lane_end(k) for k in (1, 2, 3)] == [math.inf] * 3
    default = road_params(load_road(NETWORK_DIR / "highway.net.xml")).speed_bands
    assert rp.speed_bands == (default[0], *default)  # the through neighbour's band
    lanes = RouteLanes(road)
    assert lanes.band_index == {0: 0, 1: 1, 2: 2, 3: 3}
    assert lanes.sv_lane["acc_0"] == 0 and lanes.sv_lane["main2_2"] == 3


def test_the_lane_drop_ends_the_left_lane_and_the_ramp_is_no_sv_lane() -> None:
    drop = road_params(load_road(NET, ["main2", "main3"]), None)
    assert drop.y_right == 0.0 and drop.n_lanes == 3
    assert drop.lane_end(0) == drop.lane_end(1) == math.inf
    assert 1400.0 < drop.lane_end(2) < 1500.0
    mainline = load_road(NET, ["main0", "acc", "main1", "main2"])
    rp = road_params(mainline)
    assert rp.lane_ends == () and rp.y_right == 0.0 and rp.n_lanes == 3
    lanes = RouteLanes(mainline)
    assert "acc_0" not in lanes.sv_lane  # the acceleration lane begins on the route
    assert lanes.band_index[3] == 0  # and drives at lane 0's band


def test_a_route_starting_on_the_ramp_is_smoothed_through_its_kink() -> None:
    """The ramp bends 7.6 degrees at one vertex 100 m before its gore: a route from it,
    led in along the ramp (cosim.road.tracks), smooths to R 90 m within 0.2 m there
    (refused, below R 100 m); up to coarse_deviation it bends at R ~255 m."""
    road = load_road(NET, ["ramp", "acc", "main1"])
    q = road.frame.quality
    assert q.coarse and q.min_radius > 200.0
    assert road.max_deviation <= FrameLimits().coarse_deviation
    with pytest.raises(InputError, match="radius of at least 100 m") as err:
        load_road(NET, ["ramp", "acc", "main1"],
                  limits=FrameLimits(coarse_deviation=FrameLimits().max_deviation))
    assert err.value.key == "reference line radius" and "on edge ramp" in str(err.value)
    assert "\n" not in str(err.value)


def test_a_sv_lane_that_begins_along_the_route_is_refused() -> None:
    road = load_road(NET, ["main0", "acc", "main1", "main2"])
    with pytest.raises(InputError, match=r"sv.lane = 0: a lane of the route's first edge "
                                         r"'main0' \(lane 0 of 'acc' begins along the route"):
        check_lanes(road, "s.toml", "acc", 0)
    check_lanes(road, "s.toml", "acc", 1)  # the mainline's right lane there: track 0


def test_a_middle_lane_that_ends_is_refused(tmp_path: Path) -> None:
    nodes = ('<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
             '<node id="C" x="2000" y="0"/></nodes>')
    edges = ('<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
             '<edge id="BC" from="B" to="C" numLanes="2" speed="33.3"/></edges>')
    # netconvert's own connections: a lane of three ends, on the right (accepted)
    check_lanes(load_road(netconvert(tmp_path, nodes, edges), ["AB", "BC"]), "s.toml")
    # the middle lane becomes a bus lane: for cars it ends at B, between two that run on
    bus = ('<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
           '<edge id="BC" from="B" to="C" numLanes="3" speed="33.3">'
           '<lane index="1" allow="bus"/></edge></edges>')
    road = load_road(netconvert(tmp_path, nodes, bus, name="m"), ["AB", "BC"])
    assert [t.id for t in sv_tracks(road)] == [0, 1, 2] and road.lane(1).end <= 1000.0
    with pytest.raises(InputError, match=r"lane 1 of edge 'AB' ends between two that run on"):
        check_lanes(road, "s.toml")
