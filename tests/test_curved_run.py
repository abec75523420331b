"""A run on the shipped curved motorway through real SUMO: the SV's body stays
inside SUMO's own lanes at every step, and the road columns agree with the Cartesian
ones."""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np
import shapely

from cosim.road.road import Road
from cosim.run.loop import simulate
from cosim.run.result import RunResult
from cosim.scenario import load_scenario
from cosim.scenario.load import project_root


@functools.cache
def curved_case1() -> RunResult:
    sc = load_scenario(project_root() / "scenarios" / "curved_case1_overtaking.toml")
    return simulate(sc)


def lanes_polygon(road: Road) -> shapely.Geometry:
    """The union of every lane the route's tracks run through (junction lanes too), each
    SUMO lane shape grown by half its width with flat ends."""
    parts = [shapely.LineString(piece.shape).buffer(0.5 * piece.width, cap_style="flat")
             for track in road.tracks for piece in track.pieces if len(piece.shape) >= 2]
    return shapely.union_all(parts)


def corners(x: np.ndarray, y: np.ndarray, psi: np.ndarray, length: float,
            width: float) -> np.ndarray:
    """(n, 4, 2): the body rectangle's corners of centre poses."""
    c, s = np.cos(psi), np.sin(psi)
    out = []
    for a, b in ((0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)):
        out.append(np.stack([x + a * length * c - b * width * s,
                             y + a * length * s + b * width * c], axis=1))
    return np.stack(out, axis=1)


def test_the_sv_stays_inside_sumo_lanes_through_a_lane_change_on_a_curve() -> None:
    result = curved_case1()
    sc, tr = result.scenario, result.trace
    assert result.route_road is not None and result.route_road.curved
    assert result.metrics["lane_change_completed"] == 1
    assert result.metrics["collisions"] == 0 and result.metrics["sumo_collisions"] == 0
    area = lanes_polygon(result.route_road).buffer(0.005)  # SUMO writes shapes to 1 cm / 2
    body = corners(tr["x_m"], tr["y_m"], np.radians(tr["psi_deg"]), sc.vehicle.length,
                   sc.vehicle.width)
    points = shapely.points(body.reshape(-1, 2))
    inside = shapely.contains(area, points).reshape(body.shape[:2])
    assert inside.all(), f"{(~inside.all(axis=1)).sum()} steps with a corner off the lanes"
    # the lane change ends on the target track's centre, half a lane width in
    assert abs(tr["d_m"][-1] - result.road.lane_center(1)) < 0.05


def test_the_road_columns_are_the_cartesian_pose_in_the_frame() -> None:
    result = curved_case1()
    tr = result.trace
    frame = result.route_road.frame
    x, y, _ = frame.to_cartesian(tr["s_m"], tr["d_m"])
    assert np.max(np.hypot(x - tr["x_m"], y - tr["y_m"])) < 1e-6


def test_the_same_case_on_the_straight_road_is_the_paper_case() -> None:
    """The curved case is case 5.1 moved: off the curve (its straight twin) the scenario
    gives paper_case1's plan."""
    sc = load_scenario(project_root() / "scenarios" / "curved_case1_overtaking.toml")
    straight = load_scenario(project_root() / "scenarios" / "paper_case1_overtaking.toml")
    assert replace(sc.sv, edge=None, position=straight.sv.position) == replace(
        straight.sv, edge=None)
    assert sc.tvs == straight.tvs and sc.planner == straight.planner
    assert math.isclose(sc.road.mu, straight.road.mu)
