"""The recorder (cosim.run.recorder) on hand-made scenes, without SUMO: collision onsets
counted once, the SV's fault (changing lanes, or the TV ahead), gap and TTC."""

from __future__ import annotations

import math

import numpy as np

from cosim.driving.base import PolicyStatus
from cosim.params import RoadParams
from cosim.run.recorder import COLUMN, Recorder
from cosim.scenario import project_root
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import SV_ID, Scene, SVState

ROAD = RoadParams()
L, W = 4.32, 1.8
Y0 = ROAD.lane_center(0)
KEEPING = PolicyStatus(target_lane=None, changing=False, manoeuvring=False,
                       leader_gap=math.inf, idm_accel=0.0)
CHANGING = PolicyStatus(target_lane=1, changing=True, manoeuvring=True,
                        leader_gap=math.inf, idm_accel=math.nan)


def scene(t: float, tvs: list[tuple[str, float, float, float]], sv_x: float = 100.0) -> Scene:
    """TVs as (id, x, y, speed) around an SV at (sv_x, lane 0 centre) driving 20 m/s."""
    ids = (SV_ID, *(v[0] for v in tvs))
    x = np.array([sv_x, *(v[1] for v in tvs)])
    y = np.array([Y0, *(v[2] for v in tvs)])
    n = len(ids)
    snap = TrafficSnapshot(t, ids, x, y, np.zeros(n), np.array([20.0, *(v[3] for v in tvs)]),
                           np.zeros(n), np.zeros(n, int), np.zeros(n), np.full(n, L),
                           np.full(n, W), np.zeros(n, int))
    return Scene.around(t, SVState(sv_x, Y0, 0.0, 20.0, 0.0, 0), snap)


def test_an_overlap_counts_once_and_a_tv_ahead_is_the_svs_fault() -> None:
    rec = Recorder(4, L, W, ROAD)
    rec.record(0, scene(0.0, [("a", 110.0, Y0, 15.0)]), KEEPING)
    rec.record(1, scene(0.05, [("a", 103.0, Y0, 15.0)]), KEEPING)  # overlaps (ahead)
    rec.record(2, scene(0.1, [("a", 103.0, Y0, 15.0)]), KEEPING)  # still: same contact
    row = rec.record(3, scene(0.15, [("a", 110.0, Y0, 15.0)]), KEEPING)
    assert list(rec.data[:4, COLUMN["collisions"]]) == [0, 1, 1, 0]
    assert (rec.collisions, rec.sv_fault, rec.manoeuvre_hits) == (1, 1, 0)
    assert row[COLUMN["gap_min_m"]] == np.float64(110.0 - 100.0 - L)
    # closing at 5 m/s on a 5.68 m gap
    assert row[COLUMN["ttc_min_s"]] == np.float64((110.0 - 100.0 - L) / 5.0)


def test_a_tv_from_behind_hits_a_lane_keeping_sv_but_not_one_changing_lanes() -> None:
    rec = Recorder(3, L, W, ROAD)
    rec.record(0, scene(0.0, [("b", 97.0, Y0, 25.0)]), KEEPING)  # behind, overlapping
    assert (rec.collisions, rec.sv_fault) == (1, 0)
    rec.record(1, scene(0.05, [("b", 90.0, Y0, 25.0)]), KEEPING)
    rec.record(2, scene(0.1, [("b", 97.0, Y0, 25.0)]), CHANGING)  # a new onset, changing
    assert (rec.collisions, rec.sv_fault, rec.manoeuvre_hits) == (2, 1, 1)
    assert rec.data[2, COLUMN["target_lane"]] == 1 and rec.data[2, COLUMN["changing"]] == 1


def test_tvs_in_another_lane_have_no_gap_and_sumo_onsets_count_once() -> None:
    rec = Recorder(1, L, W, ROAD)
    row = rec.record(0, scene(0.0, [("c", 120.0, ROAD.lane_center(1), 10.0)]), KEEPING)
    assert row[COLUMN["gap_min_m"]] == math.inf and row[COLUMN["ttc_min_s"]] == math.inf
    assert row[COLUMN["n_tvs"]] == 1 and row[COLUMN["lane"]] == 0
    rec.sumo_collisions({("c", SV_ID)})
    rec.sumo_collisions({("c", SV_ID)})
    rec.sumo_collisions(set())
    rec.sumo_collisions({("c", SV_ID)})
    assert rec.sumo_new == 2 and rec.sumo_step_collisions == 1


