"""The paper's design model: 2-DOF linear single track (eq. 17-19) with the
longitudinal dynamics of eq. 26 and the yaw moment dMz as an input.

Wheel force demands enter through eq. 27 (Fa) and eq. 20 (dMz), so the plant
sees what the allocation (eq. 30) actually delivers. Tyres are linear and never
saturate: mu does not enter this model.

Down to a standstill (beyond the paper): slip angles divide by max(vx, speed_floor),
so they never blow up; a negative Fa is a brake, which opposes the motion and holds
a stopped car (it never drives it backwards); RK4 takes shorter steps when the
lateral modes, of rate ~ (Cf + Cr) / (M vx), get fast at low speed.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from cosim.compiled import Array, njit
from cosim.params import VehicleParams
from cosim.vehicle.plant import PlantOutputs, PlantStart

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
def bicycle_fa(s: Array, c: Array, inputs: Array) -> float:
    """N, the longitudinal force eq. 26 gets: Fa as held if >= 0 (drive); if < 0, a brake
    of size |Fa|: the force that would stop the car within 1 / c[11] seconds, at most
    |Fa| either way (so it holds a stopped car and never drives it backwards)."""
    fa = inputs[1]
    if fa >= 0.0:
        return fa
    m, drag = c[0], c[6]
    vx = s[3]
    needed = -m * (vx * c[11] + s[4] * s[5]) + drag * vx * abs(vx)
    return min(max(needed, fa), -fa)


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
    out[3] = vy * r + (bicycle_fa(s, c, inputs) - drag * vx * abs(vx)) / m
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
    than max_step nor 2 / the lateral modes' rate bound c[10] / max(|vx|, floor))."""
    bicycle_set_inputs(c, inputs, delta, f1, f2, f3, f4)
    vx = abs(s[3])
    limit = 2.0 * (vx if vx > c[8] else c[8]) / c[10]
    if limit > c[9]:
        limit = c[9]
    n = max(1, math.ceil(h / limit - 1e-9))
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
        start: PlantStart | None = None,
        *,
        speed_floor: float = 1.0,  # m/s, slip-angle denominators never below this
        max_step: float = 0.01,  # s, longest RK4 step (the lateral modes are slow)
    ) -> None:
        self.vehicle = vehicle
        st = start or PlantStart()
        self.state = np.array([st.x, st.y, st.heading, st.vx, st.vy, st.yaw_rate], dtype=float)
        self.speed_floor = speed_floor
        self.max_step = max_step
        v = vehicle
        # 10: bound on the lateral modes' rate times vx (trace of eq. 19's matrix times vx),
        # 11: 1 / the brake's hold time (max_step / 2: RK4-stable)
        self._const = np.array([v.mass, v.yaw_inertia, v.lf, v.lr, v.cf, v.cr, v.drag,
                                v.half_track, speed_floor, max_step,
                                (v.cf + v.cr) / v.mass
                                + (v.lf**2 * v.cf + v.lr**2 * v.cr) / v.yaw_inertia,
                                2.0 / max_step])
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
        fyf, fyr = bicycle_lateral_forces(self.state, self._const, self._inputs)
        fa = bicycle_fa(self.state, self._const, self._inputs)
        _, _, _, f1, f2, f3, f4 = self._inputs.tolist()
        return PlantOutputs(
            (fa - v.drag * vx * abs(vx)) / v.mass, (fyf + fyr) / v.mass, (f1, f2, f3, f4),
            (fyf / 2.0, fyf / 2.0, fyr / 2.0, fyr / 2.0), None,
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


NEUTRAL_GRADIENT = 1e-9  # s^2/m, |K| below this is neutral steer (rounding of Cf lr = Cr lf)


def critical_speed(vehicle: VehicleParams) -> float | None:
    """m/s at which an oversteering car's yaw gain V / (L + K V^2) becomes infinite
    (sqrt(-L / K)); None if it understeers or is neutral (no critical speed)."""
    k = understeer_gradient(vehicle)
    return math.sqrt(-vehicle.wheelbase / k) if k < -NEUTRAL_GRADIENT else None


def handling(vehicle: VehicleParams) -> str:
    """One line: the understeer gradient, what it means and the critical speed."""
    k = understeer_gradient(vehicle)
    vc = critical_speed(vehicle)
    if vc is not None:
        return (f"understeer gradient K = {k:.3g} rad/(m/s^2): the car oversteers, critical "
                f"speed {vc * 3.6:.0f} km/h (yaw gain V / (L + K V^2) unbounded there)")
    if k > NEUTRAL_GRADIENT:
        return (f"understeer gradient K = {k:.3g} rad/(m/s^2): the car understeers, "
                f"characteristic speed {math.sqrt(vehicle.wheelbase / k) * 3.6:.0f} km/h, "
                "no critical speed")
    return "understeer gradient K = 0: neutral steer (lf Cf = lr Cr), no critical speed"


def critical_speed_warning(vehicle: VehicleParams, speed: float, margin: float = 0.1
                           ) -> str | None:
    """The warning `cosim run` prints when a speed (m/s) the SV may drive comes within
    `margin` (10 %) of the car's critical speed; None when it does not."""
    vc = critical_speed(vehicle)
    if vc is None or speed < (1.0 - margin) * vc:
        return None
    return (f"warning: the SV may drive {speed * 3.6:.0f} km/h, within {margin:.0%} of its "
            f"car's critical speed {vc * 3.6:.0f} km/h (it oversteers: understeer gradient "
            f"{understeer_gradient(vehicle):.3g} rad/(m/s^2)); its yaw response grows without "
            "bound there")


def warn_near_critical_speed(scenario: Any) -> None:
    """Print `critical_speed_warning` (one line, stderr) for the highest speed a scenario
    lets its SV drive: its start speed, its desired speed, and the top of every lane's
    speed band (the planner's target speeds)."""
    sv = scenario.sv
    speeds = [sv.speed, *(hi for _, hi in scenario.road.speed_bands)]
    if sv.desired_speed is not None:
        speeds.append(sv.desired_speed)
    message = critical_speed_warning(scenario.vehicle, max(speeds))
    if message is not None:
        print(message, file=sys.stderr)
