"""The traffic in road coordinates on a route from an on-ramp (real libsumo): before the
carriageway edge the frame runs along the ramp, so the mainline's vehicles there are
placed by their lane position (road_view.place_upstream), at their lane's d and where
the track they are driving into would have them along s; its pose alone puts a vehicle
100 m before the gore metres off its lane."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.traffic.road_view import place_upstream, road_view, upstream_lanes
from cosim.traffic.sumo import SumoSim

sys.path.insert(0, str(Path(__file__).parents[1] / "road"))
from ramps import build  # noqa: E402

pytestmark = pytest.mark.sumo


def test_the_mainline_beside_the_ramp_is_read_by_lane_position(tmp_path: Path) -> None:
    with SumoSim(build(tmp_path), 0.05, 1, route=("onramp", "acc", "b")) as sim:
        lanes = sim.lanes
        road = lanes.route_road
        up = upstream_lanes(road, lanes.upstream)
        assert sorted(up) == ["a_0", "a_1"] and up["a_0"].track == 1
        begin = road.lane(1).begin
        placed = {"r20": (1, begin - 20.0), "r100": (1, begin - 100.0),
                  "l60": (2, begin - 60.0), "past": (1, begin + 30.0)}
        for vid, (track, s) in placed.items():
            sim.add_traffic(vid, track, s, 0.5, speed=0.0)
        sim.step()
        snap = sim.snapshot()
        posed = road_view(snap, road.frame, None)
        seen = place_upstream(posed, road.frame, sim.api, up, "sv")
        for vid, (track, s) in placed.items():
            i = seen.index(vid)
            assert seen.lane[i] == track
            assert seen.y[i] == pytest.approx(road.lane(track).centre(begin), abs=0.02), vid
            # placed as if the lane ended where the track begins; read across the junction
            junction = up["a_0"].junction if s < begin else 0.0
            assert seen.x[i] == pytest.approx(s - junction, abs=1.0), vid
            assert abs(seen.heading[i]) < 0.01
        # by its pose alone, 100 m before the gore it is metres to the left of its lane
        i = posed.index("r100")
        assert posed.y[i] - road.lane(1).centre(begin) > 5.0
        # past the carriageway edge's start: the pose, as everywhere else
        j = seen.index("past")
        assert (seen.x[j], seen.y[j]) == (posed.x[j], posed.y[j])
        assert np.isfinite(seen.speed).all()
        # one driving from the lane into the junction and on: s grows smoothly, no jump
        # where its pose takes over (the junction's length counted)
        sim.add_traffic("mover", 2, begin - 30.0, 0.5, speed=25.0)
        s_seen = []
        for _ in range(60):
            sim.step()
            posed = road_view(sim.snapshot(), road.frame, None)
            seen = place_upstream(posed, road.frame, sim.api, up, "sv")
            if "mover" in seen.ids:
                s_seen.append(float(seen.x[seen.index("mover")]))
        steps = np.diff(s_seen)
        assert s_seen[0] < begin - 10.0 < begin + 10.0 < s_seen[-1]
        jumps = np.abs(np.diff(steps))
        assert jumps.max() < 0.03, jumps.max()  # SUMO accel: 0.007 a step; the handover 0.02
        # a route whose carriageway edge is its first: nothing to place
        assert upstream_lanes(load(tmp_path), {}) == {}


def load(tmp_path: Path):  # type: ignore[no-untyped-def]
    from cosim.road.road import load_road

    return load_road(tmp_path / "ramps.net.xml", ("acc", "b"))
