"""Two-track validation plant (beyond the paper, which used veDYNA).

Four wheels with their own spin, nonlinear combined-slip tyres saturating at
mu Fz (`cosim.vehicle.tyre`), static and dynamic load transfer, aerodynamic drag
(Table 1's Ca), active front steering (both front wheels at delta) and one
torque per wheel (in-wheel motors / brakes). Wheels: 1 FL, 2 FR, 3 RL, 4 RR.

State (12): x, y, heading, vx, vy, yaw_rate, omega_1..4 (rad/s), and the body
accelerations ax_load, ay_load (m/s^2) that set the load transfer. They follow
the real accelerations through a first-order lag (`ChassisParams.load_lag`),
which stands for the body's pitch and roll and breaks the algebraic loop
between loads and forces.

The tyres' cornering stiffness is chosen per unit load so that each axle has
Table 1's Cf or Cr at the static load: at small slip this plant and the 2-DOF
model agree (tested through the steady-state yaw-rate gain).

Integration: fixed-step RK4. The wheel-spin mode is the stiff one, with time
constant Iw v / (C_kappa R^2) (about 2.7 ms at 25 m/s with the largest load
expected), so `step` splits a substep into RK4 steps no longer than
`step_factor` (2, inside RK4's real-axis stability limit 2.78) times that
constant and no longer than `max_step` (5 ms): one RK4 step per 5 ms substep at
highway speed, more at low speed. Against a 0.2 ms reference, a 3 s sine-steer
and drive/brake manoeuvre at 25 m/s ends within 1e-6 m and 1e-6 rad/s.

Speed: the derivative, the ABS / traction control and the RK4 loop are compiled
(numba, `cosim.compiled`) and work on float arrays in place; the closed
loop calls `twotrack_step` from its own compiled substep loop, the class methods
wrap the same functions for Python callers.
"""

from __future__ import annotations

import math

import numpy as np

from cosim.compiled import Array, njit
from cosim.errors import InputError
from cosim.params import G, VehicleParams
from cosim.vehicle.chassis import ChassisParams, static_wheel_loads
from cosim.vehicle.plant import PlantOutputs
from cosim.vehicle.tyre import magic_formula, peak_slip

STATE_NAMES = (
    "x", "y", "heading", "vx", "vy", "yaw_rate",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "ax_load", "ay_load",
)
N_CONST = 30  # length of the constants array (layout: `TwoTrackPlant.__init__`)


