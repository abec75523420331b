"""A network drawn the way real ones come: coarse polylines that kink at single
vertices, a lane that ends, a road crossing over the route on a bridge (netconvert,
default connections)."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely

from cosim.errors import InputError
from cosim.road.corners import CORNER_TURN
from cosim.road.frame import FrameLimits
from cosim.road.road import load_road

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import curved_route, netconvert, ramp_curve, weave  # noqa: E402


def build(tmp: Path, step: float) -> Path:
    """The curved route with a lane ending at B and a bridge over A-B (handdrawn.py)."""
    return curved_route(tmp, step)


def test_kinks_a_lane_drop_and_a_bridge(tmp_path: Path) -> None:
    net = build(tmp_path, 50.0)  # 1.4 degree kinks, netconvert's 2-decimal coordinates
    road = load_road(net, ["AB", "BC"])
    assert road.frame.quality.max_deviation <= FrameLimits().max_deviation
    assert road.frame.quality.min_radius >= FrameLimits().min_radius
    assert road.frame.quality.max_kink == pytest.approx(math.radians(50 / 2000 * 180 / math.pi),
                                                        rel=0.05)
    # three lanes on AB, two on BC: one track ends at B, the other two run through
    through = [t for t in road.lanes if t.track.last_edge == 1]
    ended = [t for t in road.lanes if t.track.last_edge == 0]
    assert len(through) == 2 and len(ended) == 1
    assert ended[0].end == pytest.approx(1000.0, abs=15.0)  # where AB ends (junction apart)
    for table in road.lanes:
        s = np.concatenate([np.linspace(a, b, max(2, math.ceil((b - a) / 0.25)))
                            for a, b in zip(table.s_start, table.s_end, strict=True)])
        x, y, _ = road.frame.to_cartesian(s, table.centre(s))
        measured = shapely.hausdorff_distance(shapely.LineString(np.column_stack((x, y))),
                                              shapely.LineString(table.track.shape()),
                                              densify=0.05)
        assert measured <= table.deviation + 1e-3 <= FrameLimits().max_deviation + 1e-3
    # the bridge crosses the route: a vehicle on it has an (s, d) inside the lanes, but
    # its road is not the route's
    (x0, y0), (x1, y1) = road.route.net.getEdge("X").getLanes()[0].getShape()
    s, d = road.frame.to_frenet(0.5 * (x0 + x1), 0.5 * (y0 + y1))  # netconvert moved it
    assert 0.0 < s < 1000.0 and 0.0 < d < 10.0
    assert road.on_route(["X", "AB", ":B_0"]).tolist() == [False, True, True]


def test_a_coarse_curve_is_refused_with_the_number_that_fails(tmp_path: Path) -> None:
    net = build(tmp_path, 400.0)  # 11.5 degree kinks
    with pytest.raises(InputError, match=r"reference line radius = '\d+\.\d m'") as err:
        load_road(net, ["AB", "BC"], source="sc.toml")
    assert str(err.value).startswith("sc.toml: ")


def test_a_curve_drawn_with_6_degree_kinks_bends_as_the_road(tmp_path: Path) -> None:
    """A R 480 m curve drawn every 55 m (6.6-degree kinks, as SUMO's shipped A10
    interchange, an OSM import): within 0.2 m of SUMO's polyline the line keeps R ~110 m
    at every vertex; it bends as the curve instead, up to what its 100 km/h limit needs
    (R 386 m at 2 m/s^2), every lane within coarse_deviation of SUMO's."""
    net = curved_route(tmp_path, 55.0, radius=480.0, curve_lanes=3, speed=27.8)
    road = load_road(net, ["AB", "BC"])
    q, limits = road.frame.quality, FrameLimits()
    assert q.max_kink == pytest.approx(55.0 / 480.0, rel=0.02)
    assert q.coarse and q.min_radius >= 0.9 * 27.8**2 / limits.limit_lat_accel
    assert road.max_deviation <= limits.coarse_deviation
    near = load_road(net, ["AB", "BC"],
                     limits=FrameLimits(coarse_deviation=limits.max_deviation))
    assert near.frame.quality.min_radius < 150.0


def test_the_smallest_radius_is_what_the_lanes_reach_allows(tmp_path: Path) -> None:
    """A one-lane ramp (3.2 m) may bend to R 21.3 m (the frame's stretch 1 - kappa d
    across it stays >= 0.85), a motorway of four 3.75 m lanes to R 100 m; a R 15 m
    curve on the ramp is refused naming the radius and why."""
    assert load_road(ramp_curve(tmp_path, 25.0), ["AB", "BC", "CD"]).curved
    with pytest.raises(InputError) as err:
        load_road(ramp_curve(tmp_path, 15.0, name="r15"), ["AB", "BC", "CD"], source="sc.toml")
    text = str(err.value)
    assert text.startswith("sc.toml: reference line radius = '") and "\n" not in text
    assert "radius of at least 21.3 m within 0.2 m" in text
    assert "its lanes' 3.2 m stays >= 0.85, above the SV's turning circle of 3.7 m" in text


