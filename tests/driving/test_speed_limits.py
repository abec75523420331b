"""The SV keeps the route's speed limits below its lane's band (cosim.driving.speed_limits):
it brakes comfortably before a lower limit, keeps it on the slow edge and accelerates
after it, as SUMO's drivers do."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.driving.speed_limits import LIMIT_DECEL, SpeedLimits
from cosim.params import RoadParams
from cosim.run.loop import simulate
from cosim.scenario.load import scenario_from_dict
from cosim.traffic.route_lanes import road_params

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "road"))
from handdrawn import netconvert  # noqa: E402

pytestmark = pytest.mark.sumo

V100, V80 = 27.78, 22.22  # m/s, netconvert's 100 and 80 km/h


def test_the_cap_brakes_before_a_lower_limit_and_closes_on_it_inside() -> None:
    limits = SpeedLimits((((500.0, 800.0, V80),), ()))
    assert limits.at(0, 600.0) == V80 and limits.at(0, 900.0) == math.inf
    assert limits.at(1, 600.0) == math.inf  # the other lane has none
    # far ahead: free; where braking at LIMIT_DECEL must begin: braking at about it
    assert limits.accel_cap(0, 0.0, V100) > 0.0
    d = (V100 ** 2 - V80 ** 2) / (2.0 * LIMIT_DECEL)
    assert limits.accel_cap(0, 500.0 - d, V100) == pytest.approx(-LIMIT_DECEL, abs=0.1)
    assert limits.accel_cap(0, 600.0, V80 + 1.0) < 0.0  # inside: down to the limit
    assert limits.accel_cap(0, 850.0, V100) == math.inf  # after it: free
    assert limits.accel_cap(0, 450.0, V80) == math.inf  # at the limit already
    # a lane change into the lane ends at its limit if it reaches it within CHANGE_REACH
    assert limits.change_end_speed(0, 400.0, V100, 30.0) == V80
    assert limits.change_end_speed(0, 0.0, V100, 30.0) == 30.0  # too far ahead
    assert limits.change_end_speed(1, 400.0, V100, 30.0) == 30.0


@pytest.fixture(scope="module")
def slow_edge(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, object]:
    """100 -> 80 -> 100 km/h (AB 400 m, BC 150 m, CD 400 m, two lanes), the SV at 100 km/h
    in lane 1 (band 80-100 km/h) 200 m before the slow edge, no traffic."""
    tmp = tmp_path_factory.mktemp("limits")
    net = netconvert(tmp, '<nodes><node id="A" x="0" y="0"/><node id="B" x="400" y="0"/>'
                     '<node id="C" x="550" y="0"/><node id="D" x="950" y="0"/></nodes>',
                     f'<edges><edge id="AB" from="A" to="B" numLanes="2" speed="{V100}"/>'
                     f'<edge id="BC" from="B" to="C" numLanes="2" speed="{V80}"/>'
                     f'<edge id="CD" from="C" to="D" numLanes="2" speed="{V100}"/></edges>')
    doc = {"scenario": {"name": "limits", "duration_s": 17.0, "seed": 1},
           "road": {"network": str(net), "route": ["AB", "BC", "CD"], "mu": 0.8,
                    "lane_speeds_kmh": [[60, 80], [80, 100]]},
           "sv": {"edge": "AB", "lane": 1, "position_m": 200.0, "speed_kmh": 100.0,
                  "decision": True}}
    result = simulate(scenario_from_dict(doc, path=tmp / "limits.toml"))
    bands = ((60 / 3.6, 80 / 3.6), (80 / 3.6, 100 / 3.6))
    return result, road_params(result.route_road, RoadParams(speed_bands=bands))


def test_the_sv_keeps_the_lower_limit_on_its_edge_and_brakes_comfortably(
        slow_edge: tuple) -> None:
    result, road = slow_edge
    # lane 0's band tops at the slow edge's limit: nothing to keep there
    assert road.speed_limits[0] == () and [v for *_, v in road.speed_limits[1]] == [V80]
    tr = result.trace
    on = (tr["s_m"] > 400.0) & (tr["s_m"] < 550.0)  # the front on BC (s: the centre)
    assert on.any() and np.all(tr["lane"] == 1)
    assert float(np.max(tr["vx_mps"][on])) <= V80 + 0.3  # measured: 80.0 km/h (at most)
    assert float(np.min(tr["ax_mps2"])) > -1.5 * LIMIT_DECEL  # comfortable braking
    after = tr["s_m"] > 560.0
    assert after.any() and float(tr["vx_mps"][after][-1]) > V80 + 1.0  # and on again
    assert result.metrics["collisions"] == 0