@njit
def twotrack_derivative(s: Array, c: Array, inputs: Array, forces: Array, out: Array) -> None:
    """ds/dt at state s into `out`; inputs = (cos delta, sin delta, four wheel torques);
    the accelerations and wheel forces (ax, ay, Fx1..4, Fy1..4, Fz1..4) into `forces`."""
    m, iz, lf, lr, ls, rad, floor = c[0], c[1], c[2], c[3], c[4], c[5], c[6]
    shape, inv_shape, ckm, mu, drag, iw, lag = c[7], c[8], c[9], c[10], c[11], c[12], c[13]
    kd_long, kd_lat_f, kd_lat_r, fz0f, fz0r, cafm, carm = (
        c[14], c[15], c[16], c[17], c[18], c[19], c[20])
    psi, vx, vy, r = s[2], s[3], s[4], s[5]
    w1, w2, w3, w4, axl, ayl = s[6], s[7], s[8], s[9], s[10], s[11]
    cd, sd = inputs[0], inputs[1]

    # vertical loads: static + longitudinal (pitch) + lateral (roll) transfer
    dlong = kd_long * axl
    dlat_f = kd_lat_f * ayl
    dlat_r = kd_lat_r * ayl
    fz1 = fz0f - dlong - dlat_f
    fz2 = fz0f - dlong + dlat_f
    fz3 = fz0r + dlong - dlat_r
    fz4 = fz0r + dlong + dlat_r
    # a lifted wheel carries nothing
    fz1 = fz1 if fz1 > 0.0 else 0.0
    fz2 = fz2 if fz2 > 0.0 else 0.0
    fz3 = fz3 if fz3 > 0.0 else 0.0
    fz4 = fz4 if fz4 > 0.0 else 0.0

    # wheel-centre velocities (body frame), then into each wheel's frame
    vl = vx - r * ls  # left wheels' body-x speed
    vr = vx + r * ls  # right wheels' body-x speed
    vyf = vy + r * lf
    vyr = vy - r * lr
    u1 = vl * cd + vyf * sd
    l1 = -vl * sd + vyf * cd
    u2 = vr * cd + vyf * sd
    l2 = -vr * sd + vyf * cd

    # tyres: normalised slips (stiffness / mu over the slip reference speed)
    ref = u1 if u1 > floor else (-u1 if -u1 > floor else floor)
    fx1, fy1 = magic_formula(ckm * (w1 * rad - u1) / ref, -cafm * l1 / ref, fz1, mu, shape,
                             inv_shape)
    ref = u2 if u2 > floor else (-u2 if -u2 > floor else floor)
    fx2, fy2 = magic_formula(ckm * (w2 * rad - u2) / ref, -cafm * l2 / ref, fz2, mu, shape,
                             inv_shape)
    ref = vl if vl > floor else (-vl if -vl > floor else floor)
    fx3, fy3 = magic_formula(ckm * (w3 * rad - vl) / ref, -carm * vyr / ref, fz3, mu, shape,
                             inv_shape)
    ref = vr if vr > floor else (-vr if -vr > floor else floor)
    fx4, fy4 = magic_formula(ckm * (w4 * rad - vr) / ref, -carm * vyr / ref, fz4, mu, shape,
                             inv_shape)

    # front forces into the body frame
    fxf = fx1 + fx2
    fyf = fy1 + fy2
    bx1 = fx1 * cd - fy1 * sd
    bx2 = fx2 * cd - fy2 * sd
    fx_body = fxf * cd - fyf * sd + fx3 + fx4
    fy_body = fxf * sd + fyf * cd + fy3 + fy4
    mz = (
        lf * (fxf * sd + fyf * cd)
        - lr * (fy3 + fy4)
        + ls * (bx2 - bx1 + fx4 - fx3)
    )
    ax = (fx_body - drag * vx * abs(vx)) / m
    ay = fy_body / m
    forces[0], forces[1] = ax, ay
    forces[2], forces[3], forces[4], forces[5] = fx1, fx2, fx3, fx4
    forces[6], forces[7], forces[8], forces[9] = fy1, fy2, fy3, fy4
    forces[10], forces[11], forces[12], forces[13] = fz1, fz2, fz3, fz4
    c_, sn = math.cos(psi), math.sin(psi)
    out[0] = vx * c_ - vy * sn
    out[1] = vx * sn + vy * c_
    out[2] = r
    out[3] = ax + vy * r
    out[4] = ay - vx * r
    out[5] = mz / iz
    out[6] = (inputs[2] - rad * fx1) / iw
    out[7] = (inputs[3] - rad * fx2) / iw
    out[8] = (inputs[4] - rad * fx3) / iw
    out[9] = (inputs[5] - rad * fx4) / iw
    out[10] = (ax - axl) / lag
    out[11] = (ay - ayl) / lag


@njit
def twotrack_time_constant(s: Array, c: Array) -> float:
    """s, fastest wheel-spin time constant Iw v / (C_kappa Fz R^2) at state s, with 20 %
    margin on the largest wheel load (loads move within a substep)."""
    half_track, floor, fz_max0, k_long, k_lat, scale = c[22], c[23], c[24], c[25], c[26], c[27]
    v = abs(s[3]) - half_track * abs(s[5])
    fz_max = fz_max0 + k_long * abs(s[10]) + k_lat * abs(s[11])
    return scale * (v if v > floor else floor) / fz_max


