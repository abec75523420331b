"""The paper's design model: 2-DOF linear single track (eq. 17-19) with the
longitudinal dynamics of eq. 26 and the yaw moment dMz as an input.

Wheel force demands enter through eq. 27 (Fa) and eq. 20 (dMz), so the plant
sees what the allocation (eq. 30) actually delivers. Tyres are linear and never
saturate: mu does not enter this model.
"""

from __future__ import annotations

import math

from cosim.params import VehicleParams
from cosim.vehicle.integrate import rk4_step
from cosim.vehicle.plant import PlantOutputs

STATE_NAMES = ("x", "y", "heading", "vx", "vy", "yaw_rate")


class BicyclePlant:
    """2-DOF single track + eq. 26, integrated with RK4 (held inputs)."""

    kind = "bicycle"
    state_names = STATE_NAMES

    def __init__(
        self,
        vehicle: VehicleParams,
        x: float = 0.0,
        y: float = 0.0,
        heading: float = 0.0,
        vx: float = 20.0,
        vy: float = 0.0,
        yaw_rate: float = 0.0,
        *,
        speed_floor: float = 1.0,  # m/s, slip-angle denominators never below this
        max_step: float = 0.01,  # s, longest RK4 step (the lateral modes are slow)
    ) -> None:
        self.vehicle = vehicle
        self.state = [x, y, heading, vx, vy, yaw_rate]
        self.speed_floor = speed_floor
        self.max_step = max_step
        self._delta = 0.0
        self._fa = 0.0
        self._dmz = 0.0
        self._fx: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def set_inputs(self, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Hold delta (rad) and the wheel forces (N); Fa by eq. 27, dMz by eq. 20."""
        v = self.vehicle
        c, s = math.cos(delta), math.sin(delta)
        f1, f2, f3, f4 = fx_cmd
        self._delta = delta
        self._fx = (f1, f2, f3, f4)
        self._fa = (f1 + f2) * c + f3 + f4
        self._dmz = (
            f1 * (-v.half_track * c + v.lf * s)
            + f2 * (v.half_track * c + v.lf * s)
            + v.half_track * (f4 - f3)
        )

    def lateral_forces(self, s: list[float]) -> tuple[float, float]:
        """N, (Fyf, Fyr) of eq. 17-18 at state s."""
        v = self.vehicle
        vx = max(s[3], self.speed_floor)
        vy, r = s[4], s[5]
        alpha_f = self._delta - (vy + v.lf * r) / vx
        alpha_r = (v.lr * r - vy) / vx
        return v.cf * alpha_f, v.cr * alpha_r

    def derivative(self, s: list[float]) -> list[float]:
        """ds/dt: eq. 19 (lateral, yaw), eq. 26 (longitudinal), planar kinematics."""
        v = self.vehicle
        _, _, psi, vx, vy, r = s
        fyf, fyr = self.lateral_forces(s)
        c, sn = math.cos(psi), math.sin(psi)
        return [
            vx * c - vy * sn,
            vx * sn + vy * c,
            r,
            vy * r + (self._fa - v.drag * vx * abs(vx)) / v.mass,
            -vx * r + (fyf + fyr) / v.mass,
            (v.lf * fyf - v.lr * fyr + self._dmz) / v.yaw_inertia,
        ]

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds with held inputs (RK4, steps no longer than max_step)."""
        self.set_inputs(delta, fx_cmd)
        n = max(1, math.ceil(h / self.max_step - 1e-9))
        hi = h / n
        s = self.state
        for _ in range(n):
            s = rk4_step(self.derivative, s, hi)
        self.state = s

    def outputs(self) -> PlantOutputs:
        """Body accelerations (eq. 19, 26) and the held wheel forces."""
        v = self.vehicle
        vx = self.state[3]
        fyf, fyr = self.lateral_forces(self.state)
        return PlantOutputs(
            ax=(self._fa - v.drag * vx * abs(vx)) / v.mass,
            ay=(fyf + fyr) / v.mass,
            fx=self._fx,
            fy=(fyf / 2.0, fyf / 2.0, fyr / 2.0, fyr / 2.0),
            fz=None,
        )


def steady_state(vehicle: VehicleParams, vx: float, delta: float) -> tuple[float, float]:
    """(vy, yaw_rate) at which eq. 19 is at rest for constant vx and delta (dMz = 0).

    Solves [[a11, a12], [a21, a22]] [vy, r] = -[b1, b2] delta. The yaw-rate gain
    r/delta equals vx / (L + K vx^2), K = M (lr Cr - lf Cf) / (L Cf Cr).
    """
    v = vehicle
    m, iz, lf, lr, cf, cr = v.mass, v.yaw_inertia, v.lf, v.lr, v.cf, v.cr
    a11 = -(cf + cr) / (m * vx)
    a12 = -vx - (lf * cf - lr * cr) / (m * vx)
    a21 = (lr * cr - lf * cf) / (iz * vx)
    a22 = -(lf * lf * cf + lr * lr * cr) / (iz * vx)
    b1, b2 = cf / m * delta, lf * cf / iz * delta
    det = a11 * a22 - a12 * a21
    return (-b1 * a22 + b2 * a12) / det, (-a11 * b2 + a21 * b1) / det


def understeer_gradient(vehicle: VehicleParams) -> float:
    """s^2/m (rad per m/s^2 per m of wheelbase): K of r/delta = V / (L + K V^2).

    Negative for Table 1 (the car oversteers; critical speed sqrt(-L/K) ~ 40 m/s).
    """
    v = vehicle
    return v.mass * (v.lr * v.cr - v.lf * v.cf) / (v.wheelbase * v.cf * v.cr)