def test_road_columns_follow_the_track_across_a_junction_on_the_curved_motorway() -> None:
    """s_m, d_m from the road frame, `edge` as SUMO's road id, `track` the physical lane:
    on the curved motorway track 1 is SUMO's e2_1 then e3_2 (a lane added on the right
    at j2), so the index changes and the track does not; s grows along the route."""
    from cosim.road.road import load_road
    from cosim.run.outputs import trace_frame

    road = load_road(project_root() / "networks" / "curved_motorway.net.xml",
                     ["e1", "e2", "e3", "e4"])
    lane = road.lane(1)
    s_values = [float(lane.s_start[k]) + 20.0 for k in range(len(lane.track.pieces))]
    rec = Recorder(len(s_values), L, W, ROAD, route_road=road)
    cartesian = []
    for k, (piece, s) in enumerate(zip(lane.track.pieces, s_values, strict=True)):
        d = float(lane.centre(s))
        x, y, heading = road.frame.to_cartesian(s, d)
        index = int(piece.lane.rsplit("_", 1)[1])
        # the loop's scene is in road coordinates, the Cartesian pose beside it
        sv = SVState(s, d, 0.0, 20.0, 0.0, index, piece.edge,
                     cartesian=(float(x), float(y), float(heading)))
        snap = TrafficSnapshot(0.05 * k, (SV_ID,), np.array([s]), np.array([d]),
                               np.zeros(1), np.array([20.0]), np.zeros(1),
                               np.array([index]), np.zeros(1), np.full(1, L), np.full(1, W),
                               np.zeros(1, int), cx=np.array([x]), cy=np.array([y]),
                               ch=np.array([heading]))
        cartesian.append((float(x), float(y), math.degrees(float(heading))))
        rec.record(k, Scene.around(0.05 * k, sv, snap), KEEPING)
    frame = trace_frame(rec.trace(len(s_values) - 1), rec.edges)
    assert list(frame["edge"]) == [p.edge for p in lane.track.pieces]
    assert (frame["track"] == 1).all()
    assert {"e2", "e3"} <= set(frame["edge"]) and frame["sumo_lane"].nunique() > 1
    assert np.allclose(frame["s_m"], s_values, atol=1e-6)
    assert np.allclose(frame["d_m"], [float(lane.centre(s)) for s in s_values], atol=1e-6)
    assert np.allclose(frame[["x_m", "y_m", "psi_deg"]].to_numpy(), cartesian, atol=1e-9)


def test_road_columns_on_the_straight_road_are_x_and_y() -> None:
    from cosim.road.road import load_road

    road = load_road(project_root() / "networks" / "highway.net.xml")
    rec = Recorder(1, L, W, ROAD, route_road=road)
    snap = scene(0.0, [])
    sv = SVState(123.456, 5.625, 0.0, 20.0, 0.0, 1, "highway")
    rec.record(0, Scene(0.0, sv, snap.everyone, snap.tvs, snap.tv_vx), KEEPING)
    row = rec.data[0]
    assert (row[COLUMN["s_m"]], row[COLUMN["d_m"]]) == (123.456, 5.625)  # bit for bit
    assert row[COLUMN["track"]] == 1 and rec.edges == ["highway"]


def test_the_scenes_of_several_svs_found_at_once_are_each_ones_own() -> None:
    """Scene.around_all (the fleet's one search) gives each SV the scene Scene.around
    gives it: the TVs within NEAR_RANGE on the network, itself left out."""
    rng = np.random.default_rng(5)
    n = 60
    ids = tuple(f"v{i}" for i in range(n))
    x, y = rng.uniform(0.0, 1000.0, n), rng.choice([Y0, Y0 + 3.75], n)
    lane = np.where(rng.random(n) < 0.1, -1, 0)
    snap = TrafficSnapshot(0.0, ids, x, y, rng.normal(0.0, 0.02, n),
                           rng.uniform(10.0, 30.0, n), np.zeros(n), lane, np.zeros(n),
                           np.full(n, L), np.full(n, W), np.zeros(n, int))
    own = ["v3", "v17", "v40"]
    svs = [SVState(float(x[int(v[1:])]), Y0, 0.0, 20.0, 0.0, 0) for v in own]
    for got, sv, vid in zip(Scene.around_all(0.0, svs, snap, own), svs, own, strict=True):
        want = Scene.around(0.0, sv, snap, vid)
        assert got.tvs.ids == want.tvs.ids and vid not in got.tvs.ids and got.sv is sv
        assert np.array_equal(got.tv_vx, want.tv_vx) and np.array_equal(got.tvs.x, want.tvs.x)
