"""Actuator limits shared by both plants: steering angle and rate, wheel torque.

The controller's demands pass through `ActuatorLimits` before they reach a
plant, so saturation is the same on the design model and the validation model,
and the closed loop knows when it saturated (integrators are then frozen).
"""

from __future__ import annotations

from dataclasses import dataclass

from cosim.compiled import njit
from cosim.errors import InputError


@njit
def steer_core(max_steer: float, max_rate: float, previous: float, demand: float,
               dt: float) -> float:
    """rad, the road-wheel angle reached after dt from `previous` towards `demand` with
    the angle limited to +-max_steer (rad) and its rate to max_rate (rad/s)."""
    step = max_rate * dt
    value = min(max(demand, previous - step), previous + step)
    return min(max(value, -max_steer), max_steer)


@dataclass(frozen=True)
class ActuatorLimits:
    """Limits of the active front steering and the four in-wheel motors."""

    max_steer: float = 0.6  # rad, road-wheel angle (about 34 deg)
    max_steer_rate: float = 1.0  # rad/s, road-wheel angle rate (about 57 deg/s)
    max_drive_torque: float = 800.0  # N m, per wheel (in-wheel motor peak)
    max_brake_torque: float = 2000.0  # N m, per wheel (friction brake)

    def check(self) -> None:
        """Raise InputError for a limit that is not positive."""
        for key in ("max_steer", "max_steer_rate", "max_drive_torque", "max_brake_torque"):
            value = getattr(self, key)
            if not value > 0.0:
                raise InputError("actuators", key, value, "must be > 0")

    def steer(self, previous: float, demand: float, dt: float) -> float:
        """rad, the road-wheel angle reached after dt from `previous` towards `demand`."""
        return steer_core(float(self.max_steer), float(self.max_steer_rate), float(previous),
                          float(demand), float(dt))

    def wheel_force_bounds(self, wheel_radius: float) -> tuple[float, float]:
        """N, (lowest, highest) longitudinal force one wheel's torque can ask for."""
        return -self.max_brake_torque / wheel_radius, self.max_drive_torque / wheel_radius
