"""A run on an OpenStreetMap import cosim did not build (issue 23): netconvert's OSM
import of a motorway split into several ways, its curve drawn with a node every 60 m
(2.9 degree kinks), ramps guessed into acceleration and deceleration lanes, a road on
a bridge over it; random traffic and two scripted lane changes, one on the curve."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from cosim.scenario import scenario_from_dict
from cosim.sim import simulate

sys.path.insert(0, str(Path(__file__).parent / "road"))
from handdrawn import corners_in_lanes  # noqa: E402
from osm import ROUTE, import_osm, motorway_osm  # noqa: E402


def test_an_osm_motorway_with_coarse_curves_ramps_and_a_bridge(tmp_path: Path) -> None:
    net = import_osm(tmp_path, motorway_osm())
    doc = {
        "scenario": {"name": "osm", "duration_s": 45.0, "seed": 3},
        "road": {"network": str(net), "route": ROUTE},
        "sv": {"lane": 1, "position_m": 500.0, "speed_kmh": 110.0,
               "lane_changes": [{"at_s": 4.0, "direction": "left"},
                                {"at_s": 28.0, "direction": "right"}]},
        "traffic": {"density_veh_per_km_lane": 12.0},
    }
    result = simulate(scenario_from_dict(doc, path=tmp_path / "osm.toml"))
    m, tr, road = result.metrics, result.trace, result.route_road
    assert road is not None and road.curved
    # smoothing spent deviation on the 60 m chords instead of keeping R ~170 m spikes
    quality = road.frame.quality  # type: ignore[union-attr]
    assert quality.max_deviation <= 0.2 and quality.min_radius > 400.0
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    assert m["final_lane"] == 1  # left, then back right
    assert np.diff(tr["lane"]).nonzero()[0].size >= 2
    assert {"101", "101-AddedOnRampEdge"} <= set(result.edges)  # past the on-ramp, on the curve
    # the body inside SUMO's lanes at every step, within the frame's deviation
    assert corners_in_lanes(result, quality.max_deviation + 0.02)
