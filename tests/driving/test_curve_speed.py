"""The SV's curve speed: a curved route is driven at a speed whose tightest curve takes
at most the comfortable lateral acceleration (and half the road's friction), never
refused for its speed; straight routes and SUMO's driver are not capped."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.driving.curve_speed import CURVE_FRICTION_SHARE, curve_speed, keep_to
from cosim.params import G, RoadParams
from cosim.run.loop import simulate
from cosim.scenario import load_scenario, project_root
from cosim.scenario.load import scenario_from_dict

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "road"))
from handdrawn import curved_route, ramp_curve  # noqa: E402

pytestmark = pytest.mark.sumo


@pytest.mark.parametrize(("kappa", "d_abs", "mu", "a"), [
    (1 / 400, 11.25, 0.8, 2.0), (1 / 139, 9.4, 0.6, 2.0), (1 / 400, 0.0, 0.3, 2.0)])
def test_the_inner_lane_takes_exactly_the_allowed_lateral_acceleration(
        kappa: float, d_abs: float, mu: float, a: float) -> None:
    v = curve_speed(kappa, d_abs, mu, a)
    inner = kappa / (1.0 - kappa * d_abs)
    assert v * v * inner == pytest.approx(min(a, CURVE_FRICTION_SHARE * mu * G), rel=1e-9)
    assert curve_speed(0.0, d_abs, mu, a) == math.inf


def test_keep_to_caps_the_svs_speeds_and_bands_only() -> None:
    sc = load_scenario(project_root() / "scenarios" / "traffic_high.toml")
    capped, road = keep_to(sc, sc.road, 25.0)
    assert capped.sv.speed == min(sc.sv.speed, 25.0)
    assert all(hi <= 25.0 and lo <= hi for lo, hi in road.speed_bands)
    assert capped.road == road
    assert [lo for lo, _ in road.speed_bands] == [min(lo, 25.0) for lo, _ in sc.road.speed_bands]
    same, _ = keep_to(sc, RoadParams(), math.inf)
    assert same.sv == sc.sv


def _r400(tmp: Path, lat: float | None = None) -> dict:
    """A lane change to the left (inner) lane inside a left curve of R 400 m, drawn every
    10 m, at 110 km/h asked for (the band of lane 1 tops at 110)."""
    net = curved_route(tmp, 10.0, radius=400.0, length=700.0, curve_lanes=3, speed=36.1)
    sv = {"edge": "BC", "lane": 1, "position_m": 100.0, "speed_kmh": 110.0,
          "lane_changes": [{"at_s": 3.0, "direction": "left"}]}
    if lat is not None:
        sv["curve_lat_accel_mps2"] = lat
    return {"scenario": {"name": "r400", "duration_s": 16.0, "seed": 1},
            "road": {"network": str(net), "route": ["BC"], "mu": 0.8}, "sv": sv}


def _straight() -> dict:
    """The same request on the straight road: lane 1 at 100 m, 110 km/h, a change left at
    3 s, mu 0.8."""
    sv = {"lane": 1, "position_m": 100.0, "speed_kmh": 110.0,
          "lane_changes": [{"at_s": 3.0, "direction": "left"}]}
    return {"scenario": {"name": "straight", "duration_s": 16.0, "seed": 1},
            "road": {"network": "networks/highway.net.xml", "mu": 0.8}, "sv": sv}


def test_a_lane_change_in_an_r400_curve_at_the_curve_speed(tmp_path: Path) -> None:
    result = simulate(scenario_from_dict(_r400(tmp_path), path=tmp_path / "r400.toml"))
    m, tr = result.metrics, result.trace
    kappa, d_abs = result.route_road.curvature_bound()
    v_curve = curve_speed(kappa, d_abs, 0.8, 2.0)
    assert m["curve_speed_mps"] == pytest.approx(v_curve, rel=1e-12)
    assert v_curve < 110 / 3.6  # the cap is what this case tests
    assert result.first_plan is not None
    assert result.plans[0]["vxf_mps"] == pytest.approx(v_curve, rel=1e-9)  # planned at it
    assert float(np.max(tr["vx_mps"])) <= 1.003 * v_curve  # never above the curve speed
    assert m["lane_change_completed"] == 1 and m["final_lane"] == 2
    assert abs(m["final_offset_m"]) < 0.05
    assert m["collisions"] == 0 and m["sumo_events"] == 0
    # the body's lateral acceleration stays near what the curve speed allows
    # (the lane change adds its own, well below the friction left)
    assert float(np.max(np.abs(tr["ay_mps2"]))) < 0.5 * 0.8 * G
    # the path is tracked about as well as on the straight road (measured: largest |ye|
    # 1.56x, IAE of ye 1.66x the straight road's 4.3 mm and 0.014 m s; 17x and 19x
    # before the yaw moment was held within the wheels' friction on curves, control/
    # grip.py: the inner front tyre ran out of grip, the car ran wide, the integrators
    # wound up)
    straight = simulate(scenario_from_dict(_straight(), path=tmp_path / "s.toml"))
    assert straight.metrics["lane_change_completed"] == 1
    worst = float(np.max(np.abs(tr["ye_m"])))
    assert worst < 1.75 * float(np.max(np.abs(straight.trace["ye_m"])))
    assert m["iae_ye_m_s"] < 1.75 * straight.metrics["iae_ye_m_s"]


def test_a_tight_curve_is_driven_slower_not_refused(tmp_path: Path) -> None:
    """R 150 m at 110 km/h would need 6.2 m/s^2: more than mu 0.6 leaves a lane change.
    The SV drives it at its curve speed and keeps its lane, inside SUMO's lane."""
    net = curved_route(tmp_path, 10.0, radius=150.0, length=300.0, curve_lanes=3, speed=36.1)
    doc = {"scenario": {"name": "tight", "duration_s": 13.0, "seed": 1},
           "road": {"network": str(net), "route": ["AB", "BC"], "mu": 0.6},
           "sv": {"edge": "AB", "lane": 1, "position_m": 900.0, "speed_kmh": 100.0}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "tight.toml"))
    m, tr = result.metrics, result.trace
    assert m["curve_speed_mps"] < 60 / 3.6
    # never above the curve speed but for the frame's stretch along a lane off the
    # reference line (1 - kappa d: 0.1 % on R 150 m) and the speed tracking error
    assert float(np.max(tr["vx_mps"])) <= 1.003 * m["curve_speed_mps"]
    assert float(np.max(tr["s_m"])) > 1000.0 + 100.0  # it drove into the curve
    assert m["collisions"] == 0 and m["final_lane"] == 1


