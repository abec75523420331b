"""Chassis parameters the paper's Table 1 lacks, for the two-track validation plant.

Table 1 gives mass, yaw inertia, axle positions, half track, drag and axle
cornering stiffnesses. A four-wheel model also needs the CG height, the wheels'
radius and spin inertia, the tyres' longitudinal slip stiffness and saturation
shape, and how load transfer is split and delayed. The defaults are plausible
values for a mid-size sedan with in-wheel motors (the paper's Remark 5: the yaw
moment is made by differential in-wheel motor torque).
"""

from __future__ import annotations

from dataclasses import dataclass

from cosim.errors import InputError
from cosim.params import G, VehicleParams


@dataclass(frozen=True)
class ChassisParams:
    """Two-track model parameters beyond Table 1."""

    cg_height: float = 0.55  # m, CG above ground (sedan: 0.5-0.6)
    wheel_radius: float = 0.31  # m, rolling radius (205/55 R16: 0.316)
    wheel_inertia: float = 1.2  # kg m^2, wheel + tyre + in-wheel motor rotor, per wheel
    slip_stiffness: float = 20.0  # 1 per unit slip, longitudinal slip stiffness / Fz (15-25)
    shape: float = 1.4  # -, magic-formula shape factor C (> 1: a peak, then a slide)
    roll_share_front: float = 0.55  # -, share of lateral load transfer taken by the front axle
    load_lag: float = 0.08  # s, first-order lag of load transfer (pitch/roll of the body)
    slip_speed_floor: float = 1.0  # m/s, slip denominators never below this (standstill guard)
    # -, true tyre cornering stiffness / Table 1's Cf, Cr: 1 makes the design model exact at
    # small slip; below 1 models a plant that differs from what the controller assumes
    cornering_scale: float = 1.0

    def check(self) -> None:
        """Raise InputError for a value no physical chassis has."""
        positive = {
            "cg_height": self.cg_height,
            "wheel_radius": self.wheel_radius,
            "wheel_inertia": self.wheel_inertia,
            "slip_stiffness": self.slip_stiffness,
            "load_lag": self.load_lag,
            "slip_speed_floor": self.slip_speed_floor,
            "cornering_scale": self.cornering_scale,
        }
        for key, value in positive.items():
            if not value > 0.0:
                raise InputError("chassis", key, value, "must be > 0")
        if not 1.0 < self.shape < 2.0:
            raise InputError("chassis", "shape", self.shape, "magic-formula C in (1, 2)")
        if not 0.0 <= self.roll_share_front <= 1.0:
            raise InputError("chassis", "roll_share_front", self.roll_share_front, "in [0, 1]")


def static_wheel_loads(vehicle: VehicleParams) -> tuple[float, float]:
    """N, static vertical load on one front and one rear wheel."""
    weight = vehicle.mass * G
    return weight * vehicle.lr / (2.0 * vehicle.wheelbase), weight * vehicle.lf / (
        2.0 * vehicle.wheelbase
    )
