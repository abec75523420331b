"""SUMO on a route's road (real libsumo): traffic placed along s on every through track
of networks/curved_motorway.net.xml (route e1 e2 e3 e4: a lane added on the right at
j2, ended at j3, so SUMO's index of track 1 reads 1, 1, 2, 1), speed bands that follow
the track across the shift, the snapshot's lane as the track id, a vehicle on a road
crossing the route on a bridge read as on no lane, and a controlled vehicle driven
along its track by moveToXY to the route's end."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.road.road import load_road
from cosim.traffic.demand import populate
from cosim.traffic.network import NETWORK_DIR
from cosim.traffic.route_lanes import RouteLanes, s_of_lane_position, sv_start

sys.path.insert(0, str(Path(__file__).parents[1] / "road"))
from handdrawn import netconvert  # noqa: E402

from cosim.traffic.sumo import SumoSim

CURVED = NETWORK_DIR / "curved_motorway.net.xml"
ROUTE = ("e1", "e2", "e3", "e4")
STEP = 0.05  # s
L, W = 4.32, 1.8  # m

pytestmark = pytest.mark.sumo


def curved_sim(seed: int = 1) -> SumoSim:
    return SumoSim(CURVED, STEP, seed, route=ROUTE)


def test_a_place_on_a_track_maps_back_to_its_s() -> None:
    """(track, s) -> SUMO (edge, index, lane position) is the inverse of the road's
    s of a lane position; the added lane's track maps onto e3 only; the SV's start
    on a later edge is its s there."""
    route_road = load_road(CURVED, ROUTE)
    lanes = RouteLanes(route_road)
    assert [t.id for t in lanes.through] == [0, 1, 2]
    assert lanes.band_index == {0: 0, 1: 1, 2: 2, 3: 0}  # the added lane: its neighbour's
    indices = []
    for track in (0, 1, 2):
        for s in np.linspace(50.0, 4700.0, 97):
            place = lanes.place(track, float(s))
            lane_id = f"{place.edge}_{place.index}"
            if place.position == 0.0:  # a junction's lane: the next edge's start
                continue
            assert route_road.track_ids[lane_id] == track
            assert s_of_lane_position(route_road, lane_id, place.position) == pytest.approx(
                s, abs=0.01)
            if track == 1:
                indices.append((place.edge, place.index))
    assert [i for e, i in dict(indices).items()] == [1, 1, 2, 1]
    assert lanes.place(3, 3500.0).edge == "e3" and lanes.place(3, 3500.0).index == 0
    track, s = sv_start(route_road, "e3", 2, 100.0)
    assert track == 1 and s == pytest.approx(route_road.lane(1).s_start[4] + 100.0, abs=0.5)
    assert sv_start(route_road, None, 1, 300.0) == (1, pytest.approx(300.0, abs=0.01))


@pytest.mark.parametrize("net, route", [
    (CURVED, ROUTE), (NETWORK_DIR / "onramp.net.xml", ("acc", "main1", "main2"))])
def test_the_lane_hint_holds_in_its_box(net: Path, route: tuple[str, ...]) -> None:
    """The moveToXY hint is the same for every point of the box `hint_box` gives with
    it (ControlledVehicles.move looks again only outside it), and the box is not empty
    along most of the road (it saves the search)."""
    lanes = RouteLanes(load_road(net, route))
    rng = np.random.default_rng(3)
    road = lanes.route_road
    s0, s1 = min(t.begin for t in road.lanes) - 20.0, max(t.end for t in road.lanes) + 20.0
    found = 0
    for s, d in zip(rng.uniform(s0, s1, 300), rng.uniform(-9.0, 12.0, 300), strict=True):
        piece, (lo, hi, d_lo, d_hi) = lanes.hint_box(float(s), float(d))
        assert piece == lanes.hint(float(s), float(d))
        if math.isnan(lo):
            continue
        found += 1
        assert lo < s < hi and d_lo <= d < d_hi
        for u, v in zip(rng.uniform(max(lo, s0 - 1e3), min(hi, s1 + 1e3), 5),
                        rng.uniform(d_lo, d_hi, 5), strict=True):
            if lo < u < hi:
                assert lanes.hint(float(u), float(v)) == piece
        assert lanes.hint(float(np.nextafter(lo, hi)), d_lo) == piece
    assert found > 100


def test_populate_fills_every_through_track_along_s_at_the_density() -> None:
    density, length = 20.0, 4000.0
    with curved_sim(3) as sim:
        route_road = sim.lanes.route_road
        traffic = populate(sim, sim.road(), density, 3, length, inflow=False)
        assert sorted(traffic.placed) == [0, 1, 2]
        sim.step()
        snap = sim.snapshot()
        s, _ = route_road.frame.to_frenet(snap.x, snap.y)
        shifted = 0
        for track in (0, 1, 2):
            mine = snap.lane == track
            ids = set(traffic.placed[track])
            assert {v for v, m in zip(snap.ids, mine, strict=True) if m} == ids
            assert len(ids) == round(density * length / 1000.0)
            on = np.sort(s[mine])
            assert on[0] < 1000.0 / density and on[-1] > length - 1000.0 / density
            gaps = np.diff(on)
            assert np.mean(gaps) == pytest.approx(1000.0 / density, rel=0.05)
            assert gaps.min() > L  # no two bodies on each other
            shifted += sum(sim.api.vehicle.getLaneIndex(v) != track for v in ids)
        assert shifted > 0  # some of them on e3, where SUMO's index is the track's + 1


def test_speed_bands_follow_the_track_across_the_index_shift() -> None:
    """Every TV's desired speed is its place in the band of the track it is on, after
    every step; TVs that cross j2 in track 1 (index 1 -> 2) keep their desired speed and
    their snapshot lane; the added lane's TVs have track 0's band."""
    with curved_sim(5) as sim:
        route_road = sim.lanes.route_road
        populate(sim, sim.road(), 12.0, 5, 4000.0)
        # one TV that stays in track 1 from e2 across j2 into e3
        sim.add_traffic("keeper", 1, 3000.0, 0.5, speed=25.0)
        sim.add_traffic("added", 3, 3200.0, 0.9, speed=20.0)  # drivers shun the lane: put one
        sim.step()
        sim.api.vehicle.setLaneChangeMode("keeper", 0)
        bands = sim.bands
        seen_keeper: list[tuple[str, int, int]] = []
        on_added = crossed = 0
        for k in range(int(40.0 / STEP)):
            sim.step()
            if "keeper" in sim.api.vehicle.getIDList():
                snap = sim.snapshot()
                i = snap.index("keeper")
                lane_id = sim.api.vehicle.getLaneID("keeper")
                if not lane_id.startswith(":"):
                    seen_keeper.append((lane_id, int(snap.lane[i]),
                                        sim.api.vehicle.getLaneIndex("keeper")))
            if k % 10:
                continue
            for vid in sim.api.vehicle.getIDList():
                track = route_road.track_ids.get(sim.api.vehicle.getLaneID(vid))
                if track is None:
                    continue
                want = bands.speed(track, bands.quantile[vid])
                assert sim.api.vehicle.getMaxSpeed(vid) == pytest.approx(want, abs=1e-9), vid
                on_added += track == 3
                crossed += track == 1 and sim.api.vehicle.getRoadID(vid) == "e3"
        assert {lane for lane, *_ in seen_keeper} >= {"e2_1", "e3_2"}
        assert all(lane == 1 for _, lane, _ in seen_keeper)  # the track, not the index
        assert {index for *_, index in seen_keeper} >= {1, 2}
        assert sim.api.vehicle.getMaxSpeed("keeper") == pytest.approx(bands.speed(1, 0.5))
        assert crossed > 0 and on_added > 0
        assert bands.speed(3, 0.5) == bands.speed(0, 0.5)


def bridge_network(tmp: Path) -> Path:
    """A straight three-lane edge AB (1000 m along +x) and a road X crossing it at
    x = 500 m with no junction between them (a bridge), as tests/road/test_handdrawn.py
    draws it."""
    return netconvert(
        tmp, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="X1" x="500" y="-200"/><node id="X2" x="500" y="200"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
        '<edge id="X" from="X1" to="X2" numLanes="1" speed="13.9"/></edges>')


def test_a_vehicle_on_a_bridge_over_the_route_is_on_no_lane(tmp_path: Path) -> None:
    net = bridge_network(tmp_path)
    with SumoSim(net, STEP, 1, route=("AB",)) as sim:
        api = sim.api
        api.route.add("cross", ["X"])
        api.vehicle.add("bridge", "cross", departPos="180", departSpeed="5")
        api.vehicle.setSpeedMode("bridge", 0)
        sim.add_traffic("tv", 1, 480.0, 0.5, speed=10.0)
        sim.step()
        over = 0
        for _ in range(int(6.0 / STEP)):
            api.vehicle.setSpeed("bridge", 5.0)
            sim.step()
            snap = sim.snapshot()
            assert snap.lane[snap.index("bridge")] == -1
            assert snap.lane[snap.index("tv")] == 1
            # over the route's lanes: only its road tells them apart
            s, d = sim.lanes.route_road.frame.to_frenet(snap.x[snap.index("bridge")],
                                                  snap.y[snap.index("bridge")])
            over += 0.0 < s < 1000.0 and 0.0 < d < 11.25
        assert over > 20


@pytest.mark.parametrize("change_at", [None, 3300.0])
def test_a_controlled_vehicle_follows_its_track_to_the_route_end(
        change_at: float | None) -> None:
    """Moved along track 1 (and, with change_at, to track 2 over 100 m on e3) by
    SumoSim.move: SUMO keeps it on its route in the track's lane at every step, never
    teleported or dropped, to the route's end; the snapshot's lane is the track."""
    with curved_sim(2) as sim:
        route_road = sim.lanes.route_road
        frame = route_road.frame
        start = 20.0
        x, y, h = sim.centre_pose(1, start)
        sim.add_controlled("sv", x, y, h, 30.0, (L, W), 1)
        sim.step()
        s, speed = start, 30.0
        end = min(route_road.lane(1).end, route_road.lane(2).end) - L
        checked = changed = 0
        while s < end:
            s += speed * STEP
            d1, d2 = float(route_road.lane(1).centre(s)), float(route_road.lane(2).centre(s))
            u = 0.0 if change_at is None else min(max((s - change_at) / 100.0, 0.0), 1.0)
            d = d1 + (d2 - d1) * u
            x, y, h = frame.to_cartesian(s, d)
            sim.move("sv", x, y, h, speed)
            sim.step()
            assert sim.api.vehicle.getRoute("sv") == ROUTE
            track = 1 if u < 0.5 else 2
            s_front = s + 0.5 * L
            piece = route_road.lane(track).piece_at(s_front)
            bounds = np.concatenate((route_road.lane(track).s_start, route_road.lane(track).s_end))
            if abs(u - 0.5) > 0.2 and np.abs(bounds - s_front).min() > 1.0:
                assert sim.api.vehicle.getLaneID("sv") == piece.lane, (s, piece.lane)
                snap = sim.snapshot_near("sv", 10.0)
                assert snap.lane[snap.index("sv")] == track
                checked += 1
            changed += track == 2
            xs, ys = sim.api.vehicle.getPosition("sv")
            assert math.hypot(xs - x - 0.5 * L * math.cos(h), ys - y - 0.5 * L * math.sin(h)) \
                < 1e-6
        assert not sim.events  # never teleported, never lost
        assert "sv" in sim.api.vehicle.getIDList()
        assert checked > 0.9 * (end - start) / (speed * STEP)
        assert (changed > 0) == (change_at is not None)


# ------------------------------------------------------------------ scenarios on a route
DATA = Path(__file__).resolve().parents[1] / "data"


def _curved_doc(**sv: object) -> dict[str, object]:
    import tomllib

    doc = tomllib.loads((DATA / "route_curved.toml").read_text())
    doc["road"]["route"] = list(ROUTE)  # type: ignore[index]
    doc["sv"].update(sv)  # type: ignore[union-attr]
    return doc


def test_a_route_scenario_gets_the_road_in_s_d() -> None:
    from cosim.params import RoadParams
    from cosim.scenario.load import scenario_from_dict

    sc = scenario_from_dict(_curved_doc(), path=DATA / "route_curved.toml")
    assert sc.route == ROUTE
    assert sc.road == RoadParams(lane_width=3.75, speed_bands=RoadParams().speed_bands,
                                 mu=0.6, y_right=0.0)


def test_the_straight_roads_params_are_as_before() -> None:
    from cosim.params import RoadParams
    from cosim.scenario.load import load_scenario, project_root

    for name in ("paper_case1_overtaking", "traffic_high"):
        sc = load_scenario(project_root() / "scenarios" / f"{name}.toml")
        assert sc.road == RoadParams(lane_width=3.75, speed_bands=sc.road.speed_bands,
                                     mu=sc.road.mu, y_right=0.0)


def test_the_sv_starts_on_its_track_at_its_s() -> None:
    """[sv] edge e3, lane 2 (SUMO's index there) is track 1: the rules check lane 1's band
    and the World starts the SV on track 1 at the s of its lane position."""
    from cosim.scenario.load import scenario_from_dict
    from cosim.traffic.world import World

    doc = _curved_doc(edge="e3", lane=2, position_m=200.0, lane_changes=[])
    doc["tv"] = []
    doc["scenario"]["duration_s"] = 5.0  # type: ignore[index]
    sc = scenario_from_dict(doc, path=DATA / "route_curved.toml")
    world = World(sc)
    route_road = world.route_road
    assert world.sv_start_track == 1
    assert world.sv_start_x == pytest.approx(route_road.s_of_lane_position("e3_2", 200.0), abs=1e-6)
    assert world.sv_start_x == pytest.approx(float(route_road.lane(1).s_start[4]) + 200.0, abs=0.5)


def test_a_route_whose_lanes_differ_in_width_is_refused_in_one_line(tmp_path: Path) -> None:
    from cosim.errors import InputError
    from cosim.traffic.route_lanes import road_params

    net = netconvert(
        tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="C" x="2000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3" width="3.75"/>'
        '<edge id="BC" from="B" to="C" numLanes="3" speed="33.3" width="3.75">'
        '<lane index="0" width="3.5"/></edge></edges>')
    route_road = load_road(net, ["AB", "BC"])
    with pytest.raises(InputError, match=r"lane widths = \[3.5, 3.75\].*3.5, 3.75 m: SUMO's "
                       r"lanes BC_0 3.5 m, the others 3.75 m; a lane or edge width of its "
                       r"own is not supported\)$"):
        road_params(route_road)


@pytest.mark.parametrize(("s0", "first"), [(3300.0, "e3_2"), (3100.0, ":j2_0_1"),
                                           (3080.0, "e2_1")])
def test_a_lane_change_asked_of_a_sumo_driven_car_is_to_its_track(s0: float,
                                                                   first: str) -> None:
    """The SUMO-driven SV on track 1 asked to change to track 2: on e3 (track 2 is SUMO's
    index 3 there, its own lane index 2), on the junction before it, and on e2 just before
    the junction (SUMO shifts the request as the index changes): it ends on track 2."""
    with curved_sim(4) as sim:
        route_road = sim.lanes.route_road
        sim.add_driven("sv", 1, sim.centre_pose(1, s0), 30.0, 30.0, L, W,
                       own_lane_changes=False)
        sim.step()
        sim.controlled.release("sv")
        assert sim.api.vehicle.getLaneID("sv") == first
        sim.change_lane("sv", 2)
        seen: list[str] = []
        for _ in range(int(8.0 / STEP)):
            sim.step()
            lane_id = sim.api.vehicle.getLaneID("sv")
            if not seen or seen[-1] != lane_id:
                seen.append(lane_id)
        assert "e3_3" in seen, seen
        assert route_road.track_ids[seen[-1]] == 2, seen
        assert sim.snapshot().lane[sim.snapshot().index("sv")] == 2


def test_the_world_starts_traffic_around_the_sv_on_its_track() -> None:
    """World.start on the curved route: random traffic on the three through tracks,
    none on any track within the SV's exclusion zone around its s, its own track kept
    free over its start zone."""
    from cosim.scenario.load import scenario_from_dict
    from cosim.traffic.demand import start_zone
    from cosim.traffic.world import SV_LENGTH_MARGIN, World

    doc = _curved_doc(edge="e2", lane=1, position_m=600.0, lane_changes=[])
    doc["tv"] = []
    doc["traffic"] = {"density_veh_per_km_lane": 24.0, "length_m": 4000.0}
    sc = scenario_from_dict(doc, path=DATA / "route_curved.toml")
    world = World(sc)
    try:
        world.start()
        world.insert()
        snap = world.read_all()  # in road coordinates: x is s
        s = snap.x
        cx, cy, _ = snap.cartesian
        assert np.allclose(world.route_road.frame.to_frenet(cx, cy)[0], s, atol=1e-9)
        s0, margin = world.sv_start_x, SV_LENGTH_MARGIN * sc.vehicle.length
        assert world.sv_start_track == 1 and 2000.0 < s0 < 2200.0
        assert set(snap.lane.tolist()) == {0, 1, 2}
        near = np.abs(s - s0) < margin + 0.5 * L
        assert not near.any()
        lo, hi = start_zone(s0, sc.vehicle.length, sc.sv.speed, sc.road.speed_bands[1][1])
        own = snap.lane == 1
        assert not (own & (s + 0.5 * L > lo) & (s - 0.5 * L < hi)).any()
        assert ((snap.lane != 1) & (s > hi) & (s < hi + 60.0)).any()  # others are there
    finally:
        world.close()


def test_a_run_past_the_routes_end_is_refused_and_a_first_lane_that_ends_is_an_sv_lane(
        tmp_path: Path) -> None:
    from cosim.errors import InputError
    from cosim.scenario.load import scenario_from_dict
    from cosim.traffic.route_lanes import check_lanes, road_params

    doc = _curved_doc(edge="e4", lane=1, position_m=500.0, lane_changes=[])
    doc["tv"] = []
    doc["scenario"]["duration_s"] = 30.0  # type: ignore[index]
    with pytest.raises(InputError, match=r"scenario.duration_s = 30.0: short enough for the SV "
                                         r"to stay on the 4807.9\d* m road"):
        scenario_from_dict(doc, path=DATA / "route_curved.toml")
    net = netconvert(
        tmp_path, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="C" x="2000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="33.3"/>'
        '<edge id="BC" from="B" to="C" numLanes="2" speed="33.3"/></edges>')
    route_road = load_road(net, ["AB", "BC"])
    check_lanes(route_road, "s.toml")  # lane 0 ends at B, an SV lane like the others
    rp = road_params(route_road)
    assert rp.n_lanes == 3 and rp.y_right == pytest.approx(-rp.lane_width)
    assert rp.lane_end(0) <= 1000.0 and rp.lane_end(1) == rp.lane_end(2) == math.inf


def test_lanes_named_on_an_edge_with_a_lane_added_count_as_tracks() -> None:
    """On e3 (a lane added on the right at j2) SUMO's index 2 is track 1: a scenario
    written there (the SV in lane 2 changing to 3, a TV in 2 changing to 1) is checked
    and run as tracks 1 -> 2 and 1 -> 0; the added lane (index 0) is refused as a target."""
    from cosim.errors import InputError
    from cosim.scenario.load import scenario_from_dict

    doc = _curved_doc(edge="e3", lane=2, position_m=200.0,
                      lane_changes=[{"at_s": 1.0, "target_lane": 3}])
    doc["tv"][0]["lane"] = 2  # type: ignore[index]
    doc["tv"][0]["lane_change"]["target_lane"] = 1  # type: ignore[index]
    doc["tv"] = doc["tv"][:1]  # type: ignore[index]
    sc = scenario_from_dict(doc, path=DATA / "route_curved.toml")
    run = sc.in_tracks(1)
    assert run.sv.lane == 1 and run.sv.lane_changes[0].target_lane == 2
    assert run.tvs[0].lane == 1 and run.tvs[0].lane_change.target_lane == 0
    assert sc.in_tracks(sc.sv.lane) is sc
    doc["sv"].update(lane=1, lane_changes=[{"at_s": 1.0, "target_lane": 0}])  # type: ignore
    with pytest.raises(InputError, match=r"sv.lane_changes\[0\].target_lane = 0: a lane that "
                                         r"runs through the route \(on edge e3: index 1"):
        scenario_from_dict(doc, path=DATA / "route_curved.toml")


def test_the_lanes_feeding_the_routes_first_edge_map_to_its_tracks() -> None:
    """A route that starts on the on-ramp's acceleration-lane edge sees the mainline
    behind it (main0's lanes and their junction lanes: tracks 1-3), not the ramp (it
    feeds the acceleration lane, which ends, at an angle); a route that starts where the
    network does sees nothing more."""
    lanes = RouteLanes(load_road(NETWORK_DIR / "onramp.net.xml", ["acc", "main1", "main2"]))
    upstream = {k: v for k, v in lanes.sv_lane.items() if not k.startswith("acc_")
                and not k.startswith("main")}  # junction lanes
    assert {lanes.sv_lane[f"main0_{i}"] for i in range(3)} == {1, 2, 3}
    assert all(lanes.sv_lane[f"main0_{i}"] == i + 1 for i in range(3))
    assert "ramp_0" not in lanes.sv_lane and upstream
    straight = RouteLanes(load_road(NETWORK_DIR / "highway.net.xml"))
    assert set(straight.sv_lane) == {p.lane for t in straight.sv for p in t.track.pieces}


def test_a_route_from_an_on_ramp_and_one_over_an_off_ramp_give_lanes_that_begin(
        tmp_path: Path) -> None:
    """The SV's lanes are those of the carriageway edge (cosim.road.tracks): from the
    on-ramp, the ramp's lane (lane 0, to the acceleration lane's end) and the mainline's
    lanes, which begin beside it; over the off-ramp, the deceleration lane (lane 0, on to
    the ramp's end), which begins beside the mainline's, which exit. The mainline's
    upstream edge feeds the mainline where it begins (its traffic's route joins there)."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "road"))
    from ramps import build

    from cosim.params import RoadParams
    from cosim.traffic.route_lanes import exit_lanes, road_params

    net = build(tmp_path)
    on = load_road(net, ("onramp", "acc", "b"))
    lanes = RouteLanes(on)
    rp = road_params(on, RoadParams())
    acc = on.lane(1).begin
    assert [t.id for t in lanes.sv] == [0, 1, 2] and [t.id for t in lanes.through] == [1, 2]
    assert rp.y_right == -3.75 and rp.lane_begins[0] == -math.inf
    assert rp.lane_begins[1:] == pytest.approx((acc, acc), abs=0.05)
    assert rp.lane_ends == (on.lane(0).end, math.inf, math.inf)
    assert rp.lane_end(0) - acc == pytest.approx(194.5, abs=0.5)  # the acceleration lane
    assert on.lane(0).begin == pytest.approx(0.0, abs=1e-6) and acc > 200.0
    # the ramp's lane lies one lane right of the mainline's, along the ramp too
    s = np.linspace(0.0, on.lane(0).end, 50)
    assert np.allclose(on.lane(0).centre(s), -1.875) and on.lane(0).deviation < 0.05
    up = lanes.upstream[1]
    assert (up.edge, up.index, up.joins) == ("a", 0, 1)
    assert "a_0" in lanes.sv_lane and lanes.sv_lane["a_0"] == 1
    off = load_road(net, ("b", "dec", "offramp"))
    rp = road_params(off, RoadParams(speed_bands=((20.0, 25.0),) * 3))
    dec = off.lane(0).begin
    assert rp.y_right == 0.0 and rp.lane_begins == (dec, -math.inf, -math.inf)
    assert rp.lane_ends == (math.inf, off.lane(1).end, off.lane(2).end)
    assert exit_lanes(off) == (1, 2) and off.lane(1).end - dec == pytest.approx(194.5, abs=0.5)
    # nothing changes on a route along the mainline
    assert road_params(load_road(net, ("a", "acc", "b")), RoadParams()).lane_begins == ()