def test_a_one_lane_ramp_of_r25_is_driven_at_its_curve_speed(tmp_path: Path) -> None:
    """A ramp's R 25 m quarter circle (a cloverleaf loop's radius): not refused (the
    frame's stretch across its one 3.2 m lane stays >= 0.85 down to R 21 m); driven
    through at its curve speed, within a few centimetres of SUMO's lane centre."""
    net = ramp_curve(tmp_path, 25.0)
    doc = {"scenario": {"name": "ramp", "duration_s": 9.0, "seed": 1},
           "road": {"network": str(net), "route": ["AB", "BC", "CD"],
                    "lane_speeds_kmh": [[30, 40]]},
           "sv": {"edge": "AB", "lane": 0, "position_m": 190.0, "speed_kmh": 30.0}}
    result = simulate(scenario_from_dict(doc, path=tmp_path / "ramp.toml"))
    m, tr = result.metrics, result.trace
    assert 20.0 < result.route_road.frame.quality.min_radius < 25.0  # SUMO's inner border
    assert m["curve_speed_mps"] == pytest.approx(math.sqrt(2.0 * 22.0), rel=0.1)
    assert float(np.max(tr["vx_mps"])) <= 1.003 * m["curve_speed_mps"]
    assert {"BC", "CD"} <= set(result.edges)  # through the whole curve
    assert m["collisions"] == 0 and m["sumo_events"] == 0
    assert m["lane_keeping_max_offset_m"] < 0.05  # measured 3.3 cm
    assert float(np.max(np.abs(tr["ye_m"]))) < 0.03  # measured 1.9 cm


def test_sumos_driver_and_straight_roads_are_not_capped() -> None:
    sc = load_scenario(project_root() / "scenarios" / "paper_case1_overtaking.toml")
    assert simulate(sc).metrics["curve_speed_mps"] == math.inf


def test_the_sv_slows_to_a_corners_curve_speed_before_it_and_holds_it_there() -> None:
    """Before a corner (cosim.road.corners) the SV may brake no later than a uniform
    deceleration to the corner's curve speed sqrt(a R) at its start; inside it, its
    speed closes on that speed; past it (its rear out), nothing holds it."""
    from cosim.driving.curve_speed import CORNER_SETTLE_S, CornerSpeeds

    corners = CornerSpeeds(((100.0, 130.0, 25.0),), mu=1.0, lat_accel=2.0)
    v_c = math.sqrt(2.0 * 25.0)
    assert corners.accel_cap(50.0, 45.0, 13.89) == pytest.approx(
        (v_c**2 - 13.89**2) / (2.0 * 50.0))
    assert corners.accel_cap(50.0, 45.0, 5.0) == math.inf  # slower than the corner's
    assert corners.accel_cap(110.0, 105.0, 8.0) == pytest.approx((v_c - 8.0) / CORNER_SETTLE_S)
    assert corners.accel_cap(140.0, 135.0, 8.0) == math.inf
    # on a wet road the friction's half takes over from the comfortable 2 m/s^2
    wet = CornerSpeeds(((100.0, 130.0, 25.0),), mu=0.3, lat_accel=2.0)
    assert wet.zones[0][2] == pytest.approx(math.sqrt(CURVE_FRICTION_SHARE * 0.3 * G * 25.0))
