"""The paper's design model: 2-DOF linear single track (eq. 17-19) with the
longitudinal dynamics of eq. 26 and the yaw moment dMz as an input.

Wheel force demands enter through eq. 27 (Fa) and eq. 20 (dMz), so the plant
sees what the allocation (eq. 30) actually delivers. Tyres are linear and never
saturate: mu does not enter this model.
"""

from __future__ import annotations

import math

import numpy as np

from cosim.compiled import Array, njit
from cosim.params import VehicleParams
from cosim.vehicle.plant import PlantOutputs

STATE_NAMES = ("x", "y", "heading", "vx", "vy", "yaw_rate")


@njit
def bicycle_lateral_forces(s: Array, c: Array, inputs: Array) -> tuple[float, float]:
    """N, (Fyf, Fyr) of eq. 17-18 at state s; c = constants, inputs = (delta, Fa, dMz)."""
    lf, lr, cf, cr, floor = c[2], c[3], c[4], c[5], c[8]
    vx = max(s[3], floor)
    vy, r = s[4], s[5]
    alpha_f = inputs[0] - (vy + lf * r) / vx
    alpha_r = (lr * r - vy) / vx
    return cf * alpha_f, cr * alpha_r


@njit
def bicycle_derivative(s: Array, c: Array, inputs: Array, out: Array) -> None:
    """ds/dt into `out`: eq. 19 (lateral, yaw), eq. 26 (longitudinal), planar kinematics."""
    m, iz, lf, lr, drag = c[0], c[1], c[2], c[3], c[6]
    psi, vx, vy, r = s[2], s[3], s[4], s[5]
    fyf, fyr = bicycle_lateral_forces(s, c, inputs)
    cs, sn = math.cos(psi), math.sin(psi)
    out[0] = vx * cs - vy * sn
    out[1] = vx * sn + vy * cs
    out[2] = r
    out[3] = vy * r + (inputs[1] - drag * vx * abs(vx)) / m
    out[4] = -vx * r + (fyf + fyr) / m
    out[5] = (lf * fyf - lr * fyr + inputs[2]) / iz


@njit
def bicycle_set_inputs(c: Array, inputs: Array, delta: float,
                       f1: float, f2: float, f3: float, f4: float) -> None:
    """Hold delta (rad) and the wheel forces (N): Fa by eq. 27, dMz by eq. 20."""
    ls, lf = c[7], c[2]
    cs, sn = math.cos(delta), math.sin(delta)
    inputs[0] = delta
    inputs[1] = (f1 + f2) * cs + f3 + f4
    inputs[2] = f1 * (-ls * cs + lf * sn) + f2 * (ls * cs + lf * sn) + ls * (f4 - f3)
    inputs[3], inputs[4], inputs[5], inputs[6] = f1, f2, f3, f4


@njit
def bicycle_step(s: Array, c: Array, inputs: Array, h: float, delta: float,
                 f1: float, f2: float, f3: float, f4: float) -> None:
    """Integrate state s (in place) h seconds with held inputs (RK4, steps no longer
    than max_step)."""
    bicycle_set_inputs(c, inputs, delta, f1, f2, f3, f4)
    n = max(1, math.ceil(h / c[9] - 1e-9))
    hi = h / n
    half = 0.5 * hi
    sixth = hi / 6.0
    k1, k2, k3, k4, tmp = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for _ in range(n):
        bicycle_derivative(s, c, inputs, k1)
        for j in range(6):
            tmp[j] = s[j] + half * k1[j]
        bicycle_derivative(tmp, c, inputs, k2)
        for j in range(6):
            tmp[j] = s[j] + half * k2[j]
        bicycle_derivative(tmp, c, inputs, k3)
        for j in range(6):
            tmp[j] = s[j] + hi * k3[j]
        bicycle_derivative(tmp, c, inputs, k4)
        for j in range(6):
            s[j] = s[j] + sixth * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])


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
        self.state = np.array([x, y, heading, vx, vy, yaw_rate], dtype=float)
        self.speed_floor = speed_floor
        self.max_step = max_step
        v = vehicle
        self._const = np.array([v.mass, v.yaw_inertia, v.lf, v.lr, v.cf, v.cr, v.drag,
                                v.half_track, speed_floor, max_step])
        # held inputs: delta (rad), Fa (N), dMz (N m), four wheel forces (N)
        self._inputs = np.zeros(7)

    def set_inputs(self, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Hold delta (rad) and the wheel forces (N); Fa by eq. 27, dMz by eq. 20."""
        bicycle_set_inputs(self._const, self._inputs, float(delta), *(float(f) for f in fx_cmd))

    def lateral_forces(self, s: list[float] | Array) -> tuple[float, float]:
        """N, (Fyf, Fyr) of eq. 17-18 at state s."""
        return bicycle_lateral_forces(np.asarray(s, dtype=float), self._const, self._inputs)

    def derivative(self, s: list[float] | Array) -> list[float]:
        """ds/dt: eq. 19 (lateral, yaw), eq. 26 (longitudinal), planar kinematics."""
        out = np.empty(6)
        bicycle_derivative(np.asarray(s, dtype=float), self._const, self._inputs, out)
        return out.tolist()

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds with held inputs (RK4, steps no longer than max_step)."""
        bicycle_step(self.state, self._const, self._inputs, float(h), float(delta),
                     *(float(f) for f in fx_cmd))

    def outputs(self) -> PlantOutputs:
        """Body accelerations (eq. 19, 26) and the held wheel forces."""
        v = self.vehicle
        vx = float(self.state[3])
        fyf, fyr = self.lateral_forces(self.state)
        _, fa, _, f1, f2, f3, f4 = self._inputs.tolist()
        return PlantOutputs(
            ax=(fa - v.drag * vx * abs(vx)) / v.mass,
            ay=(fyf + fyr) / v.mass,
            fx=(f1, f2, f3, f4),
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
