"""Scripted TVs: kinematics over time and what they broadcast."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.params import RoadParams, kmh
from cosim.scenario import TVLaneChange, TVSpec
from cosim.traffic import scripted

ROAD = RoadParams()
X_SV = 100.0


def spec(lane_change: TVLaneChange | None = None, *, speed: float = 20.0, accel: float = 0.0,
         lane: int = 0, gap: float = 30.0) -> TVSpec:
    return TVSpec("tv", lane, gap, speed, accel, 4.32, 1.8, lane_change)


def test_lane_keeping_with_braking_stops() -> None:
    t = np.array([0.0, 2.0, 10.0, 20.0])
    k = scripted.kinematics(spec(speed=10.0, accel=-2.0), t, ROAD, X_SV)
    np.testing.assert_allclose(k.x, [130.0, 130.0 + 16.0, 155.0, 155.0])
    np.testing.assert_allclose(k.speed, [10.0, 6.0, 0.0, 0.0])
    np.testing.assert_allclose(k.accel, [-2.0, -2.0, 0.0, 0.0])
    np.testing.assert_allclose(k.y, ROAD.lane_center(0))


def test_future_lane_change_is_continuous_and_ends_in_the_target_lane() -> None:
    lc = TVLaneChange(start=2.0, target_lane=1, tau=4.0, target_speed=None, broadcast="none")
    s = spec(lc, speed=20.0, accel=0.5)
    eps = 1e-6
    k = scripted.kinematics(s, np.array([2.0 - eps, 2.0 + eps, 6.0, 9.0]), ROAD, X_SV)
    assert k.x[0] == pytest.approx(k.x[1], abs=1e-4)
    assert k.speed[0] == pytest.approx(21.0, abs=1e-4) and k.speed[1] == pytest.approx(21.0)
    assert k.y[2] == pytest.approx(ROAD.lane_center(1))
    assert k.speed[3] == pytest.approx(kmh(90))  # band rule: lane 1's minimum
    assert k.lateral_speed[3] == 0.0 and k.heading[3] == 0.0
    assert (np.diff(scripted.kinematics(s, np.linspace(0, 9, 200), ROAD, X_SV).x) > 0).all()


def test_change_under_way_at_start() -> None:
    lc = TVLaneChange(start=-1.5, target_lane=1, tau=4.0, target_speed=kmh(90),
                      broadcast="reference")
    s = spec(lc, speed=kmh(80))
    k = scripted.kinematics(s, np.array([-1.5, 0.0, 2.5]), ROAD, X_SV)
    assert k.x[1] == pytest.approx(X_SV + 30.0)  # where the gap puts it at t = 0
    assert k.y[0] == pytest.approx(ROAD.lane_center(0))
    assert k.speed[0] == pytest.approx(kmh(80))
    assert ROAD.lane_center(0) < k.y[1] < ROAD.lane_center(1)
    assert k.y[2] == pytest.approx(ROAD.lane_center(1)) and k.speed[2] == pytest.approx(kmh(90))


@pytest.mark.parametrize(("broadcast", "intention", "motion"),
                         [("reference", True, True), ("intention", True, False),
                          ("none", False, False)])
def test_messages(broadcast: str, intention: bool, motion: bool) -> None:
    lc = TVLaneChange(start=2.0, target_lane=0, tau=4.0, target_speed=None, broadcast=broadcast)
    s = spec(lc, lane=1, speed=27.0)
    before, during, after = (scripted.message(s, t, ROAD, X_SV) for t in (0.0, 3.0, 6.5))
    assert before.intention == during.intention == (-1 if intention else 0)
    assert after.intention == 0 and after.motion is None
    assert before.motion is None
    assert (during.motion is not None) == motion
    assert before.lane == 1 and after.lane == 0
    k = scripted.kinematics(s, np.array([3.0]), ROAD, X_SV)
    assert during.x == pytest.approx(k.x[0]) and during.y == pytest.approx(k.y[0])
    assert during.lateral_speed < 0


def test_broadcast_reference_reproduces_the_kinematics() -> None:
    lc = TVLaneChange(start=1.0, target_lane=2, tau=5.0, target_speed=None, broadcast="reference")
    s = spec(lc, lane=1, speed=28.0, accel=0.3)
    m = scripted.message(s, 2.0, ROAD, X_SV)
    assert m.motion is not None
    t = np.linspace(1.0, 9.0, 50)
    x, y = m.motion.position(t)
    k = scripted.kinematics(s, t, ROAD, X_SV)
    np.testing.assert_allclose(x, k.x, atol=1e-9)
    np.testing.assert_allclose(y, k.y, atol=1e-9)


def test_scripted_tv_object() -> None:
    tv = scripted.ScriptedTV(spec(), ROAD, X_SV)
    k = tv.kinematics(np.array([1.0]))
    assert (k.x[0], k.y[0], k.heading[0], k.speed[0], k.accel[0]) == pytest.approx(
        (150.0, ROAD.lane_center(0), 0.0, 20.0, 0.0))
    assert tv.message(1.0).vehicle_id == "tv"


def test_stop_and_go_brake_holds_then_drives_off() -> None:
    # [tv.brake] with a hold time (hold_s, restart_accel_mps2, restart_speed_kmh)
    from dataclasses import replace

    from cosim.scenario import TVBrake as StopAndGo

    road = RoadParams()
    tv = replace(spec(speed=20.0, gap=50.0), brake=StopAndGo(at=2.0, decel=4.0, hold=5.0,
                                                             restart_accel=2.0))
    t = np.arange(0.0, 30.0 + 1e-9, 0.01)
    k = scripted.kinematics(tv, t, road, 0.0)
    # 20 m/s until 2 s, stops at 7 s after 50 m of braking, stands 5 s, 2 m/s^2 to 20 m/s
    assert np.allclose(k.speed[t <= 2.0], 20.0)
    rest = (t >= 7.0) & (t <= 12.0)
    assert np.allclose(k.speed[rest], 0.0) and np.ptp(k.x[rest]) < 1e-9
    assert k.x[rest][0] == pytest.approx(50.0 + 40.0 + 50.0)
    assert k.speed[np.searchsorted(t, 17.0)] == pytest.approx(10.0, abs=1e-6)
    assert np.allclose(k.speed[t >= 22.0], 20.0)
    assert np.allclose(np.diff(k.x) / 0.01, k.speed[1:], atol=0.03)  # x and v agree
    np.testing.assert_allclose(k.accel[(t > 12.0) & (t < 22.0)], 2.0)
    # without a hold time it stays stopped (the key's old meaning)
    still = scripted.kinematics(replace(tv, brake=StopAndGo(at=2.0, decel=4.0)), t, road, 0.0)
    assert np.allclose(still.speed[t >= 7.0], 0.0)
    # restart speed defaults to the TV's initial speed; another one is kept to
    other = scripted.kinematics(replace(tv, brake=StopAndGo(2.0, 4.0, 5.0, None, 10.0)), t,
                                road, 0.0)
    assert np.allclose(other.speed[t >= 20.0], 10.0)
    assert np.allclose(other.accel[(t > 12.0) & (t < 18.6)], scripted.RESTART_ACCEL)