@njit
def twotrack_slip_limit(s: Array, c: Array, inputs: Array, forces: Array) -> None:
    """ABS / traction control on the torques inputs[2:6] (in place): a wheel whose
    longitudinal slip is past the peak of its tyre curve, in the direction its torque
    pushes, gets only the torque its tyre transmits (R Fx at the last evaluation), so it
    neither locks nor spins up. Slips are those of state s, forces those of the last
    derivative; inputs[0:2] = cos, sin of the steering angle."""
    vx, vy, r = s[3], s[4], s[5]
    ls, lf, rad, floor, peak = c[4], c[2], c[5], c[6], c[21]
    cd, sd = inputs[0], inputs[1]
    vyf = vy + r * lf
    vl, vr = vx - r * ls, vx + r * ls
    for i in range(4):
        if i == 0:
            u = vl * cd + vyf * sd
        elif i == 1:
            u = vr * cd + vyf * sd
        elif i == 2:
            u = vl
        else:
            u = vr
        t = inputs[2 + i]
        excess = s[6 + i] * rad - u  # slip speed
        limit = peak * (u if u > floor else (-u if -u > floor else floor))
        if (t > 0.0 and excess > limit) or (t < 0.0 and excess < -limit):
            transmitted = rad * forces[2 + i]
            inputs[2 + i] = min(t, transmitted) if t > 0.0 else max(t, transmitted)


@njit
def twotrack_step(s: Array, c: Array, inputs: Array, forces: Array, h: float, delta: float,
                  f1: float, f2: float, f3: float, f4: float) -> None:
    """Integrate state s (in place) h seconds: steering delta (rad), wheel torques R * f
    (N m) cut by `twotrack_slip_limit`; RK4 steps no longer than step_factor x the
    wheel-spin time constant and max_step."""
    rad = c[5]
    inputs[0], inputs[1] = math.cos(delta), math.sin(delta)
    inputs[2], inputs[3], inputs[4], inputs[5] = rad * f1, rad * f2, rad * f3, rad * f4
    twotrack_slip_limit(s, c, inputs, forces)
    max_step, step_factor = c[28], c[29]
    limit = step_factor * twotrack_time_constant(s, c)
    if limit > max_step:
        limit = max_step
    n = max(1, math.ceil(h / limit - 1e-9))
    hi = h / n
    half = 0.5 * hi
    sixth = hi / 6.0
    k1, k2, k3, k4 = np.empty(12), np.empty(12), np.empty(12), np.empty(12)
    tmp = np.empty(12)
    for _ in range(n):
        twotrack_derivative(s, c, inputs, forces, k1)
        for j in range(12):
            tmp[j] = s[j] + half * k1[j]
        twotrack_derivative(tmp, c, inputs, forces, k2)
        for j in range(12):
            tmp[j] = s[j] + half * k2[j]
        twotrack_derivative(tmp, c, inputs, forces, k3)
        for j in range(12):
            tmp[j] = s[j] + hi * k3[j]
        twotrack_derivative(tmp, c, inputs, forces, k4)
        for j in range(12):
            s[j] = s[j] + sixth * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])


