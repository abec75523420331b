"""Tests of cosim.vehicle.actuators: steering angle/rate limits, torque bounds."""

from __future__ import annotations

import pytest

from cosim.errors import InputError
from cosim.vehicle.actuators import ActuatorLimits


def test_steering_is_rate_then_angle_limited() -> None:
    lim = ActuatorLimits(max_steer=0.5, max_steer_rate=1.0)
    assert lim.steer(0.0, 0.3, 0.01) == pytest.approx(0.01)
    assert lim.steer(0.0, -0.3, 0.01) == pytest.approx(-0.01)
    assert lim.steer(0.1, 0.105, 0.01) == pytest.approx(0.105)
    assert lim.steer(0.495, 2.0, 0.01) == pytest.approx(0.5)


def test_wheel_force_bounds_follow_the_torques() -> None:
    limits = ActuatorLimits(max_drive_torque=620.0, max_brake_torque=1550.0)
    lo, hi = limits.wheel_force_bounds(0.31)
    assert hi == pytest.approx(2000.0) and lo == pytest.approx(-5000.0)


def test_non_positive_limit_is_an_input_error() -> None:
    with pytest.raises(InputError, match="max_steer_rate"):
        ActuatorLimits(max_steer_rate=0.0).check()
