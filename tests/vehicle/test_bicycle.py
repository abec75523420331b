"""Tests of cosim.vehicle.bicycle: the 2-DOF design model (eq. 17-19, 26, 20, 27)."""

from __future__ import annotations

import math

import pytest

from cosim.control.allocation import virtual_inputs
from cosim.params import VehicleParams
from cosim.vehicle.bicycle import BicyclePlant, steady_state, understeer_gradient
from cosim.vehicle.plant import PlantStart

VEHICLE = VehicleParams()


def hold_speed_run(plant: BicyclePlant, delta: float, seconds: float) -> None:
    """Step with the exact Fa that keeps vx constant (eq. 26 solved for Fa)."""
    v = VEHICLE
    for _ in range(int(seconds / 0.005)):
        _, _, _, vx, vy, r = plant.state
        fa = v.drag * vx * vx - v.mass * vy * r
        plant.step(0.005, delta, (0.0, 0.0, fa / 2.0, fa / 2.0))


@pytest.mark.parametrize("speed", [10.0, 22.0, 30.0])
def test_simulation_settles_on_the_analytic_steady_state(speed: float) -> None:
    delta = 0.003
    plant = BicyclePlant(VEHICLE, PlantStart(vx=speed))
    hold_speed_run(plant, delta, 8.0)
    vy_ss, r_ss = steady_state(VEHICLE, plant.state[3], delta)
    assert plant.state[3] == pytest.approx(speed, rel=1e-4)  # Fa is held over each step
    assert plant.state[4] == pytest.approx(vy_ss, rel=1e-4)
    assert plant.state[5] == pytest.approx(r_ss, rel=1e-4)


@pytest.mark.parametrize("speed", [10.0, 25.0, 35.0])
def test_steady_yaw_gain_is_the_bicycle_formula(speed: float) -> None:
    v = VEHICLE
    _, r = steady_state(v, speed, 0.01)
    k = understeer_gradient(v)
    assert r / 0.01 == pytest.approx(speed / (v.wheelbase + k * speed**2), rel=1e-9)


def test_table1_car_oversteers_with_a_critical_speed_near_40_mps() -> None:
    k = understeer_gradient(VEHICLE)
    assert k < 0
    assert math.sqrt(-VEHICLE.wheelbase / k) == pytest.approx(39.9, abs=0.1)


def test_wheel_forces_enter_through_eq_20_and_27() -> None:
    delta = 0.05
    fx = (300.0, -100.0, 250.0, 50.0)
    plant = BicyclePlant(VEHICLE, PlantStart(vx=20.0))
    plant.set_inputs(delta, fx)
    dmz, fa = virtual_inputs(VEHICLE, delta, fx)
    d = plant.derivative(plant.state)
    fyf, fyr = plant.lateral_forces(plant.state)
    assert d[3] == pytest.approx((fa - VEHICLE.drag * 400.0) / VEHICLE.mass)
    assert d[5] == pytest.approx((VEHICLE.lf * fyf - VEHICLE.lr * fyr + dmz) / VEHICLE.yaw_inertia)
    by_hand = -0.71 * 300 * math.cos(delta) + 1.45 * 300 * math.sin(delta)
    by_hand += -100 * (0.71 * math.cos(delta) + 1.45 * math.sin(delta)) + 0.71 * (50 - 250)
    assert dmz == pytest.approx(by_hand)


def test_brake_to_a_stop_hold_and_drive_off() -> None:
    """Vx -> 0 and back on the 2-DOF model: braking at 3 m/s^2 with the wheel turned, 2 s
    standing on the brake, then driving off: finite throughout, no reversing, standing
    still on the brake (slip angles divide by max(vx, 1 m/s), RK4 steps shorten)."""
    plant = BicyclePlant(VEHICLE, PlantStart(vx=10.0))
    brake, drive = (-3.0 * VEHICLE.mass / 4,) * 4, (1.0 * VEHICLE.mass / 4,) * 4
    vxs = []
    for k in range(int(8.0 / 0.005)):
        t = k * 0.005
        plant.step(0.005, 0.05, brake if t < 5.5 else drive)
        assert all(math.isfinite(v) for v in plant.state)
        vxs.append(plant.state[3])
    stop = next(k for k, v in enumerate(vxs) if v < 1e-3)
    assert stop * 0.005 == pytest.approx(10.0 / 3.0, abs=0.2)
    assert min(vxs) > -1e-6
    assert max(abs(v) for v in vxs[stop + 20:int(5.5 / 0.005)]) < 1e-6
    assert plant.state[3] == pytest.approx(2.5, rel=0.1)  # 1 m/s^2 for 2.5 s


def test_critical_speed_warning_within_10_percent() -> None:
    """Table 1's car: critical speed 144 km/h; `cosim run` warns from 129.6 km/h on."""
    from cosim.params import VEHICLE_PRESETS
    from cosim.vehicle.bicycle import critical_speed, critical_speed_warning

    vc = critical_speed(VEHICLE)
    assert vc is not None and vc * 3.6 == pytest.approx(143.6, abs=0.1)
    assert critical_speed_warning(VEHICLE, 0.89 * vc) is None
    message = critical_speed_warning(VEHICLE, 0.91 * vc)
    assert message is not None and "144 km/h" in message and "\n" not in message
    neutral = VEHICLE_PRESETS["commonroad_vehicle2"]  # Cf lf = Cr lr: no critical speed
    assert critical_speed(neutral) is None
    assert critical_speed_warning(neutral, 70.0) is None


def test_cosim_run_warns_on_stderr_near_the_critical_speed(tmp_path, capsys) -> None:
    from types import SimpleNamespace

    from cosim.params import RoadParams
    from cosim.vehicle.bicycle import warn_near_critical_speed

    sv = SimpleNamespace(speed=30.0, desired_speed=None)
    fast = RoadParams(speed_bands=((60 / 3.6, 90 / 3.6), (110 / 3.6, 135 / 3.6)))
    warn_near_critical_speed(SimpleNamespace(vehicle=VEHICLE, sv=sv, road=fast))
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "critical speed 144 km/h" in err
    warn_near_critical_speed(SimpleNamespace(vehicle=VEHICLE, sv=sv, road=RoadParams()))
    assert capsys.readouterr().err == ""