class TwoTrackPlant:
    """Four-wheel planar vehicle with wheel spin, combined-slip tyres and load transfer."""

    kind = "twotrack"
    state_names = STATE_NAMES

    def __init__(
        self,
        vehicle: VehicleParams,
        mu: float,
        x: float = 0.0,
        y: float = 0.0,
        heading: float = 0.0,
        vx: float = 20.0,
        vy: float = 0.0,
        yaw_rate: float = 0.0,
        *,
        chassis: ChassisParams | None = None,
        max_step: float = 0.005,  # s, longest RK4 step
        step_factor: float = 2.0,  # -, RK4 step / wheel-spin time constant (RK4 stable to 2.78)
    ) -> None:
        if not 0.0 < mu <= 1.5:
            raise InputError("twotrack", "mu", mu, "road friction in (0, 1.5]")
        self.vehicle = vehicle
        self.chassis = chassis or ChassisParams()
        self.chassis.check()
        self.mu = mu
        self.max_step = max_step
        self.step_factor = step_factor
        ch = self.chassis
        self.wheel_radius = ch.wheel_radius
        self.fz0_front, self.fz0_rear = static_wheel_loads(vehicle)
        # cornering stiffness per unit load: the axle has Cf (Cr) at its static load
        # (times cornering_scale, 1 by default)
        self.c_alpha_front = ch.cornering_scale * vehicle.cf / (2.0 * self.fz0_front)
        self.c_alpha_rear = ch.cornering_scale * vehicle.cr / (2.0 * self.fz0_rear)
        dlat = vehicle.mass * ch.cg_height / (2.0 * vehicle.half_track)  # N per m/s^2
        # constants of the compiled functions (stiffnesses over mu: the normalised slips
        # of `cosim.vehicle.tyre`), then the ABS threshold and `twotrack_time_constant`'s
        self._const = np.array([
            vehicle.mass, vehicle.yaw_inertia, vehicle.lf, vehicle.lr, vehicle.half_track,
            ch.wheel_radius, ch.slip_speed_floor, ch.shape, 1.0 / ch.shape,
            ch.slip_stiffness / mu, mu, vehicle.drag, ch.wheel_inertia, ch.load_lag,
            vehicle.mass * ch.cg_height / (2.0 * vehicle.wheelbase),
            dlat * ch.roll_share_front, dlat * (1.0 - ch.roll_share_front),
            self.fz0_front, self.fz0_rear, self.c_alpha_front / mu, self.c_alpha_rear / mu,
            # 21: longitudinal slip at the peak of the pure-slip tyre curve (ABS / TCS)
            peak_slip(ch.shape) * mu / ch.slip_stiffness,
            # 22-27: wheel-spin time constant, loads with 20 % margin
            vehicle.half_track, ch.slip_speed_floor,
            1.2 * max(self.fz0_front, self.fz0_rear),
            1.2 * vehicle.mass * ch.cg_height / (2.0 * vehicle.wheelbase),
            1.2 * vehicle.mass * ch.cg_height / (2.0 * vehicle.half_track),
            ch.wheel_inertia / (ch.slip_stiffness * ch.wheel_radius**2),
            # 28, 29: RK4 step limits
            max_step, step_factor,
        ])
        assert self._const.size == N_CONST
        w0 = vx / ch.wheel_radius
        self.state = np.array([x, y, heading, vx, vy, yaw_rate, w0, w0, w0, w0, 0.0, 0.0],
                              dtype=float)
        self._delta = 0.0
        # held inputs: cos delta, sin delta, four wheel torques (N m)
        self._inputs = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        # ax, ay, Fx1..4, Fy1..4, Fz1..4 at the last derivative evaluation
        self._forces = np.zeros(14)

    # -- dynamics --------------------------------------------------------------
    def derivative(self, s: list[float] | Array) -> list[float]:
        """ds/dt at state s with the held steering angle and wheel torques."""
        out = np.empty(12)
        twotrack_derivative(np.asarray(s, dtype=float), self._const, self._inputs,
                            self._forces, out)
        return out.tolist()

    def wheel_time_constant(self) -> float:
        """s, fastest wheel-spin time constant Iw v / (C_kappa Fz R^2) at the current state,
        with 20 % margin on the largest wheel load (loads move within a substep)."""
        return float(twotrack_time_constant(self.state, self._const))

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds: steering delta (rad), wheel torques R * fx_cmd (N m), cut
        by the ABS / traction control of `twotrack_slip_limit`."""
        self._delta = delta
        f1, f2, f3, f4 = (float(f) for f in fx_cmd)
        twotrack_step(self.state, self._const, self._inputs, self._forces, float(h),
                      float(delta), f1, f2, f3, f4)

    def outputs(self) -> PlantOutputs:
        """Accelerations and tyre forces at the current state."""
        self.derivative(self.state)
        f = self._forces.tolist()
        return PlantOutputs(
            ax=f[0], ay=f[1], fx=(f[2], f[3], f[4], f[5]), fy=(f[6], f[7], f[8], f[9]),
            fz=(f[10], f[11], f[12], f[13]),
        )

    def max_lateral_acceleration(self) -> float:
        """m/s^2, the friction limit mu g."""
        return self.mu * G