def test_lanes_that_step_sideways_at_a_junction_shift_the_frame(tmp_path: Path) -> None:
    """A motorway whose edges spread their lanes differently (right of the centre line,
    then centred, as on SUMO's tools/game/highway network at junction 1658939360): every
    lane steps 1.5 lane widths (4.8 m) sideways across the junction. The frame's line
    shifts with them over 124 m (as a curve of R 555 m, what 33.3 m/s needs at 2 m/s^2),
    every lane keeps its d and lies on SUMO's lane before and after."""
    net = netconvert(
        tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="C" x="2000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
        '<edge id="BC" from="B" to="C" numLanes="3" speed="33.3" spreadType="center"/>'
        "</edges>", name="step")
    road = load_road(net, ["AB", "BC"], source="sc.toml")
    (shift,) = road.shifts
    assert shift.jump == pytest.approx(4.8, abs=1e-6)
    assert shift.s == pytest.approx(1000.0, abs=0.1)
    assert shift.length == pytest.approx(124.1, abs=0.1)
    assert road.frame.quality.min_radius >= 0.99 * 33.3**2 / 2.0
    assert road.max_deviation < 1e-4  # outside the shift
    assert all(np.all(t.d_start == t.d_end) for t in road.lanes)
    # lane 0's centre: on AB_0 (y = -8.0) before, BC_0 (y = -3.2) after
    y = [road.frame.to_cartesian(s, road.lane(0).centre(s))[1] for s in (900.0, 1100.0)]
    assert y == pytest.approx([-8.0, -3.2], abs=1e-4)
    # at 30 km/h the speed limit would take R 35 m: the shift keeps the R 64 m that
    # three lanes of 3.2 m allow (the frame's stretch across them >= 0.85)
    slow = netconvert(
        tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="500" y="0"/>'
        '<node id="C" x="1000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="8.33"/>'
        '<edge id="BC" from="B" to="C" numLanes="3" speed="8.33" spreadType="center"/>'
        "</edges>", name="slow")
    road = load_road(slow, ["AB", "BC"])
    assert 0.99 * 9.6 / 0.15 <= road.frame.quality.min_radius < 70.0


def test_a_lane_cars_may_not_use_is_no_track(tmp_path: Path) -> None:
    net = netconvert(
        tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="500" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="30">'
        '<lane index="0" allow="pedestrian" width="2.0"/></edge></edges>', name="w")
    road = load_road(net)
    assert [t.id for t in road.lanes] == [1, 2]  # SUMO's indices: the sidewalk is lane 0
    assert road.reference.name == "AB_1"
    assert road.lane(2).track.name == "AB_2"
    assert road.lane(1).centre(100.0) == pytest.approx(road.lane(1).track.pieces[0].width / 2)


def test_ramps_drawn_straight_up_to_the_mainline_are_rounded_as_corners(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A weaving section whose ramps meet the mainline at 11.3 degrees at a junction (a
    kink no line within 0.2 m of SUMO's lanes bends through at R 64 m): the junction is
    rounded as a corner at what the ramp's 80 km/h needs at 2 m/s^2 (R 247 m), on a route
    from the on-ramp and on one over the off-ramp."""
    net = weave(tmp_path)
    speed = 22.22
    for route, junctions in ((["on", "BC", "CD"], ["B"]), (["AB", "BC", "off"], ["C"])):
        road = load_road(net, route)
        assert [c.junction for c in road.corners] == junctions
        for c in road.corners:
            assert c.lane_radius == pytest.approx(speed**2 / 2.0, rel=1e-3)
            assert abs(math.degrees(c.turn)) == pytest.approx(11.3, abs=0.1)
        assert road.frame.quality.min_radius > 0.9 * speed**2 / 2.0
        assert road.max_deviation <= FrameLimits().max_deviation
    # the mainline's straight route has no corner
    assert load_road(net, ["AB", "BC", "CD"]).corners == ()
    # with corners only at 15 degrees and more, the ramp's kink is refused, naming it
    monkeypatch.setattr("cosim.road.road.CORNER_TURN_REFUSED", CORNER_TURN)
    with pytest.raises(InputError, match=r"reference line radius = .* on edge BC"):
        load_road(net, ["on", "BC", "CD"])


def test_a_u_turn_at_a_junction_is_refused_naming_it(tmp_path: Path) -> None:
    """A route onto the opposite carriageway (a turnaround connection AB -> BA): no
    corner to round, refused in one line saying so, with no arithmetic warnings (it
    was a RuntimeWarning and `reference lane = [[0.0, -1.6]]`)."""
    (tmp_path / "u.con.xml").write_text(
        '<connections><connection from="AB" to="BA" fromLane="0" toLane="0"/></connections>',
        encoding="utf-8")
    net = netconvert(tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="500" y="0"/>'
                     "</nodes>", '<edges><edge id="AB" from="A" to="B" numLanes="1" '
                     'speed="13.9"/><edge id="BA" from="B" to="A" numLanes="1" speed="13.9"/>'
                     "</edges>", "u", ("-x", "u.con.xml"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError) as err:
            load_road(net, ["AB", "BA"], source="sc.toml")
    text = str(err.value)
    assert text.startswith("sc.toml: route = ['AB', 'BA']: a route whose corners can be ")
    assert text.endswith("at junction B between edges AB and BA, across which SUMO's lane "
                         "steps 3.2 m sideways, a corner: SUMO's junction turns the lane by 180 "
                         "degrees within 4.7 m (R 1.5 m), which SUMO's vehicles follow along "
                         "its shape, having no turning circle: a U-turn of 180 degrees, not "
                         "driven)")
